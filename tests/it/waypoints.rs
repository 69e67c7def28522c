//! Motions through waypoints: the raster path and a path of turns on another plant reach every
//! waypoint within the tolerance, replay in their own dynamics as planned, keep to replay's
//! limits, give the same bytes on one thread and on two; `plan --waypoints` and `simulate`
//! report each waypoint, and refuse bad waypoint files naming the file, the line and the column.

use crate::common;

use spherestep::io::planfile::{parse_plan_waypoints, write_waypoint_plan};
use spherestep::io::waypoints::read_waypoints;
use spherestep::{Scenario, WaypointPlan};
use std::path::Path;

const RASTER: &str = "scenarios/waypoints/raster-10.csv";

fn load(path: &str) -> Scenario {
    Scenario::load(Path::new(path)).unwrap()
}

fn plan_path(sc: &Scenario, file: &str, tolerance_deg: f64) -> WaypointPlan {
    let waypoints = read_waypoints(Path::new(file), &sc.plan.start).unwrap();
    sc.motor()
        .plan_waypoints(&sc.plan, &waypoints, tolerance_deg)
}

fn csv(p: &WaypointPlan) -> Vec<u8> {
    let mut out = Vec::new();
    write_waypoint_plan(p, &mut out).unwrap();
    out
}

/// Every waypoint served in order by rows that are what the dynamics does and that replay's
/// schedule check passes; each waypoint within `tolerance_deg` of the row that reaches it.
fn check_path(sc: &Scenario, p: &WaypointPlan, tolerance_deg: f64, name: &str) {
    assert!(p.reached, "{name}: {:?}", p.message);
    assert_eq!(p.rows.len(), p.serves.len(), "{name}");
    assert!(p.serves.windows(2).all(|w| w[0] <= w[1]), "{name}: order");
    for (k, r) in p.rows.iter().enumerate() {
        assert_eq!(r.step, k, "{name}: steps numbered through the motion");
    }
    let at = p.reached_at();
    assert_eq!(at.len(), p.waypoints.len(), "{name}");
    for w in &at {
        let q = p.rows[w.step].q;
        let measured = q.angle_to(&p.waypoints[w.waypoint - 1]).to_degrees();
        assert!((measured - w.error_deg).abs() < 1e-9, "{name}: {w:?}");
        assert!(w.error_deg <= tolerance_deg, "{name}: {w:?}");
        // its rows' path deviation: against the slerp from the waypoint before (the first:
        // from row 0) to it, recomputed by sampling that slerp
        let from = match w.waypoint {
            1 => p.rows[0].q,
            k => p.waypoints[k - 2],
        };
        let leg: Vec<_> = (p.rows.iter().zip(&p.serves))
            .filter(|&(_, &v)| v == w.waypoint)
            .map(|(r, _)| r.q)
            .collect();
        let to = p.waypoints[w.waypoint - 1];
        let sampled = common::sampled_path_deviation_deg(&leg, &from, &to, 2000);
        assert!(
            (w.max_path_deviation_deg - sampled).abs() < 0.01,
            "{name}: {w:?}, sampled {sampled}"
        );
        assert!(w.max_path_deviation_deg < 30.0, "{name}: {w:?}");
    }
    let summary = p.summary(&sc.plan, tolerance_deg);
    let worst = at
        .iter()
        .map(|w| w.max_path_deviation_deg)
        .fold(0.0, f64::max);
    assert_eq!(summary.max_path_deviation_deg, worst, "{name}");
    assert!(worst > 0.0, "{name}");
    // the plan is what its own dynamics does, step by step
    let sim = sc.motor().simulate(&p.rows);
    let worst = sim.iter().map(|s| s.deviation_deg).fold(0.0, f64::max);
    assert!(
        worst < 1.0,
        "{name}: a step deviates {worst} deg in simulation"
    );
    assert!(sim.iter().all(|s| s.settled), "{name}: an unsettled step");
    // and replay takes it: coils on at once, counting the transitions, and every on-time
    let checked = common::replay_check(sc, &p.rows);
    assert!(checked.is_ok(), "{name}: {:?}", checked.err());
}

#[test]
fn the_raster_reaches_every_waypoint_within_3_degrees_and_replays() {
    let sc = load("scenarios/prototype.toml");
    let p = plan_path(&sc, RASTER, 3.0);
    assert_eq!(p.waypoints.len(), 10);
    check_path(&sc, &p, 3.0, "raster");
    // the waypoints are 10 degrees apart (20 at the row change): the path is not one long turn
    let last = p.reached_at().last().copied().unwrap();
    assert_eq!(last.waypoint, 10);
    assert_eq!(last.step, p.rows.len() - 1);
}

#[test]
fn a_path_of_turns_on_a_worn_plant_reaches_every_waypoint() {
    let sc = load("scenarios/plants/prototype-worn.toml");
    let dir = tempfile::tempdir().unwrap();
    let file = dir.path().join("turns.csv");
    // turns of 5 to 60 degrees about oblique axes, each from the waypoint before
    std::fs::write(
        &file,
        "axis_x,axis_y,axis_z,angle_deg\n\
         0.060643,0.800411,-0.596377,39.415\n\
         0.986806,0.148377,0.064795,51.061\n\
         -0.3,0.2,0.93,12\n\
         0.5,-0.5,0.7,5\n",
    )
    .unwrap();
    let p = plan_path(&sc, file.to_str().unwrap(), 3.0);
    check_path(&sc, &p, 3.0, "turns on the worn plant");
    // the first turn counts from the start, the next from the waypoint before
    let w = read_waypoints(&file, &sc.plan.start).unwrap();
    assert!((w[0].angle_to(&sc.plan.start).to_degrees() - 39.415).abs() < 1e-6);
    assert!((w[1].angle_to(&w[0]).to_degrees() - 51.061).abs() < 1e-6);
}

#[test]
fn the_same_path_gives_the_same_bytes_on_one_thread_and_on_two() {
    let sc = load("scenarios/prototype.toml");
    let on = |threads| {
        rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap()
            .install(|| csv(&plan_path(&sc, RASTER, 3.0)))
    };
    let one = on(1);
    assert_eq!(one, on(2));
    // and the file says which waypoint each row serves, with the waypoint's orientation
    let text = String::from_utf8(one).unwrap();
    let serves = parse_plan_waypoints(&text, Path::new("raster plan"))
        .unwrap()
        .unwrap();
    assert_eq!(serves.first().map(|s| s.0), Some(1));
    assert_eq!(serves.last().map(|s| s.0), Some(10));
}

#[test]
fn a_tolerance_the_motor_cannot_keep_is_a_plan_not_reached_naming_the_waypoint() {
    let sc = load("scenarios/prototype.toml");
    let p = plan_path(&sc, RASTER, 0.05);
    assert!(!p.reached);
    let m = p.message.unwrap();
    assert!(m.starts_with("waypoint 1 not reached"), "{m}");
    assert!(m.contains("over the tolerance of 0.05 deg"), "{m}");
}

#[test]
fn plan_and_simulate_report_each_waypoint() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("raster.csv");
    let out_s = out.to_str().unwrap();
    let (code, said, err) = common::run(&[
        "plan",
        "scenarios/prototype.toml",
        "--waypoints",
        RASTER,
        "--out",
        out_s,
    ]);
    assert_eq!(code, 0, "{err}");
    assert!(said.contains("10 waypoints in"), "{said}");
    assert!(said.contains("  waypoint 10: step "), "{said}");
    let text = std::fs::read_to_string(&out).unwrap();
    assert!(text
        .lines()
        .next()
        .unwrap()
        .ends_with(",waypoint,waypoint_qx,waypoint_qy,waypoint_qz,waypoint_qw"));
    let sim = dir.path().join("sim.csv");
    let (code, said, err) = common::run(&[
        "simulate",
        out_s,
        "scenarios/prototype.toml",
        "--json",
        "--out",
        sim.to_str().unwrap(),
    ]);
    assert_eq!(code, 0, "{err}");
    let v: serde_json::Value = serde_json::from_str(said.trim()).unwrap();
    let w = v["waypoints"].as_array().unwrap();
    assert_eq!(w.len(), 10);
    for x in w {
        assert!(x["error_deg"].as_f64().unwrap() <= 3.0, "{x}");
    }
}

#[test]
fn bad_waypoint_files_and_tolerances_are_refused_by_name() {
    let dir = tempfile::tempdir().unwrap();
    let bad = dir.path().join("bad.csv");
    std::fs::write(&bad, "qx,qy,qz,qw\n0,0,0,1\n0,0,zero,1\n").unwrap();
    let bad_s = bad.to_str().unwrap();
    let (code, _, err) = common::run(&["plan", "scenarios/prototype.toml", "--waypoints", bad_s]);
    assert_ne!(code, 0);
    assert!(err.contains("bad.csv") && err.contains("line 3"), "{err}");
    assert!(err.contains("qz"), "{err}");
    assert!(!err.contains("panicked"), "{err}");
    let (code, _, err) = common::run(&[
        "plan",
        "scenarios/prototype.toml",
        "--waypoints",
        RASTER,
        "--tolerance-deg",
        "0",
    ]);
    assert_ne!(code, 0);
    assert!(err.contains("--tolerance-deg"), "{err}");
    let (code, _, err) = common::run(&[
        "plan",
        "scenarios/prototype.toml",
        "--waypoints",
        RASTER,
        "--axis",
        "0,0,1",
    ]);
    assert_ne!(code, 0);
    assert!(err.contains("--axis"), "{err}");
}

#[test]
fn the_progress_counts_the_waypoints_served_and_leaves_the_plan_as_it_is() {
    // the raster: every report is a count of waypoints served (at most all ten, fewer when the
    // planner goes back), the last is all ten, and the plan is the one made without reports
    let sc = load("scenarios/prototype.toml");
    let file = "scenarios/waypoints/raster-10.csv";
    let waypoints = read_waypoints(Path::new(file), &sc.plan.start).unwrap();
    let mut reports = Vec::new();
    let with = spherestep::planning::waypoints::plan_waypoints_with(
        &sc.motor(),
        &sc.plan,
        &waypoints,
        3.0,
        &mut |k| reports.push(k),
    );
    assert!(with.reached, "{:?}", with.message);
    assert!(reports.len() >= waypoints.len(), "{reports:?}");
    assert!(reports.iter().all(|&k| k <= waypoints.len()), "{reports:?}");
    assert_eq!(reports.last(), Some(&waypoints.len()), "{reports:?}");
    // one more served at a time
    for w in reports.windows(2) {
        assert!(w[1] <= w[0] + 1, "{reports:?}");
    }
    assert_eq!(csv(&with), csv(&plan_path(&sc, file, 3.0)));
}
