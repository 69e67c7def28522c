//! The path deviation a plan reports (`max_path_deviation_deg`): how far its rows stray from the
//! geodesic from row 0's orientation to its goal, checked against a sampling of that geodesic
//! recomputed from the plan file's quaternions.

mod common;

use spherestep::io::planfile::parse_plan;
use spherestep::model::geometry::{rot_q, unit, Radians};
use spherestep::PlanRow;
use std::path::Path;

/// `plan ARGS --json --out DIR/plan.csv`, reached or not (exit 1): its JSON summary, the path
/// deviation it reports and the plan's rows read back from the file.
fn planned(dir: &Path, args: &[&str]) -> (serde_json::Value, f64, Vec<PlanRow>) {
    let csv = dir.join("plan.csv");
    let mut all = vec!["plan"];
    all.extend_from_slice(args);
    all.extend_from_slice(&["--json", "--out", csv.to_str().unwrap()]);
    let (code, stdout, stderr) = common::run(&all);
    assert!(code == 0 || code == 1, "{stdout}{stderr}");
    let j: serde_json::Value = serde_json::from_str(stdout.trim()).unwrap();
    let reported = j["max_path_deviation_deg"].as_f64().unwrap();
    let rows = parse_plan(&std::fs::read_to_string(&csv).unwrap(), &csv).unwrap();
    (j, reported, rows)
}

#[test]
fn a_default_plans_path_deviation_is_its_rows_distance_from_the_slerp() {
    let dir = tempfile::tempdir().unwrap();
    let (j, reported, rows) = planned(dir.path(), &["scenarios/prototype.toml"]);
    assert!(rows.len() > 2, "{j}");
    // the prototype's default: 90 degrees about Z, applied to row 0
    let z = unit(nalgebra::Vector3::z()).unwrap();
    let start = rows[0].q;
    let goal = rot_q(&z, Radians(90f64.to_radians())) * start;
    let qs: Vec<_> = rows.iter().map(|r| r.q).collect();
    let sampled = common::sampled_path_deviation_deg(&qs, &start, &goal, 2000);
    assert!(
        (reported - sampled).abs() < 0.01,
        "reported {reported}, sampled {sampled}"
    );
    assert!(reported > 0.0 && reported < 30.0, "{j}");
    // and the one-line text summary says it too
    let (_, text, _) = common::run(&["plan", "scenarios/prototype.toml", "--out", "/dev/null"]);
    assert!(
        text.contains(&format!("path deviation {reported:.2} deg")),
        "{text}"
    );
}

#[test]
fn a_plan_to_an_orientation_is_measured_against_the_way_from_row_0_to_it() {
    let dir = tempfile::tempdir().unwrap();
    let sc = spherestep::Scenario::load(Path::new("scenarios/prototype.toml")).unwrap();
    // 60 degrees about an oblique axis from the scenario's start
    let axis = unit(nalgebra::Vector3::new(0.3, -0.4, 0.87)).unwrap();
    let target = rot_q(&axis, Radians(60f64.to_radians())) * sc.plan.start;
    let to = format!("{},{},{},{}", target.i, target.j, target.k, target.w);
    let (j, reported, rows) = planned(dir.path(), &["scenarios/prototype.toml", "--to", &to]);
    let qs: Vec<_> = rows.iter().map(|r| r.q).collect();
    let sampled = common::sampled_path_deviation_deg(&qs, &rows[0].q, &target, 2000);
    assert!(
        (reported - sampled).abs() < 0.01,
        "reported {reported}, sampled {sampled}"
    );
    assert!(reported > 0.0 && reported < 30.0, "{j}");
}
