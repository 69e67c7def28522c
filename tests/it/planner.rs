//! Commutation and planning: the filter's geometry, pivot steps, the paper's targets, the
//! search against the greedy schemes, determinism, and unreachable targets.

use crate::common;

use common::csv_bytes;
use nalgebra::Vector3;
use spherestep::commands::{plan_settings, PlanOverrides};
use spherestep::io::scenario::Scenario;
use spherestep::model::geometry::{angular_distance, unit, Pair, Radians, UnitVec};
use spherestep::physics::torque::{Interaction, MagnetTorques};
use spherestep::planning::commutation::{
    filter_candidates, filter_deviations, pivot_step, rotation_axis_of_step, ERROR_BOUND_START,
};
use spherestep::planning::planner::{max_axis_error_deg, plan, PlanSettings};
use std::path::Path;

fn load(name: &str) -> Scenario {
    Scenario::load(Path::new(name)).unwrap()
}

fn settings(sc: &Scenario, axis: &str, scheme: &str, model: &str, pairs: &str) -> PlanSettings {
    plan_settings(
        sc,
        &PlanOverrides {
            axis: Some(axis.into()),
            scheme: Some(scheme.into()),
            model: Some(model.into()),
            pairs: Some(pairs.into()),
            ..Default::default()
        },
    )
    .unwrap()
}

#[test]
fn filter_deviations_on_hand_made_cases() {
    let z = unit(Vector3::z()).unwrap();
    let b: f64 = 0.3;
    let r = Vector3::new(1.0, 0.0, 0.0);
    // coil ahead of the magnet about +Z: the torque is along +Z, the pull is a chord whose
    // angle with the tangent (perpendicular to the arm) is half the arc
    let s = Vector3::new(b.cos(), b.sin(), 0.0);
    let (d1, d2) = filter_deviations(&r, &s, &z);
    assert!(d1.0.abs() < 1e-12, "{d1:?}");
    assert!((d2.0 - b / 2.0).abs() < 1e-12, "{d2:?}");
    // coil behind: the torque points along -Z
    let s = Vector3::new(b.cos(), -b.sin(), 0.0);
    let (d1, _) = filter_deviations(&r, &s, &z);
    assert!((d1.0 - std::f64::consts::PI).abs() < 1e-12);
    // coil above the magnet: the torque is horizontal (90 degrees off Z); the pull is again a
    // chord half the arc off its tangent, which is perpendicular to the arm
    let s = Vector3::new(b.cos(), 0.0, b.sin());
    let (d1, d2) = filter_deviations(&r, &s, &z);
    assert!((d1.0 - std::f64::consts::FRAC_PI_2).abs() < 1e-12);
    assert!((d2.0 - b / 2.0).abs() < 1e-12, "{d2:?}");
    // a magnet on the axis has no torque arm: it fails test (2) outright
    let (_, d2) = filter_deviations(&Vector3::z(), &s, &z);
    assert!((d2.0 - std::f64::consts::PI).abs() < 1e-12);
}

#[test]
fn the_filter_bound_widens_until_something_is_left() {
    // one coil, one magnet 10 degrees away along a circle tilted 12 degrees from the desired
    // axis: test (1) fails at pi/24 (7.5 degrees) and passes at pi/12 (15 degrees)
    let tilt = unit(Vector3::new(
        12f64.to_radians().sin(),
        0.0,
        12f64.to_radians().cos(),
    ))
    .unwrap();
    let rim = Vector3::new(0.0, -1.0, 0.0);
    let s = spherestep::model::geometry::rot_q(&tilt, Radians(10f64.to_radians())) * rim;
    let torques = MagnetTorques {
        rotor: vec![rim],
        stator: vec![s],
        well: Scenario::prototype().torques.well.clone(),
        interaction: Interaction::Pairs,
    };
    let n = unit(Vector3::z()).unwrap();
    let q = nalgebra::UnitQuaternion::identity();
    // the magnet must be in the bottom hemisphere: tip everything down a little
    let down = spherestep::model::geometry::rot_q(&unit(Vector3::x()).unwrap(), Radians(0.3));
    let torques = MagnetTorques {
        rotor: vec![down * rim],
        stator: vec![down * s],
        ..torques
    };
    let n = UnitVec::new_normalize(down * n.into_inner());
    let (c, bound) = filter_candidates(&torques, &q, &n, &[], ERROR_BOUND_START);
    assert_eq!(c.len(), 1);
    assert!(
        (bound.0 - std::f64::consts::PI / 12.0).abs() < 1e-12,
        "{bound:?}"
    );
    assert!(
        (c[0].deviation.0.to_degrees() - 12.0).abs() < 0.5,
        "{:?}",
        c[0]
    );
    // a pair on an excluded coil is no candidate
    let (c, _) = filter_candidates(&torques, &q, &n, &[Pair::new(0, 5)], ERROR_BOUND_START);
    assert!(c.is_empty());
}

#[test]
fn a_pivot_step_is_a_pure_rotation_about_the_pivot_coil() {
    let sc = load("scenarios/prototype.toml");
    let q = spherestep::model::geometry::rot_q(
        &unit(Vector3::new(0.1, 0.5, 1.0)).unwrap(),
        Radians(0.4),
    );
    for (pivot, cand) in [
        (Pair::new(0, 14), Pair::new(3, 40)),
        (Pair::new(12, 7), Pair::new(9, 33)),
    ] {
        let st = pivot_step(&sc.torques, &q, pivot, cand);
        let d = st.q * q.inverse();
        let axis = rotation_axis_of_step(&d).unwrap();
        let s = UnitVec::new_normalize(sc.torques.stator[pivot.coil.0]);
        let off = angular_distance(&axis, &s)
            .0
            .min(angular_distance(&-axis, &s).0);
        assert!(off < 1e-9, "axis off the pivot coil by {off}");
        // the pivot magnet keeps its distance from the pivot coil
        let before = q * sc.torques.rotor[pivot.magnet.0];
        let after = st.q * sc.torques.rotor[pivot.magnet.0];
        assert!((before.dot(&s) - after.dot(&s)).abs() < 1e-12);
        assert_eq!(st.active, vec![pivot, cand]);
    }
}

#[test]
fn the_z_plan_with_a_coil_on_the_axis_keeps_its_axis_error_tiny() {
    let sc = load("scenarios/paper-fig7-z.toml");
    let p = plan(&sc.motor(), &sc.plan);
    assert!(p.reached, "{:?}", p.message);
    assert!(max_axis_error_deg(&p.rows) < 1e-9);
    let last = p.rows.last().unwrap();
    assert!(last.cum_angle_deg >= 89.5 && last.cum_angle_deg < 100.0);
    // every step pivots on the coil on the axis
    assert!(p.rows[1..].iter().all(|r| r.pivot.unwrap().coil.0 == 0));
}

#[test]
fn the_paper_targets_are_met_by_both_models() {
    for (file, bound) in [
        ("scenarios/paper-fig7-z.toml", 3.0),
        ("scenarios/paper-fig8-y.toml", 15.0),
        ("scenarios/paper-fig7-z-dynamic3.toml", 3.0),
        ("scenarios/paper-fig8-y-dynamic3.toml", 15.0),
    ] {
        let sc = load(file);
        // the paper's targets are axis errors: where its plans end is none of them (its pivot
        // plans end up to 9 degrees from the target orientation)
        let s = PlanSettings {
            tolerance: Radians(std::f64::consts::PI),
            ..sc.plan.clone()
        };
        let p = plan(&sc.motor(), &s);
        assert!(p.reached, "{file}: {:?}", p.message);
        let worst = max_axis_error_deg(&p.rows);
        assert!(worst <= bound, "{file}: worst axis error {worst} > {bound}");
    }
}

#[test]
fn the_search_is_never_worse_than_the_weighted_greedy() {
    let sc = load("scenarios/prototype.toml");
    for (model, pairs) in [("pivot", "2"), ("dynamic", "2"), ("dynamic", "2-4")] {
        for axis in ["0,0,1", "0,1,0", "1,0,0", "1,1,0", "1,0,1", "-1,2,-1"] {
            let g = plan(&sc.motor(), &settings(&sc, axis, "weighted", model, pairs));
            let s = plan(&sc.motor(), &settings(&sc, axis, "search", model, pairs));
            if g.reached {
                assert!(s.reached, "{model} {axis}: greedy reached, search did not");
                let (ge, se) = (max_axis_error_deg(&g.rows), max_axis_error_deg(&s.rows));
                assert!(
                    se <= ge + 1e-9,
                    "{model} {axis}: search {se} > weighted {ge}"
                );
            }
        }
    }
}

#[test]
fn plans_are_deterministic_whatever_the_thread_count() {
    let sc = load("scenarios/paper-fig8-y-dynamic3.toml");
    let run = |threads: usize| {
        rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap()
            .install(|| csv_bytes(&plan(&sc.motor(), &sc.plan)))
    };
    let one = run(1);
    assert_eq!(one, run(2));
    assert_eq!(one, run(3));
    assert!(one.len() > 200);
}

#[test]
fn an_unreachable_target_ends_with_a_message_and_keeps_its_steps() {
    let dir = tempfile::tempdir().unwrap();
    let scen = dir.path().join("tight.toml");
    // steps may not stray more than 12 degrees from the axis: about X (21 degrees from the
    // nearest coil) the plan gets stuck
    std::fs::write(
        &scen,
        "[plan]\naxis = [1, 0, 0]\nangle_deg = 90\nscheme = \"weighted\"\nmax_step_axis_error_deg = 12\n",
    )
    .unwrap();
    let sc = Scenario::load(&scen).unwrap();
    let p = plan(&sc.motor(), &sc.plan);
    assert!(!p.reached);
    assert!(p.message.as_deref().unwrap().contains("target not reached"));
    assert!(!p.rows.is_empty());
    // the command line: non-zero exit, a clear message, the CSV with the steps made
    let out = dir.path().join("stuck.csv");
    let res = std::process::Command::new(common::bin())
        .args([
            "plan",
            scen.to_str().unwrap(),
            "--out",
            out.to_str().unwrap(),
            "--json",
        ])
        .output()
        .unwrap();
    assert_eq!(res.status.code(), Some(1));
    let stdout = String::from_utf8_lossy(&res.stdout);
    let v: serde_json::Value = serde_json::from_str(stdout.trim()).unwrap();
    assert_eq!(v["reached"], false);
    let stderr = String::from_utf8_lossy(&res.stderr);
    assert!(stderr.contains("target not reached"), "{stderr}");
    let rows = spherestep::io::planfile::read_plan(&out).unwrap();
    assert_eq!(rows.len(), p.rows.len());
}

#[test]
fn a_dynamic_plan_replays_exactly_in_its_own_scenario() {
    let sc = load("scenarios/paper-fig7-z-dynamic3.toml");
    let p = plan(&sc.motor(), &sc.plan);
    let sim = spherestep::planning::simulate::simulate(&sc.motor(), &p.rows);
    assert_eq!(sim.len(), p.rows.len());
    // Each row settles from the row before to 1e-15 degrees; the replay starts each step from
    // its own previous result instead, 1e-16 degrees off, and step 3, whose magnet grazes a
    // cut-off, is settled at tight tolerances, whose step sequence hangs on those last bits:
    // 7e-6 degrees. Anything like a real drift is thousands of times more.
    for r in &sim {
        assert!(
            r.deviation_deg < 1e-4,
            "step {}: {}",
            r.step,
            r.deviation_deg
        );
    }
    // in broad "coils" wells the same plan drifts: the slop becomes measurable
    let mut broad = sc.clone();
    broad.torques.interaction = Interaction::Coils;
    let sim = spherestep::planning::simulate::simulate(&broad.motor(), &p.rows);
    assert!(sim.iter().any(|r| r.deviation_deg > 0.01));
}

/// A geometric (pivot) plan predicts every step's settle time (the arrival of the dynamics'
/// settle of the step's set from the orientation the plan predicts before it), so that `replay`
/// waits for the ball instead of only its 200 ms floor.
#[test]
fn pivot_plans_predict_each_steps_settle_time() {
    use spherestep::physics::dynamics::settle;
    let sc = load("scenarios/prototype.toml");
    let s = settings(&sc, "0,0,1", "weighted", "pivot", "2");
    let p = plan(&sc.motor(), &s);
    assert!(p.rows.len() > 2);
    let mut from = s.start;
    let mut sooner = 0;
    for r in &p.rows {
        let expect = settle(&sc.torques, &r.active, &from, sc.body, sc.settle);
        assert!(
            r.settle_time_s > 0.05,
            "step {}: {}",
            r.step,
            r.settle_time_s
        );
        assert_eq!(r.settle_time_s, expect.arrival_time_s, "step {}", r.step);
        assert!(
            expect.arrival_time_s <= expect.settle_time_s,
            "step {}",
            r.step
        );
        sooner += usize::from(expect.arrival_time_s < expect.settle_time_s);
        from = r.q;
    }
    // the ball arrives before the torque test passes, in most steps
    assert!(2 * sooner > p.rows.len(), "{sooner} of {}", p.rows.len());
}

/// Near 180 degrees the cumulative angle wrapped (173.8 -> -175.1 -> -7.6, axis
/// error 180), so the plan turned the ball some 352 degrees the long way round. It is tracked
/// continuously: every step moves it by at most the step's own angle, it never runs backwards
/// in these plans, and they stop where they pass the target, with the axis error of the turn.
#[test]
fn the_cumulative_angle_does_not_wrap_near_180_degrees() {
    use spherestep::planning::planner::PlanSettings;
    // a wrapping angle once ended this plan with exit 1, a final angle of -7.62 and an axis error of 180
    let (code, stdout, stderr) = common::run(&[
        "plan",
        "scenarios/prototype.toml",
        "--model",
        "pivot",
        "--scheme",
        "weighted",
        "--angle",
        "179",
        "--tolerance-deg",
        "90",
        "--json",
        "--out",
        "/dev/null",
    ]);
    assert_eq!(code, 0, "{stdout}{stderr}");
    let j: serde_json::Value = serde_json::from_str(stdout.trim()).unwrap();
    let last = j["final_angle_deg"].as_f64().unwrap();
    assert!((178.5..209.0).contains(&last), "{j}");
    assert!(j["max_axis_error_deg"].as_f64().unwrap() < 1e-9, "{j}");
    let sc = load("scenarios/prototype.toml");
    // the pivot plans end up to 6 degrees from the target orientation: not what this checks
    let with_angle = |axis: &str, scheme: &str, angle: f64| PlanSettings {
        angle: Radians(angle.to_radians()),
        tolerance: Radians(std::f64::consts::PI),
        ..settings(&sc, axis, scheme, "pivot", "2")
    };
    for (axis, scheme, angle, worst_bound) in [
        ("0,0,1", "weighted", 179.0, 1e-9),
        ("0,0,1", "weighted", 180.0, 1e-9),
        ("0,0,1", "search", 180.0, 1e-9),
        ("0,1,0", "max-angle", 175.0, 10.82),
    ] {
        let s = with_angle(axis, scheme, angle);
        let p = plan(&sc.motor(), &s);
        let what = format!("{axis} {scheme} {angle}");
        assert!(p.reached, "{what}: {:?}", p.message);
        for w in p.rows.windows(2) {
            let (a, b) = (&w[0], &w[1]);
            let moved = b.cum_angle_deg - a.cum_angle_deg;
            assert!(
                moved > 0.0 && moved <= b.step_angle_deg.abs() + 1e-6,
                "{what}: step {} moved the cumulative angle by {moved} (step angle {})",
                b.step,
                b.step_angle_deg
            );
        }
        let last = p.rows.last().unwrap();
        assert!(
            last.cum_angle_deg >= angle - 0.5 && last.cum_angle_deg < angle + 30.0,
            "{what}: {}",
            last.cum_angle_deg
        );
        assert!(
            max_axis_error_deg(&p.rows) <= worst_bound,
            "{what}: {}",
            max_axis_error_deg(&p.rows)
        );
        // the plan stops at the first row past the target: no turn the long way round
        let past = p
            .rows
            .iter()
            .position(|r| r.cum_angle_deg >= angle - 0.5)
            .unwrap();
        assert_eq!(past, p.rows.len() - 1, "{what}");
    }
    // the measure itself: 185 degrees about Z, seen from 170, reads 185 with no axis error
    use spherestep::model::geometry::rot_q;
    use spherestep::planning::commutation::{cumulative, cumulative_from};
    let z = unit(Vector3::z()).unwrap();
    let q0 = nalgebra::UnitQuaternion::identity();
    let q = rot_q(&z, Radians(185f64.to_radians()));
    let (a, e) = cumulative(&q0, &q, &z);
    assert!((a.0.to_degrees() + 175.0).abs() < 1e-9 && e.0.to_degrees() > 179.9);
    let (a, e) = cumulative_from(&q0, &q, &z, 170f64.to_radians());
    assert!((a.0.to_degrees() - 185.0).abs() < 1e-9, "{a:?}");
    assert!(e.0.to_degrees() < 1e-9, "{e:?}");
    // and unchanged away from the wrap
    let q = rot_q(&z, Radians(40f64.to_radians()));
    assert_eq!(cumulative_from(&q0, &q, &z, 0.3), cumulative(&q0, &q, &z));
}

/// A step that never settles was written with the settle time t_max and nothing
/// else; only `simulate` showed it. The plan row, the CSV (`settled`), the summary (JSON
/// `unsettled_steps`, a warning line) and `replay` say so, and plan files without the column
/// still read (as settled).
#[test]
fn a_step_that_never_settles_is_flagged_in_the_plan() {
    use spherestep::io::planfile::parse_plan;
    let sc = load("scenarios/prototype.toml");
    let s = settings(&sc, "0,0,1", "weighted", "pivot", "2");
    let p = plan(&sc.motor(), &s);
    let flagged: Vec<usize> = p
        .rows
        .iter()
        .filter(|r| !r.settled)
        .map(|r| r.step)
        .collect();
    assert_eq!(flagged, vec![2]);
    assert_eq!(p.rows[2].settle_time_s, sc.settle.t_max);
    assert!(p
        .rows
        .iter()
        .filter(|r| r.settled)
        .all(|r| r.settle_time_s < sc.settle.t_max));
    // the dynamics agrees: simulate leaves step 2 unsettled too
    let sim = spherestep::planning::simulate::simulate(&sc.motor(), &p.rows);
    assert!(!sim[2].settled);
    assert_eq!(p.summary(&s).unsettled_steps, vec![2]);
    // the CSV's last column, read back; a file without it reads as settled
    let text = String::from_utf8(csv_bytes(&p)).unwrap();
    assert!(text
        .lines()
        .next()
        .unwrap()
        .ends_with(",settle_time_s,settled"));
    assert!(text.lines().nth(3).unwrap().ends_with(",5,false"), "{text}");
    let back = parse_plan(&text, Path::new("p.csv")).unwrap();
    let flags = |rows: &[spherestep::planning::plan::PlanRow]| -> Vec<(bool, f64)> {
        rows.iter().map(|r| (r.settled, r.settle_time_s)).collect()
    };
    assert_eq!(flags(&back), flags(&p.rows));
    let old: String = text
        .lines()
        .map(|l| &l[..l.rfind(',').unwrap()])
        .collect::<Vec<_>>()
        .join("\n");
    let back = parse_plan(&old, Path::new("old.csv")).unwrap();
    assert!(back.iter().all(|r| r.settled) && back.len() == p.rows.len());
    let bad = text.replace(",5,false", ",5,maybe");
    let e = parse_plan(&bad, Path::new("p.csv"))
        .unwrap_err()
        .to_string();
    assert!(e.contains("line 4") && e.contains("`settled`"), "{e}");
    // the command line: the warning line and the JSON key
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("p.csv");
    let out = out.to_str().unwrap();
    let args = [
        "plan",
        "scenarios/prototype.toml",
        "--model",
        "pivot",
        "--scheme",
        "weighted",
        "--tolerance-deg",
        "90",
        "--out",
        out,
    ];
    let (code, stdout, stderr) = common::run(&args);
    assert_eq!(code, 0, "{stderr}");
    assert!(
        stdout.contains("warning: step 2 never settled within t_max (5 s)"),
        "{stdout}"
    );
    let (code, stdout, _) = common::run(&[&args[..], &["--json"]].concat());
    assert_eq!(code, 0);
    let j: serde_json::Value = serde_json::from_str(stdout.trim()).unwrap();
    assert_eq!(j["unsettled_steps"], serde_json::json!([2]));
    // replay's dwell of that step says where it comes from
    let relay = dir.path().join("relay.toml");
    std::fs::write(
        &relay,
        "[relay]\nboard = \"numato\"\nchannels = 16\nmax_on_time_s = 86400\n",
    )
    .unwrap();
    let (code, stdout, stderr) =
        common::run(&["replay", out, relay.to_str().unwrap(), "--dry-run"]);
    assert_eq!(code, 0, "{stderr}");
    let dwell2 = stdout
        .lines()
        .find(|l| l.contains("    2 dwell"))
        .unwrap_or_default();
    assert!(
        dwell2.ends_with("dwell 7500 ms (the step never settled in the plan: its settle time is t_max, not a settle)"),
        "{stdout}"
    );
    assert!(!stdout
        .lines()
        .any(|l| l.contains("    3 dwell") && l.contains("never settled")));
}

/// `qx,qy,qz,qw` of an orientation, as `--from` and `--to` take it.
fn xyzw_text(q: &spherestep::model::geometry::Orientation) -> String {
    format!("{},{},{},{}", q.i, q.j, q.k, q.w)
}

#[test]
fn a_target_orientation_plans_the_shortest_turn_to_it_from_the_start() {
    use spherestep::model::geometry::rot_q;
    let sc = load("scenarios/prototype.toml");
    let x = UnitVec::new_normalize(Vector3::x());
    let n = UnitVec::new_normalize(Vector3::new(-0.4, 0.7, 0.2));
    let from = rot_q(&x, Radians(30f64.to_radians()));
    let to = rot_q(&n, Radians(70f64.to_radians())) * from;
    let by_target = plan_settings(
        &sc,
        &PlanOverrides {
            from: Some(xyzw_text(&from)),
            to: Some(xyzw_text(&to)),
            ..Default::default()
        },
    )
    .unwrap();
    assert!(
        angular_distance(&by_target.axis, &n).0 < 1e-12,
        "{:?}",
        by_target.axis
    );
    assert!((by_target.angle.0.to_degrees() - 70.0).abs() < 1e-9);
    assert!(by_target.target.unwrap().angle_to(&to) < 1e-12);
    // the axis and angle it stands for, without the target: aimed at the turn applied to row 0
    let by_axis = PlanSettings {
        axis: n,
        angle: Radians(70f64.to_radians()),
        target: None,
        ..by_target.clone()
    };
    let (p, q) = (plan(&sc.motor(), &by_target), plan(&sc.motor(), &by_axis));
    let (a, b) = (p.summary(&by_target), q.summary(&by_axis));
    // row 0 (the initial commutation) moved the ball: the turn from the start misses `to`
    let moved = q.rows[0].q.angle_to(&from).to_degrees();
    let missed = q.rows.last().unwrap().q.angle_to(&to).to_degrees();
    assert!(moved > 3.0 && missed > 3.0, "{moved} {missed}");
    // the final orientation error of a plan to an orientation: its last row against it
    let e = p.rows.last().unwrap().q.angle_to(&to).to_degrees();
    assert!((a.final_orientation_error_deg - e).abs() < 1e-12, "{a:?}");
    assert!(e < 2.0, "{a:?}");
    assert_eq!(p.reached, e <= 1.0, "{a:?}");
    // and of a plan by axis and angle: against the turn applied to row 0
    let goal = rot_q(&by_axis.axis, by_axis.angle) * q.rows[0].q;
    let e = q.rows.last().unwrap().q.angle_to(&goal).to_degrees();
    assert!((b.final_orientation_error_deg - e).abs() < 1e-12, "{b:?}");
    // the target's plan counts the settles of both plans it made
    assert!(a.settles > b.settles, "{} {}", a.settles, b.settles);
    // refused: the start itself, and a target beside an axis
    let same = PlanOverrides {
        from: Some(xyzw_text(&from)),
        to: Some(xyzw_text(&from)),
        ..Default::default()
    };
    let e = plan_settings(&sc, &same).unwrap_err().to_string();
    assert!(
        e.contains("--to") && e.contains("other than the start"),
        "{e}"
    );
    let both = PlanOverrides {
        axis: Some("0,0,1".into()),
        to: Some(xyzw_text(&to)),
        ..Default::default()
    };
    let e = plan_settings(&sc, &both).unwrap_err().to_string();
    assert!(e.contains("--to") && e.contains("not both"), "{e}");
}

#[test]
fn random_motions_land_near_their_target_orientation_and_replay_in_their_own_dynamics() {
    use spherestep::io::scenario::random_motions;
    use spherestep::planning::plan::final_orientation_error_deg;
    use spherestep::planning::search::over_on_time;
    let sc = load("scenarios/prototype.toml");
    let motor = sc.motor();
    let (lo, hi) = (Radians(5f64.to_radians()), Radians(180f64.to_radians()));
    let mut errors = Vec::new();
    for m in random_motions(6, 7, lo, hi) {
        let s = PlanSettings {
            axis: m.axis,
            angle: m.angle,
            start: m.start,
            ..sc.plan.clone()
        };
        let p = plan(&motor, &s);
        let what = format!("{:.1} deg about {:?}", m.angle.0.to_degrees(), m.axis);
        let e = final_orientation_error_deg(&s, &p.rows);
        // reached: within the tolerance (1 degree) of the target orientation, and only then
        assert_eq!(p.reached, e <= 1.0, "{what}: {e} {:?}", p.message);
        errors.push(e);
        // every step, the landing's among them, is what the dynamics does from the step before
        let sim = spherestep::planning::simulate::simulate(&motor, &p.rows);
        assert!(sim.iter().all(|r| r.deviation_deg < 1e-4), "{what}");
        assert_eq!(over_on_time(&p.rows, s.limits.on_time), None, "{what}");
        assert!(max_axis_error_deg(&p.rows) <= 7.0, "{what}");
    }
    errors.sort_by(f64::total_cmp);
    // the landing brings the ends near the target orientation: before it, the ends of such
    // motions lay 3.8 degrees from it at the median
    assert!(errors[2] < 1.5 && errors[5] < 3.0, "{errors:?}");
    // the main job, 90 degrees about Y: 3.36 degrees from the target before the landing
    let y = settings(&sc, "0,1,0", "search", "dynamic", "2-4");
    let p = plan(&motor, &y);
    let e = final_orientation_error_deg(&y, &p.rows);
    assert!(p.reached && e < 1.5, "{e}");
}

#[test]
fn the_sweeps_worst_ends_land_within_the_tolerance_on_sets_that_hold_nearest_the_goal() {
    use spherestep::planning::plan::final_orientation_error_deg;
    use spherestep::planning::search::over_on_time;
    let sc = load("scenarios/prototype.toml");
    let motor = sc.motor();
    // (start x,y,z,w; axis; angle deg; where the plan ended before the landing aimed at the
    // goal's final sets), motions 409, 434, 222 and 0 of results/sweep-500-motions.csv
    let motions: [([f64; 4], [f64; 3], f64, f64); 4] = [
        (
            [
                0.027547130186449876,
                0.056523811473446435,
                0.9633456214074397,
                0.260790007611716,
            ],
            [
                -0.5289125843342626,
                -0.4330305844041121,
                -0.7298876564948092,
            ],
            157.74979449604734,
            2.79,
        ),
        (
            [
                0.3149166490076957,
                0.0939016930864874,
                0.9341589459293669,
                0.13912957972116924,
            ],
            [
                0.8922280547014205,
                0.07300295496615707,
                -0.44564522545397967,
            ],
            41.086630554542545,
            2.39,
        ),
        (
            [
                -0.6860009423252367,
                0.20979563853383087,
                -0.04299929843466013,
                0.6953700867273459,
            ],
            [-0.5601994651574631, -0.4878342582175177, 0.6694731478906801],
            129.40194177392803,
            1.91,
        ),
        (
            [
                -0.6581291834184358,
                -0.017447141906394358,
                -0.13638128692300683,
                0.7402443648887207,
            ],
            [
                -0.933471651597632,
                0.34095027314405013,
                -0.11128156588845572,
            ],
            138.50651858455817,
            2.63,
        ),
    ];
    for (q, a, angle, before) in motions {
        let start = nalgebra::UnitQuaternion::from_quaternion(nalgebra::Quaternion::new(
            q[3], q[0], q[1], q[2],
        ));
        let s = PlanSettings {
            axis: unit(Vector3::new(a[0], a[1], a[2])).unwrap(),
            angle: Radians(angle.to_radians()),
            start,
            ..sc.plan.clone()
        };
        let p = plan(&motor, &s);
        let e = final_orientation_error_deg(&s, &p.rows);
        assert!(
            p.reached && e <= 1.0,
            "{angle} deg: {e} (was {before}) {:?}",
            p.message
        );
        // the landing's steps are what the dynamics does, within every coil's on-time
        let sim = spherestep::planning::simulate::simulate(&motor, &p.rows);
        assert!(sim.iter().all(|r| r.deviation_deg < 1e-4), "{angle} deg");
        assert_eq!(over_on_time(&p.rows, s.limits.on_time), None, "{angle} deg");
    }
}

#[test]
fn the_search_stops_when_it_stalls() {
    // about Y a stall of one settle stops the search at its first plan of its own, a stall of
    // the whole budget never stops it early (nor the default), and 3,000 lies between
    // (counted settles: the same on any machine; 1,257 / 6,798 / 10,886 when written)
    let sc = load("scenarios/prototype.toml");
    let about_y = settings(&sc, "0,1,0", "search", "dynamic", "2-4");
    let with = |stall: usize| {
        let s = PlanSettings {
            stall_settles: stall,
            ..about_y.clone()
        };
        plan(&sc.motor(), &s)
    };
    let (first, default, never) = (with(1), with(3_000), with(10_000));
    let unset = plan(&sc.motor(), &about_y);
    assert_eq!((unset.settles, &unset.rows), (never.settles, &never.rows));
    assert!(first.reached && default.reached && never.reached);
    assert!(
        first.settles < default.settles && default.settles < never.settles,
        "settles: stall 1 {}, default {}, never {}",
        first.settles,
        default.settles,
        never.settles
    );
    // the search's own improvements are what the stall waits for: the plan searched longest
    // strays least
    let worst = |p: &spherestep::planning::planner::Plan| max_axis_error_deg(&p.rows);
    assert!(
        worst(&never) <= worst(&first) + 1e-9,
        "{} {}",
        worst(&never),
        worst(&first)
    );
    assert!(
        worst(&default) < worst(&first),
        "{} {}",
        worst(&default),
        worst(&first)
    );
}
