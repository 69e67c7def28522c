//! The figures: well-formed SVG with the expected elements and text, PNGs that decode at the
//! right size and are not blank, identical bytes for identical input, and `plot_csv` on plan,
//! sweep and bad CSVs. Set SPHERESTEP_KEEP_PLOTS=DIR to keep the pictures for a look.

use spherestep::figures::{
    plot_csv, render_svg, write_figure, AxisErrorPlot, CommutationPlot, ErrorSeries, Figure,
    ReferenceLine, SweepMap, View3d,
};
use spherestep::model::geometry::Pair;
use spherestep::model::packing::{prototype_rotor, prototype_stator};
use std::path::{Path, PathBuf};

fn count(svg: &str, tag: &str) -> usize {
    svg.matches(&format!("<{tag} ")).count()
}

/// Polylines stroked in `color`.
fn polylines(svg: &str, color: &str) -> usize {
    svg.split("<polyline")
        .skip(1)
        .filter(|p| p.contains(&format!("stroke=\"{color}\"")))
        .count()
}

/// Polylines stroked in `color` with width `w`.
fn polylines_w(svg: &str, color: &str, w: u32) -> usize {
    svg.split("<polyline")
        .skip(1)
        .filter(|p| {
            p.contains(&format!("stroke=\"{color}\""))
                && p.contains(&format!("stroke-width=\"{w}\""))
        })
        .count()
}

/// Coarse well-formedness: one svg root, every element closed, tags balanced.
fn assert_well_formed(svg: &str) {
    assert!(svg.trim_start().starts_with("<svg"), "starts with <svg");
    assert!(svg.trim_end().ends_with("</svg>"), "ends with </svg>");
    let mut stack: Vec<String> = Vec::new();
    let mut rest = svg;
    while let Some(i) = rest.find('<') {
        rest = &rest[i + 1..];
        let end = rest.find('>').expect("unclosed tag");
        let tag = &rest[..end];
        rest = &rest[end + 1..];
        if tag.starts_with('?') || tag.starts_with('!') {
            continue;
        }
        if let Some(name) = tag.strip_prefix('/') {
            assert_eq!(stack.pop().as_deref(), Some(name.trim()), "balanced tags");
        } else if !tag.ends_with('/') {
            let name = tag.split_whitespace().next().unwrap_or("").to_string();
            stack.push(name);
        }
    }
    assert!(stack.is_empty(), "unclosed elements: {stack:?}");
    assert!(
        !svg.contains("NaN") && !svg.contains("inf"),
        "no NaN/inf in the SVG"
    );
}

fn texts(svg: &str) -> Vec<String> {
    svg.split("<text")
        .skip(1)
        .filter_map(|t| {
            let start = t.find('>')? + 1;
            let end = t.find("</text>")?;
            Some(t[start..end].trim().to_string())
        })
        .collect()
}

fn has_text(svg: &str, s: &str) -> bool {
    texts(svg).iter().any(|t| t == s)
}

/// Writes the figure twice, checks identical bytes, decodes the PNG; returns (svg, png).
fn write_and_check<F: Figure>(fig: &F, name: &str) -> (String, image::RgbImage) {
    let dir = tempfile::tempdir().unwrap();
    let a = write_figure(fig, &dir.path().join(name)).unwrap();
    let first: Vec<Vec<u8>> = a.iter().map(|p| std::fs::read(p).unwrap()).collect();
    let b = write_figure(fig, &dir.path().join(name)).unwrap();
    assert_eq!(a, b);
    let second: Vec<Vec<u8>> = b.iter().map(|p| std::fs::read(p).unwrap()).collect();
    assert!(first == second, "{name}: same input, same bytes");
    assert_eq!(a[0].file_name().unwrap(), format!("{name}.svg").as_str());
    assert_eq!(a[1].file_name().unwrap(), format!("{name}.png").as_str());
    // No temporary files left.
    let names: Vec<_> = std::fs::read_dir(dir.path())
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    assert_eq!(names.len(), 2, "{names:?}");
    let img = image::open(&a[1]).unwrap().to_rgb8();
    assert_eq!((img.width(), img.height()), fig.size());
    let ink = img.pixels().filter(|p| p.0 != [255, 255, 255]).count();
    let total = (img.width() * img.height()) as usize;
    assert!(
        ink > total / 100,
        "{name}: PNG nearly blank ({ink} of {total})"
    );
    // Text was rendered: dark grey-to-black pixels exist (titles, labels).
    let dark = img.pixels().filter(|p| p.0.iter().all(|c| *c < 80)).count();
    assert!(dark > 200, "{name}: no text/axes drawn ({dark})");
    let svg = String::from_utf8(first[0].clone()).unwrap();
    assert_eq!(svg, render_svg(fig).unwrap());
    if let Some(keep) = std::env::var_os("SPHERESTEP_KEEP_PLOTS") {
        let keep = PathBuf::from(keep);
        std::fs::create_dir_all(&keep).unwrap();
        write_figure(fig, &keep.join(name)).unwrap();
    }
    (svg, img)
}

fn v3(p: &nalgebra::Unit<nalgebra::Vector3<f64>>) -> [f64; 3] {
    [p.x, p.y, p.z]
}

/// The prototype at rest: magnets of the bottom hemisphere, candidates within 25 degrees.
fn commutation() -> CommutationPlot {
    let rotor = prototype_rotor();
    let stator = prototype_stator();
    let magnets: Vec<(usize, [f64; 2])> = rotor
        .points
        .iter()
        .enumerate()
        .filter(|(_, p)| p.z < 0.0)
        .map(|(j, p)| (j, [p.x, p.y]))
        .collect();
    let mut candidates = Vec::new();
    for (i, s) in stator.points.iter().enumerate() {
        for (j, _) in &magnets {
            let d = s
                .dot(&rotor.points[*j])
                .clamp(-1.0, 1.0)
                .acos()
                .to_degrees();
            if d < 25.0 && d > 1e-6 {
                candidates.push(Pair::new(i, *j));
            }
        }
    }
    assert!(candidates.len() >= 3);
    let chosen = vec![candidates[0], candidates[candidates.len() - 1]];
    CommutationPlot {
        title: "Initial commutation state (prototype, identity)".into(),
        coils: stator.points.iter().map(|p| [p.x, p.y]).collect(),
        magnets,
        candidates,
        chosen,
    }
}

#[test]
fn figure5_commutation_state() {
    let fig = commutation();
    let (svg, _) = write_and_check(&fig, "figure5");
    assert_well_formed(&svg);
    // Polylines by colour: a '+' is two strokes, a '*' three, a pair's line one; each legend
    // entry draws its own sample once more.
    assert_eq!(polylines(&svg, "#1F77B4"), 2 * fig.coils.len() + 2, "coils");
    assert_eq!(
        polylines(&svg, "#C81E1E"),
        3 * fig.magnets.len() + 3,
        "magnets"
    );
    assert_eq!(
        polylines(&svg, "#969696"),
        fig.candidates.len() + 1,
        "candidates"
    );
    assert_eq!(
        polylines_w(&svg, "#000000", 2),
        fig.chosen.len() + 1,
        "chosen pairs"
    );
    // Boxes: two per chosen pair and one in the legend, plus the background and the legend's
    // fill and frame.
    assert_eq!(count(&svg, "rect"), 2 * fig.chosen.len() + 1 + 3);
    for t in [
        "world x (seen from +Z, above the ball, through it)",
        "world y",
        "candidate pair",
        "chosen pair (boxed)",
        "stator coil (+)",
        "rotor magnet, z &lt; 0 (*)",
        "Initial commutation state (prototype, identity)",
    ] {
        assert!(has_text(&svg, t), "text `{t}` in {:?}", texts(&svg));
    }
    // Every coil and magnet is labelled with its index.
    for (j, _) in &fig.magnets {
        assert!(has_text(&svg, &j.to_string()));
    }
}

fn view3d() -> View3d {
    let rotor = prototype_rotor();
    let stator = prototype_stator();
    let f5 = commutation();
    View3d {
        title: "Model output (3-D view)".into(),
        coils: stator.points.iter().map(v3).collect(),
        magnets: rotor.points.iter().map(v3).enumerate().collect(),
        active: f5.chosen.clone(),
        desired_axis: [0.0, 0.0, 1.0],
        actual_axis: Some([0.12, -0.05, 0.99]),
    }
}

#[test]
fn figure6_view3d() {
    let fig = view3d();
    let (svg, _) = write_and_check(&fig, "figure6");
    assert_well_formed(&svg);
    // Every magnet is a disk, plus the magnet legend entry.
    assert_eq!(count(&svg, "circle"), fig.magnets.len() + 1);
    for t in [
        "desired axis",
        "actual axis",
        "active pair",
        "stator coil (+)",
        "world x",
        "world y",
        "world z",
    ] {
        assert!(has_text(&svg, t), "text `{t}`");
    }
    // Without the actual axis, its arrow and legend entry are gone.
    let mut no_actual = fig.clone();
    no_actual.actual_axis = None;
    let svg2 = render_svg(&no_actual).unwrap();
    assert!(!has_text(&svg2, "actual axis"));
}

fn axis_error() -> AxisErrorPlot {
    let series = |name: &str, k: f64| ErrorSeries {
        name: name.into(),
        points: (0..=12)
            .map(|s| {
                let a = s as f64 * 7.5;
                (a, k * (a / 10.0).sin().abs() + 0.1 * s as f64)
            })
            .collect(),
    };
    AxisErrorPlot {
        title: "Axis error vs. rotation angle (Y axis)".into(),
        series: vec![
            series("weighted", 9.0),
            series("min axis error", 6.0),
            series("max angle", 13.0),
        ],
        reference: Some(ReferenceLine {
            label: "paper: 15 deg".into(),
            value_deg: 15.0,
        }),
        target_deg: Some(90.0),
    }
}

#[test]
fn figure7_axis_error() {
    let fig = axis_error();
    let (svg, _) = write_and_check(&fig, "figure8");
    assert_well_formed(&svg);
    for t in [
        "cumulative rotation angle (deg)",
        "cumulative axis error (deg)",
        "weighted",
        "min axis error",
        "max angle",
        "paper: 15 deg",
        "target 90 deg",
        "Axis error vs. rotation angle (Y axis)",
    ] {
        assert!(has_text(&svg, t), "text `{t}`");
    }
    // Each series' markers are drawn in its colour: one outline per point, plus its legend's.
    for (k, s) in fig.series.iter().enumerate() {
        let c = spherestep::figures::series_style(k).color;
        let hex = format!("#{:02X}{:02X}{:02X}", c.0, c.1, c.2);
        assert!(
            polylines_w(&svg, &hex, 2) > s.points.len(),
            "series {k} ({hex}): a marker per point and in the legend"
        );
    }
    // Without a reference line, no legend entry for it.
    let mut plain = fig.clone();
    plain.reference = None;
    assert!(!has_text(&render_svg(&plain).unwrap(), "paper: 15 deg"));
}

/// `n` axes spread over the sphere (a Fibonacci lattice) with a smooth made-up value.
fn sweep_points(n: usize) -> Vec<([f64; 3], f64)> {
    let golden = std::f64::consts::PI * (3.0 - 5f64.sqrt());
    (0..n)
        .map(|k| {
            let z = 1.0 - 2.0 * (k as f64 + 0.5) / n as f64;
            let r = (1.0 - z * z).sqrt();
            let a = golden * k as f64;
            let axis = [r * a.cos(), r * a.sin(), z];
            (axis, 15.0 * (1.0 - z.abs()) + 2.0 * a.cos().abs())
        })
        .collect()
}

#[test]
fn sweep_map() {
    let mut fig = SweepMap {
        title: "Worst axis error over the sphere of axes (weighted)".into(),
        value_label: "worst axis error (deg)".into(),
        points: sweep_points(500),
        range: None,
        unreached: Vec::new(),
        coils: Vec::new(),
    };
    let (svg, img) = write_and_check(&fig, "sweep");
    assert_well_formed(&svg);
    assert_eq!(count(&svg, "circle"), 500);
    for t in [
        "axis longitude atan2(y, x) (deg)",
        "axis latitude asin(z) (deg)",
        "worst axis error (deg)",
    ] {
        assert!(has_text(&svg, t), "text `{t}`");
    }
    // The colours span the scale: the PNG holds both ends' hues.
    let near = |c: [u8; 3]| {
        img.pixels().any(|p| {
            p.0.iter()
                .zip(c)
                .all(|(a, b)| (*a as i32 - b as i32).abs() < 12)
        })
    };
    assert!(near([68, 1, 84]) && near([253, 231, 37]));
    // Missing values are rings with a legend entry.
    fig.points[0].1 = f64::NAN;
    fig.points[1].1 = f64::NAN;
    let svg = render_svg(&fig).unwrap();
    assert_well_formed(&svg);
    assert!(has_text(&svg, "no result"));
    assert_eq!(count(&svg, "circle"), 500 + 1);
}

#[test]
fn bad_data_is_an_error() {
    let mut f5 = commutation();
    f5.chosen.push(Pair::new(99, 0));
    let e = render_svg(&f5).unwrap_err().to_string();
    assert!(e.contains("99"), "{e}");
    let mut f6 = view3d();
    f6.desired_axis = [0.0; 3];
    assert!(render_svg(&f6).is_err());
    let mut f7 = axis_error();
    f7.series[0].points.push((f64::NAN, 1.0));
    assert!(render_svg(&f7).is_err());
    let dir = tempfile::tempdir().unwrap();
    let e = write_figure(&f7, &dir.path().join("x"))
        .unwrap_err()
        .to_string();
    assert!(e.contains("x.svg") && e.contains("plotting failed"), "{e}");
    let map = SweepMap {
        title: "t".into(),
        value_label: "v".into(),
        points: vec![([0.0, 0.0, 0.0], 1.0)],
        range: None,
        unreached: Vec::new(),
        coils: Vec::new(),
    };
    assert!(render_svg(&map).is_err());
}

const PLAN: &str = "step,pivot_coil,pivot_magnet,new_coil,new_magnet,active,qx,qy,qz,qw,step_angle_deg,step_axis_error_deg,cum_angle_deg,cum_axis_error_deg,settle_time_s
0,,,0;14,34;9,0:34;14:9,0,0,0,1,0,0,0,0,0.1
1,0,34,3,7,0:34;3:7,0,0,0.1,0.995,11.5,0.5,11.5,0.5,0.2
2,0,34,5,8,0:34;5:8,0,0,0.2,0.98,11,1.2,22.5,1.1,0.2
3,0,34,6,2,0:34;6:2,0,0,0.3,0.954,12,0.4,34.5,0.9,0.2
";

fn write(dir: &Path, name: &str, text: &str) -> PathBuf {
    let p = dir.join(name);
    std::fs::write(&p, text).unwrap();
    p
}

#[test]
fn plot_csv_plan() {
    let dir = tempfile::tempdir().unwrap();
    let csv = write(dir.path(), "plan_z.csv", PLAN);
    let files = plot_csv(&csv, None, None).unwrap();
    assert_eq!(
        files,
        vec![dir.path().join("plan_z.svg"), dir.path().join("plan_z.png")]
    );
    let svg = std::fs::read_to_string(&files[0]).unwrap();
    assert_well_formed(&svg);
    // A marker per step (4) and in the legend, in the first series' colour.
    let c = spherestep::figures::series_style(0).color;
    let hex = format!("#{:02X}{:02X}{:02X}", c.0, c.1, c.2);
    assert_eq!(polylines_w(&svg, &hex, 2), 4 + 1);
    assert!(has_text(&svg, "plan_z"));
    assert!(has_text(&svg, "axis error vs. rotation angle: plan_z"));
    let out = dir.path().join("pics");
    let files = plot_csv(&csv, Some(&out), Some("About Z")).unwrap();
    assert_eq!(files[0], out.join("plan_z.svg"));
    assert!(has_text(
        &std::fs::read_to_string(&files[0]).unwrap(),
        "About Z"
    ));
    image::open(&files[1]).unwrap();
}

#[test]
fn plot_csv_sweep_per_scheme() {
    let dir = tempfile::tempdir().unwrap();
    let mut text = String::from("scheme,axis_x,axis_y,axis_z,max_axis_error_deg,reached\n");
    for scheme in ["weighted", "min/error"] {
        for (a, v) in sweep_points(60) {
            text += &format!("{scheme},{},{},{},{v},true\n", a[0], a[1], a[2]);
        }
    }
    text += "weighted,1,0,0,NaN,false\n";
    let csv = write(dir.path(), "sweep.csv", &text);
    let files = plot_csv(&csv, None, None).unwrap();
    let names: Vec<_> = files
        .iter()
        .map(|f| f.file_name().unwrap().to_string_lossy().into_owned())
        .collect();
    assert_eq!(
        names,
        [
            "sweep_weighted.svg",
            "sweep_weighted.png",
            "sweep_min_error.svg",
            "sweep_min_error.png"
        ]
    );
    let svg = std::fs::read_to_string(&files[0]).unwrap();
    assert_eq!(count(&svg, "circle"), 61 + 1);
    assert!(has_text(
        &svg,
        "worst axis error over the sphere of axes: sweep, scheme weighted"
    ));
    // Without a scheme column: one map named after the file.
    let csv = write(
        dir.path(),
        "one.csv",
        "axis_x,axis_y,axis_z,max_axis_error_deg\n0,0,1,2.5\n1,0,0,14\n0,1,0,12\n",
    );
    let files = plot_csv(&csv, None, Some("t")).unwrap();
    assert_eq!(files[0], dir.path().join("one.svg"));
}

#[test]
fn plot_csv_errors() {
    let dir = tempfile::tempdir().unwrap();
    let missing = dir.path().join("missing.csv");
    let e = plot_csv(&missing, None, None).unwrap_err().to_string();
    assert!(e.contains("missing.csv"), "{e}");
    let odd = write(dir.path(), "odd.csv", "a,b,c\n1,2,3\n");
    let e = plot_csv(&odd, None, None).unwrap_err().to_string();
    assert!(
        e.contains("odd.csv")
            && e.contains("a, b, c")
            && e.contains("cum_axis_error_deg")
            && e.contains("max_axis_error_deg"),
        "{e}"
    );
    let empty = write(dir.path(), "empty.csv", "");
    let e = plot_csv(&empty, None, None).unwrap_err().to_string();
    assert!(e.contains("empty.csv") && e.contains("no columns"), "{e}");
    let binary = dir.path().join("bin.csv");
    std::fs::write(&binary, [0xff, 0xfe, 0x00, 0x81, b'\n']).unwrap();
    assert!(plot_csv(&binary, None, None).is_err());
    let bad_row = write(
        dir.path(),
        "bad.csv",
        "axis_x,axis_y,axis_z,max_axis_error_deg\n0,0,1,2.5\n0,zz,0,1\n",
    );
    let e = plot_csv(&bad_row, None, None).unwrap_err().to_string();
    assert!(e.contains("bad.csv: line 3") && e.contains("axis_y"), "{e}");
    let zero = write(
        dir.path(),
        "zero.csv",
        "axis_x,axis_y,axis_z,max_axis_error_deg\n0,0,0,2.5\n",
    );
    assert!(plot_csv(&zero, None, None).is_err());
    let header_only = write(
        dir.path(),
        "h.csv",
        "axis_x,axis_y,axis_z,max_axis_error_deg\n",
    );
    assert!(plot_csv(&header_only, None, None).is_err());
    let broken_plan = write(dir.path(), "p.csv", &PLAN.replace("11.5,0.5", "x,0.5"));
    let e = plot_csv(&broken_plan, None, None).unwrap_err().to_string();
    assert!(e.contains("p.csv: line 3"), "{e}");
    // Nothing was written for the failures.
    let pics = std::fs::read_dir(dir.path())
        .unwrap()
        .filter(|e| {
            let n = e.as_ref().unwrap().file_name();
            let n = n.to_string_lossy();
            n.ends_with(".svg") || n.ends_with(".png")
        })
        .count();
    assert_eq!(pics, 0);
}

/// Values of +-1e308 gave the colour scale an infinite span, and drawing
/// never finished; they are refused (by the map and by `plot`), naming the line.
#[test]
fn huge_sweep_values_are_refused_not_drawn_for_ever() {
    for values in [[1e308, -1e308], [f64::INFINITY, 3.0], [1e300, 0.0]] {
        let map = SweepMap {
            title: "t".into(),
            value_label: "v".into(),
            points: vec![([1.0, 0.0, 0.0], values[0]), ([0.0, 1.0, 0.0], values[1])],
            range: None,
            unreached: Vec::new(),
            coils: Vec::new(),
        };
        let e = render_svg(&map).unwrap_err();
        assert!(e.0.contains("sweep map: expected"), "{}", e.0);
    }
    let dir = tempfile::tempdir().unwrap();
    let csv = write(
        dir.path(),
        "huge.csv",
        "axis_x,axis_y,axis_z,max_axis_error_deg\n0,0,1,5\n1,0,0,1e308\n0,1,0,-1e308\n",
    );
    let e = plot_csv(&csv, None, None).unwrap_err().to_string();
    assert!(
        e.contains("huge.csv: line 3")
            && e.contains("max_axis_error_deg")
            && e.contains("0 to 180"),
        "{e}"
    );
    assert!(!dir.path().join("huge.png").exists());
}

/// Every series of a scheme figure has its own colour (colour-blind safe),
/// marker and dash, so identical series stay visible; a zero-error series is lifted off the
/// frame; the labels say "cumulative"; the target is marked.
#[test]
fn scheme_figures_tell_their_series_apart() {
    use spherestep::figures::{series_style, SERIES_COLORS};
    let styles: Vec<_> = (0..4).map(series_style).collect();
    for a in 0..styles.len() {
        for b in a + 1..styles.len() {
            let (x, y) = (styles[a], styles[b]);
            assert!(
                x.color != y.color && x.marker != y.marker && x.dash != y.dash,
                "series {a} and {b} share a colour, marker or dash"
            );
        }
    }
    // Okabe-Ito, no pure red or green: no two colours differ only in red against green.
    for c in SERIES_COLORS {
        assert!(
            {
                let red = c.0 > 150 && c.1 < 60 && c.2 < 60;
                let green = c.1 > 150 && c.0 < 60 && c.2 < 60;
                !red && !green
            },
            "{c:?}"
        );
    }
    let same = ErrorSeries {
        name: "a".into(),
        points: vec![(0.0, 0.0), (30.0, 0.0), (60.0, 0.0), (90.0, 0.0)],
    };
    let fig = AxisErrorPlot {
        title: "three identical schemes".into(),
        series: ["a", "b", "c"]
            .iter()
            .map(|n| ErrorSeries {
                name: n.to_string(),
                ..same.clone()
            })
            .collect(),
        reference: None,
        target_deg: Some(90.0),
    };
    let r = fig.y_range();
    assert!(
        r.start < 0.0 && r.end > 0.0,
        "zero errors above the frame: {r:?}"
    );
    let svg = render_svg(&fig).unwrap();
    assert_well_formed(&svg);
    assert!(has_text(&svg, "target 90 deg"));
    // Each of the three identical series shows: a marker per point in its own colour (and
    // one in the legend).
    for k in 0..3 {
        let c = series_style(k).color;
        let hex = format!("#{:02X}{:02X}{:02X}", c.0, c.1, c.2);
        assert_eq!(polylines_w(&svg, &hex, 2), 4 + 1, "series {k}");
    }
}

/// The SVGs name the bundled font, not just a generic family.
#[test]
fn svgs_name_the_bundled_font() {
    let svg = render_svg(&axis_error()).unwrap();
    let families: Vec<&str> = svg
        .split("font-family=\"")
        .skip(1)
        .map(|r| r.split('"').next().unwrap())
        .collect();
    assert!(!families.is_empty());
    for f in families {
        assert!(f.starts_with("DejaVu Sans"), "font-family {f}");
    }
}

/// A sweep's maps (one per scheme) share one colour scale, so that they
/// can be compared: the same colour bar whatever each scheme's own range.
#[test]
fn a_sweeps_maps_share_one_colour_scale() {
    let dir = tempfile::tempdir().unwrap();
    let mut text = String::from("scheme,axis_x,axis_y,axis_z,max_axis_error_deg\n");
    for (scheme, scale) in [("small", 1.0), ("large", 4.0)] {
        for (a, v) in sweep_points(40) {
            text += &format!("{scheme},{},{},{},{}\n", a[0], a[1], a[2], v * scale);
        }
    }
    let csv = write(dir.path(), "sw.csv", &text);
    let files = plot_csv(&csv, None, Some("t")).unwrap();
    let bar = |f: &PathBuf| -> Vec<String> {
        // Every text but the title (which names the scheme).
        texts(&std::fs::read_to_string(f).unwrap())
            .into_iter()
            .filter(|t| !t.contains("scheme"))
            .collect()
    };
    let (a, b) = (bar(&files[0]), bar(&files[2]));
    assert!(a.len() > 10, "{a:?}");
    assert_eq!(a, b, "one colour bar for both maps");
}

/// A label and its box (x0, y0, x1, y1) in pixels.
type NamedBox = (String, (i32, i32, i32, i32));

/// The SVG `<text ` elements: (attributes, content).
fn text_elements(svg: &str) -> Vec<(String, String)> {
    svg.split("<text ")
        .skip(1)
        .filter_map(|t| {
            let (attrs, rest) = t.split_once('>')?;
            let body = rest.split("</text>").next()?.trim().to_string();
            Some((format!(" {attrs}"), body))
        })
        .collect()
}

fn attr<'a>(attrs: &'a str, k: &str) -> Option<&'a str> {
    attrs.split(&format!(" {k}=\"")).nth(1)?.split('"').next()
}

/// The boxes (x0, y0, x1, y1) of the labels `wanted` (content, pixel size) of an SVG, drawn
/// from their top left and sized as `label_size` says; each must be there.
fn label_boxes(svg: &str, wanted: &[(String, u32)]) -> Vec<NamedBox> {
    let els = text_elements(svg);
    wanted
        .iter()
        .map(|(body, px)| {
            let (a, _) = els
                .iter()
                .find(|(a, b)| b == body && attr(a, "text-anchor") == Some("start"))
                .unwrap_or_else(|| panic!("label {body} drawn from its top left"));
            let x = attr(a, "x").unwrap().parse::<f64>().unwrap() as i32;
            let y = attr(a, "y").unwrap().parse::<f64>().unwrap() as i32;
            let (w, h) = spherestep::figures::label_size(body, *px);
            (body.clone(), (x, y, x + w, y + h))
        })
        .collect()
}

fn assert_apart(boxes: &[NamedBox]) {
    for (i, (a, p)) in boxes.iter().enumerate() {
        for (b, q) in &boxes[i + 1..] {
            let apart = p.2 <= q.0 || q.2 <= p.0 || p.3 <= q.1 || q.3 <= p.1;
            assert!(apart, "labels {a} {p:?} and {b} {q:?} overlap");
        }
    }
}

/// Figure 5's coil and magnet numbers never overlap each other.
#[test]
fn figure5_labels_do_not_overlap() {
    let fig = commutation();
    let svg = render_svg(&fig).unwrap();
    // Coil and magnet numbers may repeat (coil 3, magnet 3): each is found once per kind.
    let els = text_elements(&svg);
    let mut boxes = Vec::new();
    for (color, names) in [
        ("#1F77B4", (0..fig.coils.len()).collect::<Vec<_>>()),
        ("#C81E1E", fig.magnets.iter().map(|m| m.0).collect()),
    ] {
        for n in names {
            let (a, _) = els
                .iter()
                .find(|(a, b)| *b == n.to_string() && attr(a, "fill") == Some(color))
                .unwrap_or_else(|| panic!("label {n} in {color}"));
            assert_eq!(attr(a, "text-anchor"), Some("start"));
            let x = attr(a, "x").unwrap().parse::<f64>().unwrap() as i32;
            let y = attr(a, "y").unwrap().parse::<f64>().unwrap() as i32;
            let (w, h) = spherestep::figures::label_size(&n.to_string(), 12);
            boxes.push((format!("{color} {n}"), (x, y, x + w, y + h)));
        }
    }
    assert_apart(&boxes);
}

/// Figure 6's labels (coils, world axes, rotation axes) never overlap.
#[test]
fn figure6_labels_do_not_overlap() {
    let fig = view3d();
    let svg = render_svg(&fig).unwrap();
    let mut wanted: Vec<(String, u32)> =
        (0..fig.coils.len()).map(|i| (i.to_string(), 12)).collect();
    for t in [
        "world x",
        "world y",
        "world z",
        "desired axis",
        "actual axis",
    ] {
        wanted.push((t.to_string(), 16));
    }
    let boxes = label_boxes(&svg, &wanted);
    assert_apart(&boxes);
    // All inside the picture (drawn larger now: no wide blank margin, nothing cut off).
    let (w, h) = fig.size();
    for (t, b) in &boxes {
        assert!(
            b.0 >= 0 && b.1 >= 0 && b.2 <= w as i32 && b.3 <= h as i32,
            "{t} {b:?}"
        );
    }
}

#[test]
fn place_labels_avoids_taken_places() {
    use spherestep::figures::place_labels;
    // Three points in a row, 12 px apart: no two boxes meet, none covers a mark.
    let at = [(100, 100), (112, 100), (124, 100)];
    let sizes = [(16, 12); 3];
    let marks: Vec<_> = at.iter().map(|p| (*p, 6)).collect();
    let off = place_labels(&at, &sizes, &marks);
    let boxes: Vec<_> = at
        .iter()
        .zip(&off)
        .map(|(p, o)| (p.0 + o.0, p.1 + o.1, p.0 + o.0 + 16, p.1 + o.1 + 12))
        .collect();
    let meet = |a: &(i32, i32, i32, i32), b: &(i32, i32, i32, i32)| {
        !(a.2 <= b.0 || b.2 <= a.0 || a.3 <= b.1 || b.3 <= a.1)
    };
    for (i, a) in boxes.iter().enumerate() {
        for b in &boxes[i + 1..] {
            assert!(!meet(a, b), "{boxes:?}");
        }
        for (m, r) in &marks {
            assert!(
                !meet(a, &(m.0 - r, m.1 - r, m.0 + r, m.1 + r)),
                "{a:?} on {m:?}"
            );
        }
    }
}

/// A sweep map marks the cases that did not reach their target and draws
/// the coil directions its text explains it by.
#[test]
fn sweep_maps_mark_unreached_cases_and_coil_axes() {
    let dir = tempfile::tempdir().unwrap();
    let mut text = String::from("scheme,axis_x,axis_y,axis_z,max_axis_error_deg,reached\n");
    let pts = sweep_points(30);
    for (k, (a, v)) in pts.iter().enumerate() {
        let reached = k % 10 != 3;
        text += &format!("w,{},{},{},{v},{reached}\n", a[0], a[1], a[2]);
    }
    let csv = write(dir.path(), "sw.csv", &text);
    let coils = [[0.0, 0.0, -1.0], [0.5, 0.0, -0.8]];
    let files = spherestep::figures::plot_csv_with_coils(&csv, None, Some("t"), &coils).unwrap();
    let svg = std::fs::read_to_string(&files[0]).unwrap();
    assert!(has_text(&svg, "not reached") && has_text(&svg, "coil axis"));
    // A cross is two black strokes of width 2: three unreached cases and the key's.
    let crosses = svg
        .matches("<line opacity=\"1\" stroke=\"#000000\" stroke-width=\"2\"")
        .count();
    assert_eq!(crosses, 2 * 3 + 2);
    // A '+' at both ends of each coil's line (two strokes each), and the key's.
    assert_eq!(polylines_w(&svg, "#1F77B4", 2), 2 * 2 * coils.len() + 2);
    // Without a reached column or coils: neither.
    let plain = write(
        dir.path(),
        "plain.csv",
        "axis_x,axis_y,axis_z,max_axis_error_deg\n0,0,1,2.5\n1,0,0,14\n",
    );
    let svg = std::fs::read_to_string(&plot_csv(&plain, None, None).unwrap()[0]).unwrap();
    assert!(!has_text(&svg, "not reached") && !has_text(&svg, "coil axis"));
}

/// The text elements of an SVG with their `x` and `y` attributes.
fn placed_texts(svg: &str) -> Vec<(String, String, String)> {
    svg.split("<text")
        .skip(1)
        .filter_map(|t| {
            let attr = |name: &str| {
                let k = t.find(&format!(" {name}=\""))? + name.len() + 3;
                Some(t[k..k + t[k..].find('"')?].to_string())
            };
            let start = t.find('>')? + 1;
            let end = t.find("</text>")?;
            Some((t[start..end].trim().to_string(), attr("x")?, attr("y")?))
        })
        .collect()
}

/// A run's step axis (`plot` of a run CSV) is labelled with whole steps,
/// each once, however few the steps.
#[test]
fn loop_plot_labels_its_steps_with_whole_numbers_each_once() {
    for last in [1usize, 2, 3, 7, 40] {
        let fig = spherestep::figures::LoopPlot {
            title: "run".into(),
            rows: (0..=last)
                .map(|k| (k, 10.0 - k as f64 * 0.2, 3.0 * k as f64, k == 1))
                .collect(),
        };
        let svg = render_svg(&fig).unwrap();
        // the step labels: the numbers on the lowest line of labels
        let numbers: Vec<(String, String, String)> = placed_texts(&svg)
            .into_iter()
            .filter(|(t, _, _)| t.parse::<f64>().is_ok())
            .collect();
        let bottom = numbers
            .iter()
            .map(|(_, _, y)| y.parse::<f64>().unwrap())
            .fold(f64::MIN, f64::max);
        let steps: Vec<&str> = numbers
            .iter()
            .filter(|(_, _, y)| y.parse::<f64>().unwrap() == bottom)
            .map(|(t, _, _)| t.as_str())
            .collect();
        assert!(steps.len() >= 2, "{last}: {steps:?}");
        let values: Vec<i64> = steps
            .iter()
            .map(|s| {
                s.parse::<i64>()
                    .unwrap_or_else(|_| panic!("{last}: {s} in {steps:?}"))
            })
            .collect();
        assert!(values.windows(2).all(|w| w[0] < w[1]), "{last}: {steps:?}");
        assert!(
            values.iter().all(|&v| (0..=last as i64).contains(&v)),
            "{last}: {steps:?}"
        );
    }
}
