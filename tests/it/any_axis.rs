//! The default planner about any axis (dynamic model, 2 to 4 pairs per step, best-first search):
//! hard axes within the paper's 15 degrees, plans that are what the dynamics does, the pivot
//! model's floor, and the planner's settings checked.

use crate::common;

use spherestep::commands::{plan_settings, PlanOverrides};
use spherestep::io::scenario::Scenario;
use spherestep::model::geometry::{unit, UnitVec};
use spherestep::planning::commutation::{pivot_floor, PairsPerStep, StepModel};
use spherestep::planning::planner::{max_axis_error_deg, plan, Scheme};
use spherestep::planning::simulate::simulate;
use std::path::Path;
use std::process::Command;

fn proto() -> Scenario {
    Scenario::load(Path::new("scenarios/prototype.toml")).unwrap()
}

fn axis(v: [f64; 3]) -> UnitVec {
    unit(nalgebra::Vector3::new(v[0], v[1], v[2])).unwrap()
}

/// Axes in the X-Y plane (the paper's hardest case), the four worst of the 500-axis sweep and an
/// oblique one: all far from every coil's axis line.
const HARD_AXES: [[f64; 3]; 7] = [
    [1.0, 0.0, 0.0],
    [1.0, 1.0, 0.0],
    [0.8976, -0.1140, -0.4260],
    [0.39033, 0.69311, -0.60600],
    [0.9632, -0.1727, -0.2060],
    [-0.8114, -0.3420, -0.4740],
    [-1.0, 2.0, -1.0],
];

#[test]
fn the_default_planner_turns_hard_axes_within_15_degrees_and_its_plans_replay() {
    let sc = proto();
    let mut pairs_used = std::collections::BTreeSet::new();
    for a in HARD_AXES {
        let text = format!("{},{},{}", a[0], a[1], a[2]);
        let s = plan_settings(
            &sc,
            &PlanOverrides {
                axis: Some(text.clone()),
                angle_deg: Some(90.0),
                ..Default::default()
            },
        )
        .unwrap();
        assert_eq!(s.model, StepModel::Dynamic);
        assert_eq!(s.pairs, PairsPerStep { min: 2, max: 4 });
        assert_eq!(s.scheme, Scheme::Search);
        let p = plan(&sc.motor(), &s);
        // reached only within the tolerance (1 degree) of the target orientation; these hard
        // axes all end within 2
        let off = p.summary(&s).final_orientation_error_deg;
        assert!(off < 2.0, "{text}: {:?}", p.message);
        assert_eq!(p.reached, off <= 1.0, "{text}: {:?}", p.message);
        let worst = max_axis_error_deg(&p.rows);
        // the paper's bound is 15 degrees; the default planner keeps within 10 (the stretch)
        assert!(worst <= 10.0, "{text}: worst cumulative axis error {worst}");
        // the turn about the axis is within the final error's bound: the landing aims at the
        // target orientation, not at the angle
        let last = p.rows.last().unwrap().cum_angle_deg;
        assert!((last - 90.0).abs() < 2.0, "{text}: ends at {last}");
        for (prev, r) in p.rows.iter().zip(&p.rows[1..]) {
            assert!((2..=4).contains(&r.active.len()), "{text}: {:?}", r.active);
            // the supply powers 4 coils: the held and the new set are on together for a moment
            let mut coils: Vec<usize> = prev
                .active
                .iter()
                .chain(&r.active)
                .map(|p| p.coil.0)
                .collect();
            coils.sort();
            coils.dedup();
            assert!(
                coils.len() <= 4,
                "{text}: step {} switches {coils:?}",
                r.step
            );
            // a step keeps a held pair (the pivot) and switches on new ones; a landing step
            // towards the target orientation may keep any of the pairs on (or none) and switch
            // on new ones, or only switch some off
            if let Some(p) = r.pivot {
                assert!(prev.active.contains(&p), "{text}: step {}", r.step);
            }
            for a in &r.active {
                let kept = prev.active.contains(a);
                assert!(kept || r.new.contains(a), "{text}: step {}: {a:?}", r.step);
            }
            assert!(r.new.iter().all(|n| r.active.contains(n)));
            pairs_used.insert(r.active.len());
        }
        // the plan is what the dynamics does: replayed step by step, within 1 degree
        let sim = simulate(&sc.motor(), &p.rows);
        assert_eq!(sim.len(), p.rows.len());
        for r in &sim {
            assert!(r.settled, "{text}: step {} does not settle", r.step);
            assert!(
                r.deviation_deg < 1.0,
                "{text}: step {} lands {} deg off the plan",
                r.step,
                r.deviation_deg
            );
        }
    }
    // the number of pairs is chosen per step, not fixed
    assert!(pairs_used.len() >= 2, "{pairs_used:?}");
}

#[test]
fn the_pivot_floor_bounds_every_pivot_plan_and_the_dynamic_model_goes_below_it() {
    let sc = proto();
    // a coil on -Z: no floor about Z
    assert!(pivot_floor(&sc.torques, &axis([0.0, 0.0, 1.0])).0 < 1e-12);
    let mut below = 0;
    for a in HARD_AXES {
        let n = axis(a);
        let floor = pivot_floor(&sc.torques, &n).0.to_degrees();
        // the floor is the nearest coil axis line, of either sign
        let by_hand = sc
            .stator
            .points
            .iter()
            .map(|s| s.dot(&n).abs().clamp(0.0, 1.0).acos().to_degrees())
            .fold(f64::INFINITY, f64::min);
        assert!((floor - by_hand).abs() < 1e-9);
        let text = format!("{},{},{}", a[0], a[1], a[2]);
        let o = |model: &str| PlanOverrides {
            axis: Some(text.clone()),
            model: Some(model.into()),
            ..Default::default()
        };
        let pivot = plan(&sc.motor(), &plan_settings(&sc, &o("pivot")).unwrap());
        if pivot.reached {
            let w = max_axis_error_deg(&pivot.rows);
            assert!(
                w >= floor - 1e-6,
                "{text}: pivot plan {w} below its floor {floor}"
            );
        }
        let dynamic = plan(&sc.motor(), &plan_settings(&sc, &o("dynamic")).unwrap());
        if max_axis_error_deg(&dynamic.rows) < floor {
            below += 1;
        }
    }
    assert!(
        below >= 5,
        "the dynamic model beats the floor on {below} of 7"
    );
}

fn run(args: &[&str], threads: &str) -> (i32, Vec<u8>, String) {
    let out = Command::new(common::bin())
        .args(args)
        .env("RAYON_NUM_THREADS", threads)
        .output()
        .unwrap();
    (
        out.status.code().unwrap_or(-1),
        out.stdout,
        String::from_utf8_lossy(&out.stderr).into_owned(),
    )
}

#[test]
fn the_default_plan_is_the_same_bytes_on_one_and_two_threads() {
    let dir = tempfile::tempdir().unwrap();
    let mut files = Vec::new();
    for t in ["1", "2"] {
        let f = dir.path().join(format!("plan-{t}.csv"));
        let (code, json, err) = run(
            &[
                "plan",
                "scenarios/prototype.toml",
                "--axis",
                "0.7071,0.7071,0",
                "--tolerance-deg",
                "2",
                "--out",
                f.to_str().unwrap(),
                "--json",
            ],
            t,
        );
        assert_eq!(code, 0, "{err}");
        let json = String::from_utf8(json).unwrap();
        assert!(json.contains("\"model\":\"dynamic\""), "{json}");
        assert!(json.contains("\"pairs_per_step\":4"), "{json}");
        files.push(std::fs::read(f).unwrap());
    }
    assert_eq!(files[0], files[1]);
}

/// `plan` with a scenario of `[plan]` text and extra arguments must fail naming `needles`.
fn plan_fails_with(plan_section: &str, args: &[&str], needles: &[&str]) {
    let dir = tempfile::tempdir().unwrap();
    let file = dir.path().join("bad.toml");
    std::fs::write(&file, format!("[plan]\n{plan_section}\n")).unwrap();
    let mut all = vec!["plan", file.to_str().unwrap()];
    all.extend_from_slice(args);
    let (code, _, err) = run(&all, "1");
    assert_ne!(code, 0, "must fail: {err}");
    assert_ne!(code, 101, "a panic is not an error message: {err}");
    for n in needles {
        assert!(err.contains(n), "expected '{n}' in: {err}");
    }
}

#[test]
fn pairs_and_budgets_out_of_range_are_refused_naming_the_field() {
    plan_fails_with(
        "max_pairs_per_step = 9",
        &[],
        &["bad.toml", "plan.max_pairs_per_step", "2 to 8", "2-9"],
    );
    plan_fails_with("max_pairs_per_step = 1", &[], &["plan.max_pairs_per_step"]);
    plan_fails_with(
        "pairs_per_step = 3\nmax_pairs_per_step = 4",
        &[],
        &["plan.max_pairs_per_step", "not both"],
    );
    plan_fails_with("settle_budget = 0", &[], &["plan.settle_budget", ">= 1"]);
    plan_fails_with("stall_settles = 0", &[], &["plan.stall_settles", ">= 1"]);
    plan_fails_with("stall_settles = -3", &[], &["stall_settles"]);
    plan_fails_with(
        "settles_per_state = 0",
        &[],
        &["plan.settles_per_state", ">= 1"],
    );
    plan_fails_with("", &["--pairs", "2-9"], &["--pairs", "2 to 8"]);
    plan_fails_with("", &["--pairs", "four"], &["--pairs", "2-K", "four"]);
    plan_fails_with(
        "",
        &["--model", "pivot", "--pairs", "3"],
        &["--pairs", "pivot model"],
    );
}

#[test]
fn weighing_stops_at_sets_that_hold_nothing_and_settles_held_sets_exactly_as_simulate() {
    use spherestep::model::geometry::Pair;
    use spherestep::physics::dynamics::{settle, Stop};
    let sc = proto();
    let m = sc.motor();
    let q0 = nalgebra::UnitQuaternion::identity();
    // coil 0 with its nearest magnet holds; magnet 15 is 163.5 degrees from coil 0's neighbour:
    // out of reach, so one direction is free
    let (near, _) = spherestep::planning::commutation::nearest_magnet(
        &sc.torques,
        spherestep::model::geometry::CoilId(0),
        &q0,
    );
    let loose = [Pair::new(0, near.0), Pair::new(7, 15)];
    let w = settle(&sc.torques, &loose, &q0, sc.body, m.weighing());
    assert_eq!(w.stop, Stop::Unheld, "{w:?}");
    assert!(!w.settled);
    let full = settle(&sc.torques, &loose, &q0, sc.body, sc.settle);
    assert_ne!(full.stop, Stop::Unheld, "simulate follows it: {full:?}");
    // a set that holds: the same result, to the bit
    let (m7, _) = spherestep::planning::commutation::nearest_magnet(
        &sc.torques,
        spherestep::model::geometry::CoilId(7),
        &q0,
    );
    let held = [Pair::new(0, near.0), Pair::new(7, m7.0)];
    let a = settle(&sc.torques, &held, &q0, sc.body, m.weighing());
    let b = settle(&sc.torques, &held, &q0, sc.body, sc.settle);
    assert!(a.settled && b.settled);
    assert_eq!(a.q, b.q);
    assert_eq!(a.settle_time_s, b.settle_time_s);
}
