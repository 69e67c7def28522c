//! `spherestep design` (issue 56) on a tiny search: the `[design]` section's refusals, the same
//! bytes on 1 and 2 threads, from two shards and after a partial run resumed, and a front
//! whose layouts load as scenarios and whose objectives are what planning them gives.

use crate::common;
use spherestep::commands::batch::Shard;
use spherestep::commands::design::{run_design, DesignOptions};
use spherestep::io::scenario::Scenario;
use spherestep::planning::design::objectives::tail_mean;
use spherestep::planning::planner::{max_axis_error_deg, plan, PlanSettings};
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

/// A tiny search: 16 or 12-14 coils free in the prototype's cap, 4 layouts a generation, two
/// generations, 2 coarse and 3 full axes of 30 degrees.
const TINY: &str = r#"
name = "tiny"
[design]
free = "stator"
coils_min = 12
coils_max = 16
cap_deg = 79.2
coil_separation_deg = 18
families = ["scenario", "tammes", "fibonacci"]
axes = 2
full_axes = 3
axis_seed = 5
population = 4
generations = 1
angle_deg = 30
"#;

fn spec(dir: &Path) -> PathBuf {
    let p = dir.join("tiny.toml");
    std::fs::write(&p, TINY).unwrap();
    p
}

fn opts(out: &Path, jobs: usize, shard: Option<Shard>, resume: bool) -> DesignOptions {
    DesignOptions {
        out: out.to_path_buf(),
        seed: 3,
        jobs: Some(jobs),
        shard,
        resume,
        progress: false,
    }
}

/// The run's own outputs: front.csv, history.csv and the layouts (name -> bytes).
fn outputs(out: &Path) -> BTreeMap<String, Vec<u8>> {
    let mut m = BTreeMap::new();
    for p in common::files_below(out) {
        let rel = p.strip_prefix(out).unwrap().to_string_lossy().into_owned();
        let ours = [
            "front.csv",
            "history.csv",
            "front.svg",
            "front.png",
            "best-layouts.svg",
            "best-layouts.png",
        ];
        if ours.contains(&rel.as_str()) || rel.starts_with("layouts") {
            m.insert(rel, std::fs::read(&p).unwrap());
        }
    }
    m
}

#[test]
fn a_design_run_is_the_same_bytes_on_1_and_2_threads_from_shards_and_resumed() {
    let t = tempfile::tempdir().unwrap();
    let s = spec(t.path());
    let (a, b) = (t.path().join("a"), t.path().join("b"));
    let ra = run_design(&s, &opts(&a, 1, None, false)).unwrap();
    run_design(&s, &opts(&b, 2, None, false)).unwrap();
    let want = outputs(&a);
    assert_eq!(want, outputs(&b));
    assert_eq!(ra.generations, 2);
    assert_eq!(ra.evaluations, 8);
    assert!(!ra.front.is_empty() && ra.full_evaluations >= ra.front.len());
    let front = String::from_utf8(want["front.csv"].clone()).unwrap();
    assert_eq!(front.lines().count(), ra.front.len() + 1, "{front}");
    // every row as wide as the header, its objectives those the run reports
    let columns = |l: &str| l.split(',').count();
    let header = front.lines().next().unwrap();
    assert!(
        front.lines().all(|l| columns(l) == columns(header)),
        "{front}"
    );
    for ((id, o), row) in ra.front.iter().zip(front.lines().skip(1)) {
        let cells: Vec<&str> = row.split(',').collect();
        assert_eq!(cells[0], id.as_str(), "{front}");
        assert_eq!(cells[2].parse::<f64>().unwrap(), o.coils, "{front}");
        assert_eq!(
            cells[4].parse::<f64>().unwrap(),
            o.worst_axis_error_deg,
            "{front}"
        );
        assert_eq!(
            cells[5].parse::<f64>().unwrap(),
            o.tail_axis_error_deg,
            "{front}"
        );
        assert_eq!(cells[9].parse::<f64>().unwrap(), o.worst_steps, "{front}");
    }
    // the picture names the front's best (least tail) at each median step count, and no
    // other layout of the front (a text element's content is on lines of its own)
    let svg = String::from_utf8(want["front.svg"].clone()).unwrap();
    for (id, o) in &ra.front {
        let best = (ra.front.iter())
            .filter(|(_, p)| p.median_steps == o.median_steps)
            .min_by(|(a, p), (b, q)| {
                (p.tail_axis_error_deg.total_cmp(&q.tail_axis_error_deg)).then(a.cmp(b))
            });
        assert_eq!(
            svg.contains(&format!("\n{id}\n")) || svg.contains(&format!("\n{id} (own)\n")),
            best.is_some_and(|(b, _)| b == id),
            "{id} named exactly when it is the front's best at its median steps"
        );
    }
    let history = String::from_utf8(want["history.csv"].clone()).unwrap();
    assert_eq!(history.lines().count(), 3, "{history}");
    // two shards, each run computing its part of the first stage not finished
    let c = t.path().join("c");
    let mut rounds = 0;
    loop {
        rounds += 1;
        assert!(rounds < 12, "the shards never finished");
        let mut done = false;
        for i in 0..2 {
            let sh = Some(Shard { index: i, count: 2 });
            done |= run_design(&s, &opts(&c, 1, sh, false))
                .unwrap()
                .waiting
                .is_none();
        }
        if done {
            break;
        }
    }
    assert!(common::files_below(&c)
        .iter()
        .any(|p| p.to_string_lossy().contains(".shard-1-of-2")));
    assert_eq!(outputs(&c), want);
    // a run cut short: the last generation's results gone, the outputs not written yet
    for gone in [
        "front.csv",
        "history.csv",
        "front.svg",
        "front.png",
        "best-layouts.svg",
    ] {
        std::fs::remove_file(a.join(gone)).unwrap();
    }
    std::fs::remove_dir_all(a.join("gen-001")).unwrap();
    let rr = run_design(&s, &opts(&a, 2, None, true)).unwrap();
    assert_eq!(outputs(&a), want);
    assert_eq!(rr.front, ra.front);
}

#[test]
fn the_fronts_layouts_load_and_plan_as_the_front_says() {
    let t = tempfile::tempdir().unwrap();
    let s = spec(t.path());
    let out = t.path().join("o");
    let r = run_design(&s, &opts(&out, 2, None, false)).unwrap();
    let (id, o) = &r.front[0];
    let sc = Scenario::load(&out.join(format!("layouts/{id}.toml"))).unwrap();
    assert_eq!(sc.stator.len() as f64, o.coils);
    assert!((12..=16).contains(&sc.stator.len()));
    assert_eq!(sc.rotor.len(), 80);
    let sw = sc.sweep.clone().unwrap();
    assert_eq!(sw.axes.len(), 3);
    // the front's worst axis error is the worst of planning the layout about its full axes,
    // its tail the mean of the worst quarter (of 3 axes: the worst one)
    let errors: Vec<f64> = sw
        .axes
        .iter()
        .map(|axis| {
            let settings = PlanSettings {
                axis: *axis,
                angle: sw.angles[0],
                ..sc.plan.clone()
            };
            max_axis_error_deg(&plan(&sc.motor(), &settings).rows)
        })
        .collect();
    let worst = errors.iter().copied().fold(0.0, f64::max);
    assert_eq!(worst, o.worst_axis_error_deg);
    assert_eq!(tail_mean(&errors), o.tail_axis_error_deg);
    assert_eq!(o.tail_axis_error_deg, o.worst_axis_error_deg);
    assert!(o.median_axis_error_deg <= o.worst_axis_error_deg);
    // `plan` loads the layout's scenario
    let (code, _, err) = common::run(&[
        "plan",
        out.join(format!("layouts/{id}.toml")).to_str().unwrap(),
        "--axis",
        "0,1,0",
        "--angle",
        "30",
        "--out",
        t.path().join("p.csv").to_str().unwrap(),
    ]);
    assert_eq!(code, 0, "{err}");
    best_layouts_show_the_scenario_and_the_fronts_best(&out, &r.front);
}

/// `best-layouts.svg`: the scenario's layout, then the front's best three by the mean of the
/// worst quarter of their axis errors
/// (the scenario's own left out), each with its coils ('+': two strokes) and 80 magnets (dots).
fn best_layouts_show_the_scenario_and_the_fronts_best(
    out: &Path,
    front: &[(String, spherestep::planning::design::objectives::Objectives)],
) {
    let own = spherestep::model::packing::prototype_stator();
    let is_own = |sc: &Scenario| {
        sc.stator.len() == own.points.len()
            && sc
                .stator
                .points
                .iter()
                .zip(&own.points)
                .all(|(p, q)| (p.into_inner() - q.into_inner()).norm() < 1e-9)
    };
    let mut best: Vec<(f64, String, usize)> = front
        .iter()
        .filter_map(|(id, o)| {
            let sc = Scenario::load(&out.join(format!("layouts/{id}.toml"))).unwrap();
            (!is_own(&sc)).then(|| (o.tail_axis_error_deg, id.clone(), sc.stator.len()))
        })
        .collect();
    best.sort_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)));
    best.truncate(3);
    let svg = std::fs::read_to_string(out.join("best-layouts.svg")).unwrap();
    assert!(out.join("best-layouts.png").is_file());
    let coils: usize = own.points.len() + best.iter().map(|b| b.2).sum::<usize>();
    let strokes = svg
        .split("<polyline")
        .skip(1)
        .filter(|p| p.contains("stroke=\"#1F77B4\"") && p.contains("stroke-width=\"2\""))
        .count();
    assert_eq!(strokes, 2 * coils, "two strokes a coil");
    assert_eq!(
        svg.matches("<circle ").count(),
        80 * (1 + best.len()),
        "80 magnets a panel"
    );
    assert!(best.iter().all(|b| svg.contains(&b.1)), "{best:?}");
}

fn refused(extra: &str) -> String {
    Scenario::from_toml(&format!("[design]\n{extra}\n"), Path::new("d.toml"))
        .unwrap_err()
        .to_string()
}

#[test]
fn bad_design_sections_are_refused_naming_the_field() {
    for (extra, field, words) in [
        (
            "coils_min = 14\ncoils_max = 12",
            "design.coils_max",
            "not empty",
        ),
        ("coils = 0", "design.coils", "at least 1"),
        ("coils = 12\ncoils_min = 10", "design.coils", "not both"),
        (
            "coils = 40\ncap_deg = 60\ncoil_separation_deg = 30",
            "design.coil_separation_deg",
            "at most 21 coils fit",
        ),
        ("free = \"rotor\"\ncoils = 12", "design.coils", "not free"),
        ("free = \"all\"", "design.free", "\"both\""),
        (
            "families = [\"fibonacci\", \"hexagons\"]",
            "design.families[1]",
            "tammes",
        ),
        ("families = []", "design.families", "at least one"),
        (
            "axes = 64\nfull_axes = 32",
            "design.full_axes",
            "at least design.axes",
        ),
        ("population = 2", "design.population", "at least 4"),
        ("move_deg = -1", "design.move_deg", "[0, 90]"),
    ] {
        let e = refused(extra);
        assert!(
            e.contains("d.toml") && e.contains(&format!("`{field}`")) && e.contains(words),
            "{extra}: {e}"
        );
    }
    assert!(refused("colis = 12").contains("unknown field `colis`"));
    // the defaults are the scenario's own: 16 coils within 79.19 degrees of -Z
    let sc = Scenario::from_toml("[design]\n", Path::new("d.toml")).unwrap();
    let d = sc.design.unwrap();
    assert_eq!((d.coils, d.magnets), ((16, 16), (80, 80)));
    assert!((d.cap.0.to_degrees() - 79.188).abs() < 1e-3);
}

#[test]
fn design_without_a_design_section_fails_naming_it() {
    let t = tempfile::tempdir().unwrap();
    let s = t.path().join("plain.toml");
    std::fs::write(&s, "").unwrap();
    let (code, _, err) = common::run(&[
        "design",
        s.to_str().unwrap(),
        "--out",
        t.path().join("o").to_str().unwrap(),
    ]);
    assert_eq!(code, 1);
    assert!(
        err.contains("field `design`") && err.contains("plain.toml"),
        "{err}"
    );
}
