//! Tests of `spherestep view`: the page embeds the plan and the packings as JSON (parsed back
//! here), references nothing outside itself, and a bad input gives an error and no page.

use spherestep::figures::view::{extract_data_json, write_view, SCRIPT, STYLE, TEMPLATE};
use spherestep::io::planfile::read_plan;
use spherestep::io::scenario::Scenario;
use std::path::{Path, PathBuf};
use std::process::Command;

fn data_dir() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data")
}

fn bin() -> Command {
    Command::new(env!("CARGO_BIN_EXE_spherestep"))
}

/// Every file in `dir` (to check that no temporary file is left behind).
fn listing(dir: &Path) -> Vec<String> {
    let mut v: Vec<String> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    v.sort();
    v
}

fn assert_self_contained(html: &str) {
    let lower = html.to_lowercase();
    for bad in [
        "http://",
        "https://",
        "<script src",
        " src=",
        "<link",
        "@import",
        "url(",
        "//cdn",
        "fetch(",
        "xmlhttprequest",
    ] {
        assert!(!lower.contains(bad), "the page must not reference `{bad}`");
    }
}

#[test]
fn page_embeds_plan_and_packings() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("plan.html");
    let plan_path = data_dir().join("view_plan_z.csv");
    let sc = Scenario::prototype();
    let axis = spherestep::commands::args::parse_axis("0,0,2", "--axis").unwrap();
    write_view(
        &plan_path,
        &sc,
        Some(&data_dir().join("view_sim_z.csv")),
        Some(axis),
        &out,
    )
    .unwrap();
    let html = std::fs::read_to_string(&out).unwrap();
    assert!(html.starts_with("<!DOCTYPE html>"));
    assert_self_contained(&html);
    assert!(html.contains(SCRIPT) && html.contains(STYLE));

    let v: serde_json::Value = serde_json::from_str(extract_data_json(&html).unwrap()).unwrap();
    let plan = read_plan(&plan_path).unwrap();
    let steps = v["steps"].as_array().unwrap();
    assert_eq!(steps.len(), plan.len());
    assert_eq!(steps.len(), 4);
    for (s, r) in steps.iter().zip(&plan) {
        assert_eq!(s["step"].as_u64().unwrap() as usize, r.step);
        let q: Vec<f64> = serde_json::from_value(s["q"].clone()).unwrap();
        let want = spherestep::model::geometry::xyzw(&r.q);
        for k in 0..4 {
            assert!(
                (q[k] - want[k]).abs() < 1e-12,
                "step {} q {q:?} vs {want:?}",
                r.step
            );
        }
        let active: Vec<[usize; 2]> = serde_json::from_value(s["active"].clone()).unwrap();
        let want: Vec<[usize; 2]> = r.active.iter().map(|p| [p.coil.0, p.magnet.0]).collect();
        assert_eq!(active, want);
        assert_eq!(s["settle_time_s"].as_f64().unwrap(), r.settle_time_s);
        assert_eq!(s["cum_angle_deg"].as_f64().unwrap(), r.cum_angle_deg);
    }
    assert_eq!(steps[2]["active"], serde_json::json!([[13, 7], [6, 62]]));
    assert!(steps[0]["pivot"].is_null());
    assert_eq!(steps[1]["pivot"], serde_json::json!([1, 44]));
    // packings: every coordinate as in the scenario
    let rotor: Vec<[f64; 3]> = serde_json::from_value(v["rotor"].clone()).unwrap();
    let stator: Vec<[f64; 3]> = serde_json::from_value(v["stator"].clone()).unwrap();
    assert_eq!(rotor.len(), 80);
    assert_eq!(stator.len(), 16);
    // (serde_json's own parser may be 1 ulp off; browsers parse the shortest form exactly)
    let same = |a: &[f64; 3], b: &spherestep::model::geometry::UnitVec| {
        (0..3).all(|k| (a[k] - b[k]).abs() <= 1e-15)
    };
    for (a, b) in rotor.iter().zip(&sc.rotor.points) {
        assert!(same(a, b), "{a:?} vs {b:?}");
    }
    for (a, b) in stator.iter().zip(&sc.stator.points) {
        assert!(same(a, b), "{a:?} vs {b:?}");
    }
    // the given desired axis, normalised
    assert_eq!(v["desired_axis"]["source"], "given");
    assert_eq!(
        v["desired_axis"]["axis"],
        serde_json::json!([0.0, 0.0, 1.0])
    );
    // simulate results with the file's deviation
    let sim = v["sim"].as_array().unwrap();
    assert_eq!(sim.len(), 4);
    assert_eq!(sim[3]["deviation_deg"].as_f64().unwrap(), 4.5);
    assert!((sim[3]["q"][2].as_f64().unwrap() - 0.156434465).abs() < 1e-8);
    assert_eq!(listing(dir.path()), vec!["plan.html".to_string()]);
}

#[test]
fn assets_are_self_contained() {
    for text in [TEMPLATE, STYLE, SCRIPT] {
        assert_self_contained(text);
    }
    assert_eq!(TEMPLATE.matches("{{DATA}}").count(), 1);
    assert_eq!(TEMPLATE.matches("{{SCRIPT}}").count(), 1);
    assert_eq!(TEMPLATE.matches("{{STYLE}}").count(), 1);
}

#[test]
fn cli_writes_page_with_default_scenario_and_inferred_axis() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("p.html");
    let o = bin()
        .arg("view")
        .arg(data_dir().join("view_plan_z.csv"))
        .arg("--out")
        .arg(&out)
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    assert!(String::from_utf8_lossy(&o.stdout).contains("4 steps"));
    let html = std::fs::read_to_string(&out).unwrap();
    let v: serde_json::Value = serde_json::from_str(extract_data_json(&html).unwrap()).unwrap();
    assert_eq!(v["desired_axis"]["source"], "inferred");
    let z = v["desired_axis"]["axis"][2].as_f64().unwrap();
    assert!(z > 0.99, "inferred axis should be near +Z, got {z}");
    assert!(v["sim"].is_null());
    // a scenario file given explicitly: its name and packings are used
    let sc_path = dir.path().join("motor.toml");
    std::fs::write(&sc_path, "name = \"test motor\"\n").unwrap();
    let o = bin()
        .arg("view")
        .arg(data_dir().join("view_plan_z.csv"))
        .arg(&sc_path)
        .arg("--out")
        .arg(&out)
        .arg("--axis")
        .arg("0,0,-1")
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let html = std::fs::read_to_string(&out).unwrap();
    let v: serde_json::Value = serde_json::from_str(extract_data_json(&html).unwrap()).unwrap();
    assert_eq!(v["scenario"], "test motor");
    assert_eq!(
        v["desired_axis"]["axis"],
        serde_json::json!([0.0, 0.0, -1.0])
    );
    // a scenario with fewer magnets than the plan uses is refused
    std::fs::write(
        &sc_path,
        "[rotor]\npoints = [[0, 0, 1], [0, 1, 0], [1, 0, 0]]\n",
    )
    .unwrap();
    let out2 = dir.path().join("small.html");
    let o = bin()
        .arg("view")
        .arg(data_dir().join("view_plan_z.csv"))
        .arg(&sc_path)
        .arg("--out")
        .arg(&out2)
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(!o.status.success() && err.contains("magnet 44"), "{err}");
    assert!(!out2.exists());
}

/// Runs `view` expecting failure; returns stderr. Checks that `out` keeps `before` (or stays
/// absent) and that no temporary file is left.
fn view_fails(args: &[&std::ffi::OsStr], dir: &Path, out: &Path, before: Option<&str>) -> String {
    let o = bin()
        .arg("view")
        .args(args)
        .arg("--out")
        .arg(out)
        .output()
        .unwrap();
    assert!(!o.status.success(), "expected failure");
    match before {
        None => assert!(!out.exists(), "no page may be written"),
        Some(b) => assert_eq!(std::fs::read_to_string(out).unwrap(), b),
    }
    for f in listing(dir) {
        assert!(!f.ends_with(".tmp"), "temporary file left: {f}");
    }
    String::from_utf8_lossy(&o.stderr).into_owned()
}

#[test]
fn bad_plan_row_gives_error_and_no_page() {
    let dir = tempfile::tempdir().unwrap();
    let good = std::fs::read_to_string(data_dir().join("view_plan_z.csv")).unwrap();
    let bad = dir.path().join("bad.csv");
    std::fs::write(&bad, good.replace("13:7;6:62", "13:7;six:62")).unwrap();
    let out = dir.path().join("page.html");
    let err = view_fails(&[bad.as_os_str()], dir.path(), &out, None);
    assert!(
        err.contains("bad.csv: line 4") && err.contains("`active`"),
        "error should name file, line and column: {err}"
    );
    // an existing page is left as it was
    std::fs::write(&out, "old page").unwrap();
    let err = view_fails(&[bad.as_os_str()], dir.path(), &out, Some("old page"));
    assert!(err.contains("line 4"), "{err}");
    // a non-number
    std::fs::write(&bad, good.replacen("0.150", "slow", 1)).unwrap();
    let err = view_fails(&[bad.as_os_str()], dir.path(), &out, Some("old page"));
    assert!(
        err.contains("line 3") && err.contains("settle_time_s"),
        "{err}"
    );
    // a pair index beyond the prototype's coils
    std::fs::write(&bad, good.replace("6:62;5:38", "6:62;50:38")).unwrap();
    let err = view_fails(&[bad.as_os_str()], dir.path(), &out, Some("old page"));
    assert!(err.contains("line 5") && err.contains("coil 50"), "{err}");
    // a missing plan file
    let missing = dir.path().join("missing.csv");
    let err = view_fails(&[missing.as_os_str()], dir.path(), &out, Some("old page"));
    assert!(err.contains("missing.csv"), "{err}");
}

#[test]
fn bad_sim_or_axis_gives_error_and_no_page() {
    let dir = tempfile::tempdir().unwrap();
    let plan = data_dir().join("view_plan_z.csv");
    let out = dir.path().join("page.html");
    let sim = dir.path().join("sim.csv");
    std::fs::write(&sim, "step,qx,qy,qz\n0,0,0,0\n").unwrap();
    let err = view_fails(
        &[plan.as_os_str(), "--sim".as_ref(), sim.as_os_str()],
        dir.path(),
        &out,
        None,
    );
    assert!(err.contains("sim.csv") && err.contains("`qw`"), "{err}");
    std::fs::write(&sim, "step,qx,qy,qz,qw\n7,0,0,0,1\n").unwrap();
    let err = view_fails(
        &[plan.as_os_str(), "--sim".as_ref(), sim.as_os_str()],
        dir.path(),
        &out,
        None,
    );
    assert!(err.contains("--sim") && err.contains("step 7"), "{err}");
    let err = view_fails(
        &[plan.as_os_str(), "--axis".as_ref(), "0,0,0".as_ref()],
        dir.path(),
        &out,
        None,
    );
    assert!(err.contains("--axis"), "{err}");
}

#[test]
fn plan_then_simulate_then_view() {
    // The whole pipeline on a paper scenario: the page takes `simulate`'s CSV as it is.
    let dir = tempfile::tempdir().unwrap();
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let scenario = root.join("scenarios/paper-fig7-z.toml");
    let (plan, sim, page) = (
        dir.path().join("plan.csv"),
        dir.path().join("sim.csv"),
        dir.path().join("plan.html"),
    );
    let o = bin()
        .arg("plan")
        .arg(&scenario)
        .arg("--out")
        .arg(&plan)
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let o = bin()
        .arg("simulate")
        .arg(&plan)
        .arg(&scenario)
        .arg("--out")
        .arg(&sim)
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let o = bin()
        .arg("view")
        .arg(&plan)
        .arg(&scenario)
        .arg("--sim")
        .arg(&sim)
        .arg("--out")
        .arg(&page)
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let html = std::fs::read_to_string(&page).unwrap();
    assert_self_contained(&html);
    let v: serde_json::Value = serde_json::from_str(extract_data_json(&html).unwrap()).unwrap();
    let rows = read_plan(&plan).unwrap();
    assert_eq!(v["steps"].as_array().unwrap().len(), rows.len());
    let sims = v["sim"].as_array().unwrap();
    assert_eq!(sims.len(), rows.len());
    for s in sims {
        let d = s["deviation_deg"].as_f64().unwrap();
        let c = s["computed_deviation_deg"].as_f64().unwrap();
        assert!(
            (d - c).abs() < 1e-6,
            "file and computed deviation differ: {s}"
        );
    }
}
