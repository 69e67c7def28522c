//! Closed loop in simulation: plans played on a plant whose physics is not
//! the model's, measured by a noisy sensor and replanned; open loop ends far off, closed loop
//! at the goal; the same seed gives the same bytes on any thread count; bad options refused.

use crate::common;

use common::run;
use spherestep::commands::closed_loop::{run_command, LoopOptions, Report, RunSummary};
use spherestep::commands::{plan_settings, PlanOverrides};
use spherestep::io::scenario::Scenario;
use std::path::Path;

fn load(name: &str) -> Scenario {
    Scenario::load(Path::new(name)).unwrap()
}

/// One run about `axis` (90 degrees) of the broad-well model on `plant`: the CSV and summary.
fn play(plant: &str, axis: &str, closed: bool, noise_deg: f64, seed: u64) -> (Vec<u8>, RunSummary) {
    let o = LoopOptions {
        closed,
        noise_deg,
        seed,
        max_steps: None,
        identify: true,
    };
    play_with("scenarios/broad-wells.toml", plant, axis, &o)
}

/// The plan settings of `sc` for 90 degrees about `axis`.
fn about(sc: &Scenario, axis: &str) -> spherestep::planning::plan::PlanSettings {
    plan_settings(
        sc,
        &PlanOverrides {
            axis: Some(axis.into()),
            angle_deg: Some(90.0),
            ..Default::default()
        },
    )
    .unwrap()
}

/// One run about `axis` (90 degrees), planned in `model`, played on `plant` as `o` says.
fn play_with(model: &str, plant: &str, axis: &str, o: &LoopOptions) -> (Vec<u8>, RunSummary) {
    let sc = load(model);
    let plant = load(plant);
    let (summary, csv) = run_in_process(&sc, &plant, &about(&sc, axis), o);
    (csv, summary.unwrap())
}

/// `spherestep run` in-process: planned in `sc` with `s`, played on `plant` as `o` says, the
/// CSV (and any note) into a buffer: the summary, or the refusal, and the CSV.
fn run_in_process(
    sc: &Scenario,
    plant: &Scenario,
    s: &spherestep::planning::plan::PlanSettings,
    o: &LoopOptions,
) -> (spherestep::Result<RunSummary>, Vec<u8>) {
    let (mut csv, mut note) = (Vec::new(), Vec::new());
    let report = Report {
        file: None,
        json: false,
        out: &mut csv,
        note: &mut note,
    };
    let summary = run_command(sc, plant, s, o, report);
    (summary, csv)
}

const WORN: &str = "scenarios/plants/broad-wells-worn.toml";

#[test]
fn closed_loop_reaches_the_goal_where_open_loop_does_not() {
    // the pair model's plan about Z, played on cosine wells reaching 35 degrees in which every
    // coil pulls: open loop ends far off
    let o = |closed: bool| LoopOptions {
        closed,
        noise_deg: 1.0,
        seed: 5,
        max_steps: None,
        identify: true,
    };
    let (model, plant) = (
        "scenarios/prototype.toml",
        "scenarios/plants/cosine-35-coils.toml",
    );
    let (_, open) = play_with(model, plant, "0,0,1", &o(false));
    assert!(open.run.final_error_deg > 10.0, "{:?}", open.run);
    assert_eq!(open.run.replans, 0);
    let (csv, closed) = play_with(model, plant, "0,0,1", &o(true));
    let r = &closed.run;
    assert!(r.reached && r.final_error_deg < 3.0, "{r:?}");
    assert!(r.replans >= 1);
    // within the default step budget (3 x the planned steps + 6), with room to spare
    assert!(
        r.steps <= 3 * closed.planned_steps,
        "{} > 3 x {}",
        r.steps,
        closed.planned_steps
    );
    // the rows: one per step and the initial state, the replans flagged, the error column
    // the summary's
    let text = String::from_utf8(csv).unwrap();
    let rows: Vec<&str> = text.lines().skip(1).collect();
    assert_eq!(rows.len(), r.steps + 1);
    let replanned = rows
        .iter()
        .filter(|l| l.split(',').nth(2) == Some("true"))
        .count();
    assert_eq!(replanned, r.replans);
    let last_error: f64 = rows[r.steps].split(',').nth(17).unwrap().parse().unwrap();
    assert_eq!(last_error, r.final_error_deg);
}

#[test]
fn a_loop_planned_in_the_pair_model_fits_the_broad_wells_and_arrives() {
    // the paper's pair model with sharp wells, played on the broad-well,
    // all-coils plant, 90 degrees about X with 1 degree of sensor noise
    let (model, plant) = ("scenarios/prototype.toml", "scenarios/broad-wells.toml");
    let o = |closed: bool, identify: bool| LoopOptions {
        closed,
        noise_deg: 1.0,
        seed: 1,
        max_steps: None,
        identify,
    };
    let (_, open) = play_with(model, plant, "1,0,0", &o(false, false));
    assert!(open.run.final_error_deg > 30.0, "{:?}", open.run);
    // replanning in the pair model alone does not steer the plant
    let (_, blind) = play_with(model, plant, "1,0,0", &o(true, false));
    assert!(blind.run.final_error_deg > 30.0, "{:?}", blind.run);
    assert_eq!(blind.run.fitted, None);
    // fitting the wells to the measured steps does
    let (csv, fit) = play_with(model, plant, "1,0,0", &o(true, true));
    let r = &fit.run;
    assert!(r.final_error_deg < 3.0, "{r:?}");
    // within the default budget (the plant's broad wells give short steps)
    let budget = spherestep::commands::closed_loop::default_max_steps(fit.planned_steps);
    assert!(r.steps <= budget, "{r:?}");
    let name = r.fitted.as_deref().unwrap_or_default();
    assert!(name.contains("every coil pulls"), "{name}");
    let k = r.fitted_after_step.expect("the fit steered");
    assert!(k <= 2, "{r:?}");
    assert!(r.fit_settles > 0);
    // the step after the fit took over was replanned from the measurement
    let text = String::from_utf8(csv).unwrap();
    let replanned: Vec<bool> = text
        .lines()
        .skip(1)
        .map(|l| l.split(',').nth(2) == Some("true"))
        .collect();
    assert!(replanned[k], "{replanned:?}");
}

#[test]
fn without_model_error_or_noise_nothing_is_replanned() {
    // the plant is the model: the plan happens as planned, the loop never intervenes
    let (open_csv, open) = play("scenarios/broad-wells.toml", "0,0,1", false, 0.0, 1);
    let (closed_csv, closed) = play("scenarios/broad-wells.toml", "0,0,1", true, 0.0, 1);
    assert_eq!(closed.run.replans, 0);
    // the same steps, the closed loop stopping once the sensor says the goal is reached
    assert!(closed.run.steps <= open.run.steps && closed.run.steps > 0);
    assert!(
        open_csv.starts_with(&closed_csv),
        "the closed loop's rows differ"
    );
    assert!(open.run.final_error_deg < 2.6, "{:?}", open.run);
}

#[test]
fn the_same_seed_gives_the_same_bytes_on_any_thread_count() {
    let on = |threads: usize, seed: u64| {
        rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap()
            .install(|| play(WORN, "0,0,1", true, 1.0, seed).0)
    };
    let one = on(1, 5);
    assert_eq!(one, on(2, 5));
    assert_ne!(one, on(2, 6), "another seed, other measurements");
}

#[test]
fn the_command_line_refuses_what_it_cannot_do() {
    let dir = tempfile::tempdir().unwrap();
    let plan = dir.path().join("p.csv");
    let (code, _, stderr) = run(&[
        "plan",
        "scenarios/broad-wells.toml",
        "--axis",
        "0,0,1",
        "--angle",
        "30",
        "--out",
        plan.to_str().unwrap(),
    ]);
    assert_eq!(code, 0, "{stderr}");
    for (args, needle) in [
        (
            vec![
                "run",
                "scenarios/broad-wells.toml",
                "--plant",
                WORN,
                "--closed-loop",
                "--sensor-noise-deg=-1",
            ],
            "--sensor-noise-deg",
        ),
        (
            vec![
                "run",
                "scenarios/broad-wells.toml",
                "--plant",
                WORN,
                "--closed-loop",
                "--max-steps",
                "0",
            ],
            "--max-steps",
        ),
        (
            vec![
                "simulate",
                plan.to_str().unwrap(),
                "scenarios/broad-wells.toml",
                "--closed-loop",
            ],
            "need --plant",
        ),
    ] {
        let (code, _, stderr) = run(&args);
        assert_eq!(code, 1, "{args:?}");
        assert!(stderr.contains(needle), "{args:?}: {stderr}");
    }
    // a plant with other packings
    let other = dir.path().join("other.toml");
    std::fs::write(
        &other,
        "[rotor]\npoints = [[0, 0, -1], [0, 1, 0], [1, 0, 0]]\n",
    )
    .unwrap();
    let (code, _, stderr) = run(&[
        "run",
        "scenarios/broad-wells.toml",
        "--plant",
        other.to_str().unwrap(),
        "--closed-loop",
    ]);
    assert_eq!(code, 1);
    assert!(
        stderr.contains("--plant") && stderr.contains("magnets"),
        "{stderr}"
    );
    // a plan file replayed closed loop: its own target
    let out = dir.path().join("loop.csv");
    let (code, stdout, stderr) = run(&[
        "simulate",
        plan.to_str().unwrap(),
        "scenarios/broad-wells.toml",
        "--plant",
        WORN,
        "--closed-loop",
        "--sensor-noise-deg",
        "0.5",
        "--json",
        "--out",
        out.to_str().unwrap(),
    ]);
    assert_eq!(code, 0, "{stderr}");
    let s: serde_json::Value = serde_json::from_str(stdout.trim()).unwrap();
    assert_eq!(s["mode"], "closed");
    assert!(s["final_error_deg"].as_f64().unwrap() < 2.0, "{s}");
    assert!(std::fs::read_to_string(&out)
        .unwrap()
        .starts_with("step,active,replanned,planned_qx"));
}

#[test]
fn a_run_csv_is_drawn_by_plot() {
    let dir = tempfile::tempdir().unwrap();
    let csv = dir.path().join("run.csv");
    std::fs::write(&csv, play(WORN, "0,0,1", true, 1.0, 2).0).unwrap();
    let (code, stdout, stderr) = run(&["plot", csv.to_str().unwrap()]);
    assert_eq!(code, 0, "{stderr}");
    assert!(
        stdout.contains("run.svg") && stdout.contains("run.png"),
        "{stdout}"
    );
    let svg = std::fs::read_to_string(dir.path().join("run.svg")).unwrap();
    for needle in [
        "distance to the goal by step: run",
        "replanned after this step",
        "deg from the goal",
    ] {
        assert!(svg.contains(needle), "{needle}");
    }
    // a damaged file names the line and the column
    let text = std::fs::read_to_string(&csv)
        .unwrap()
        .replacen(",false,", ",maybe,", 1);
    std::fs::write(&csv, text).unwrap();
    let (code, _, stderr) = run(&["plot", csv.to_str().unwrap()]);
    assert_eq!(code, 1);
    assert!(
        stderr.contains("line 2") && stderr.contains("replanned"),
        "{stderr}"
    );
}

/// The goal tolerance is twice the sensor's noise, so a noise of 45 degrees made
/// a run "reached" 69 degrees from the goal. A noise beyond 10 degrees is refused, naming the
/// option and the bound, before anything is planned; at the bound the tolerance is 20 degrees.
#[test]
fn a_sensor_noise_beyond_ten_degrees_is_refused_before_planning() {
    let (code, stdout, stderr) = run(&[
        "run",
        "scenarios/prototype.toml",
        "--plant",
        "scenarios/prototype.toml",
        "--closed-loop",
        "--sensor-noise-deg",
        "45",
        "--axis",
        "0,1,0",
        "--angle",
        "90",
    ]);
    assert_eq!(code, 1, "{stdout}{stderr}");
    assert!(!stdout.contains("reached"), "{stdout}");
    assert!(
        stderr.contains("--sensor-noise-deg") && stderr.contains("[0, 10] degrees"),
        "{stderr}"
    );
    let sc = load("scenarios/prototype.toml");
    let s = plan_settings(&sc, &PlanOverrides::default()).unwrap();
    let o = |noise_deg: f64| LoopOptions {
        closed: true,
        noise_deg,
        seed: 1,
        max_steps: None,
        identify: true,
    };
    let e = run_in_process(&sc, &sc, &s, &o(10.5)).0.unwrap_err();
    assert!(e.to_string().contains("--sensor-noise-deg"), "{e}");
    let cl = spherestep::commands::closed_loop::loop_settings(&o(10.0), 6).unwrap();
    assert!((cl.goal_tolerance.0.to_degrees() - 20.0).abs() < 1e-9);
}

/// A bad loop option is refused before the plan is computed (the broad wells
/// took 11 s to plan before `--sensor-noise-deg -1` was refused). A model in which no plan can
/// be made tells the order: the error names the option, not the plan that failed.
#[test]
fn bad_loop_options_are_refused_before_the_plan_is_computed() {
    let dir = tempfile::tempdir().unwrap();
    // one coil: no initial commutation state, so planning fails at once
    let one = dir.path().join("one-coil.toml");
    std::fs::write(&one, "[stator]\npoints = [[0, 0, -1]]\n").unwrap();
    let one = one.to_str().unwrap();
    for (args, needle) in [
        (vec!["--sensor-noise-deg=-1"], "--sensor-noise-deg"),
        (vec!["--max-steps", "0"], "--max-steps"),
    ] {
        let mut all = vec!["run", one, "--plant", one, "--closed-loop"];
        all.extend(args);
        let (code, _, stderr) = run(&all);
        assert_eq!(code, 1, "{all:?}: {stderr}");
        assert!(
            stderr.contains(needle) && !stderr.contains("--axis/--angle"),
            "{all:?}: {stderr}"
        );
    }
    // the closed loop's options without --closed-loop are refused (clap: usage error, 2)
    let plan = dir.path().join("p.csv");
    std::fs::write(
        &plan,
        "step,pivot_coil,pivot_magnet,new_coil,new_magnet,active,qx,qy,qz,qw,step_angle_deg,\
         step_axis_error_deg,cum_angle_deg,cum_axis_error_deg,settle_time_s\n\
         0,,,0,14,0:14,0,0,0,1,0,0,0,0,0.1\n",
    )
    .unwrap();
    let plan = plan.to_str().unwrap();
    for extra in [
        &["--sensor-noise-deg", "1"][..],
        &["--seed", "3"],
        &["--max-steps", "4"],
        &["--no-identify"],
    ] {
        for head in [
            &[
                "run",
                "scenarios/prototype.toml",
                "--plant",
                "scenarios/prototype.toml",
            ][..],
            &[
                "simulate",
                plan,
                "scenarios/prototype.toml",
                "--plant",
                "scenarios/prototype.toml",
            ],
        ] {
            let mut all = head.to_vec();
            all.extend(extra);
            let (code, stdout, stderr) = run(&all);
            assert_eq!(code, 2, "{all:?}: {stdout}{stderr}");
            assert!(
                stderr.contains("--closed-loop") && stdout.is_empty(),
                "{all:?}: {stderr}"
            );
        }
    }
}

/// `run` took its worst axis error, 90 degrees, from step 0, a small offset
/// of the plant's initial commutation from the model's, whose axis points anywhere. Rows that
/// turned the ball less than `MIN_AXIS_ANGLE_DEG` are left out of the worst (the CSV keeps
/// them).
#[test]
fn the_worst_axis_error_of_a_run_leaves_out_rotations_too_small_to_have_an_axis() {
    use spherestep::planning::closed_loop::MIN_AXIS_ANGLE_DEG;
    // this run once reported a worst axis error of 90.00 degrees
    let (_, stdout, stderr) = run(&[
        "run",
        "scenarios/sweep-500-axes.toml",
        "--plant",
        "scenarios/prototype.toml",
        "--json",
        "--out",
        "/dev/null",
    ]);
    let j: serde_json::Value = serde_json::from_str(stdout.trim()).expect(&stderr);
    assert!(j["max_axis_error_deg"].as_f64().unwrap() < 10.0, "{j}");
    let sc = load("scenarios/sweep-500-axes.toml");
    let plant = load("scenarios/prototype.toml");
    let s = plan_settings(&sc, &PlanOverrides::default()).unwrap();
    let o = LoopOptions {
        closed: false,
        noise_deg: 0.0,
        seed: 1,
        max_steps: None,
        identify: true,
    };
    let (summary, csv) = run_in_process(&sc, &plant, &s, &o);
    let summary = summary.unwrap();
    let text = String::from_utf8(csv).unwrap();
    let rows: Vec<(f64, f64)> = text
        .lines()
        .skip(1)
        .map(|l| {
            let f: Vec<&str> = l.split(',').collect();
            (f[15].parse().unwrap(), f[16].parse().unwrap())
        })
        .collect();
    // step 0: the offset (0.07 degrees), its axis error meaningless (and kept in the CSV)
    assert!(
        rows[0].0 > 0.01 && rows[0].0 < MIN_AXIS_ANGLE_DEG,
        "{rows:?}"
    );
    assert!(rows[0].1 > 89.0, "{rows:?}");
    let worst = rows
        .iter()
        .filter(|r| r.0.abs() >= MIN_AXIS_ANGLE_DEG)
        .map(|r| r.1)
        .fold(0.0, f64::max);
    assert_eq!(summary.run.max_axis_error_deg, worst);
    assert!(worst < 10.0, "{worst}");
}

/// A run of the prototype's pair-model plan (90 degrees about `axis`) on `plant`, closed or
/// open loop, 1 degree of sensor noise, `seed`, at most `max_steps` steps.
fn on_plant(plant: &str, axis: &str, closed: bool, seed: u64, max_steps: usize) -> RunSummary {
    let o = LoopOptions {
        closed,
        noise_deg: 1.0,
        seed,
        max_steps: Some(max_steps),
        identify: true,
    };
    play_with("scenarios/prototype.toml", plant, axis, &o).1
}

#[test]
fn on_plants_unlike_the_model_the_closed_loop_ends_within_three_degrees() {
    // max_steps: twice the plant's own fewest steps (research/closed_loop_grid.rs)
    for (plant, axis, seed, max_steps) in [
        ("scenarios/plants/cosine-35-coils.toml", "0,0,1", 1, 12),
        ("scenarios/plants/cosine-35-coils.toml", "1,1,1", 2, 14),
        ("scenarios/plants/gaussian-12-25.toml", "1,0,0", 3, 14),
        ("scenarios/plants/narrow-coils-stiff.toml", "1,0,0", 1, 14),
    ] {
        let open = on_plant(plant, axis, false, seed, max_steps);
        let closed = on_plant(plant, axis, true, seed, max_steps);
        let r = &closed.run;
        assert!(r.final_error_deg < 3.0, "{plant} about {axis}: {r:?}");
        assert!(r.steps <= max_steps, "{r:?}");
        // no worse than open loop, or within the goal tolerance (twice the noise) where open
        // loop comes nearer still (its plan lands on the target orientation)
        assert!(
            r.final_error_deg <= open.run.final_error_deg + 1e-9 || r.final_error_deg <= 2.0,
            "{plant}: {r:?} {open:?}"
        );
    }
}

#[test]
fn where_the_model_is_right_the_closed_loop_ends_no_worse_than_open_loop() {
    for (plant, axis, seed) in [
        ("scenarios/prototype.toml", "0,1,0", 1),
        ("scenarios/prototype.toml", "0,0,1", 2),
        ("scenarios/plants/prototype-strong-10.toml", "1,1,1", 3),
    ] {
        let open = on_plant(plant, axis, false, seed, 14);
        let closed = on_plant(plant, axis, true, seed, 14);
        assert!(
            closed.run.final_error_deg <= open.run.final_error_deg + 1.0,
            "{plant} about {axis}: closed {:?}, open {:?}",
            closed.run,
            open.run
        );
        // the plan is followed, not second-guessed on noise: replans only at its end
        assert!(closed.run.replans <= 2, "{:?}", closed.run);
    }
}

#[test]
fn the_step_budget_does_not_hang_on_the_plan_alone() {
    use spherestep::commands::closed_loop::default_max_steps;
    assert_eq!(default_max_steps(4), 18);
    assert_eq!(default_max_steps(0), 6);
}

#[test]
fn a_loop_that_stops_by_its_estimate_beyond_the_tolerance_is_not_reached() {
    // the loop decides on its estimate; here it stopped with the last measurement 2.09 degrees
    // from the goal, over its 1.5 (a loop so once said "reached")
    let (code, stdout, stderr) = common::run(&[
        "run",
        "scenarios/prototype.toml",
        "--plant",
        "scenarios/plants/gaussian-12-25.toml",
        "--axis",
        "0,0,1",
        "--angle",
        "90",
        "--closed-loop",
        "--sensor-noise-deg",
        "0.5",
        "--json",
    ]);
    let j: serde_json::Value = serde_json::from_str(stdout.lines().last().unwrap_or("")).unwrap();
    let measured = j["final_measured_error_deg"].as_f64().unwrap();
    assert!(measured > 1.5, "{j}");
    assert_eq!(j["reached"], false, "{j}");
    assert!(
        j["message"]
            .as_str()
            .unwrap()
            .contains("stopped at the goal by its estimate, but the last measurement is"),
        "{j}"
    );
    assert_eq!(code, 1, "{stderr}");
}

/// A run's path deviation is that of its measured orientations: against the slerp from the
/// plan's row 0 (the loop CSV's first planned orientation) to the goal, 90 degrees about the
/// axis applied to it, recomputed here by sampling that slerp.
#[test]
fn a_runs_path_deviation_is_its_measured_rows_distance_from_the_slerp() {
    use spherestep::model::geometry::{orientation_from_xyzw, rot_q, unit, Radians};
    let (csv, summary) = play(WORN, "0,0,1", true, 1.0, 1);
    let text = String::from_utf8(csv).unwrap();
    let mut lines = text.lines();
    let head: Vec<&str> = lines.next().unwrap().split(',').collect();
    let at = |name: &str| head.iter().position(|h| *h == name).unwrap();
    let quat = |f: &[&str], prefix: &str| {
        let c = |x: &str| f[at(&format!("{prefix}{x}"))].parse::<f64>().unwrap();
        orientation_from_xyzw(c("x"), c("y"), c("z"), c("w")).unwrap()
    };
    let rows: Vec<Vec<&str>> = lines.map(|l| l.split(',').collect()).collect();
    let start = quat(&rows[0], "planned_q");
    let measured: Vec<_> = rows.iter().map(|f| quat(f, "measured_q")).collect();
    let z = unit(nalgebra::Vector3::z()).unwrap();
    let goal = rot_q(&z, Radians(90f64.to_radians())) * start;
    let sampled = common::sampled_path_deviation_deg(&measured, &start, &goal, 2000);
    let reported = summary.run.max_path_deviation_deg;
    assert!(
        (reported - sampled).abs() < 0.01,
        "reported {reported}, sampled {sampled}"
    );
    assert!(reported > 0.0 && reported < 30.0, "{reported}");
}

/// A replan counts the time it takes against the coils that hold the ball meanwhile, and plans
/// within the limit from there: the hardware loop checks each replan against the coils'
/// measured on-times, which include the search, and refused a replan that its simulated twin
/// accepted (coil 12 for 10.017 s against 10 s on the virtual motor).
#[test]
fn a_replan_counts_its_own_time_against_the_coils_holding_the_ball() {
    use spherestep::planning::closed_loop::{Controller, Decision};
    use spherestep::planning::on_time::{self, STEP_IO};
    let sc = load("scenarios/prototype.toml");
    let s = about(&sc, "0,1,0");
    let limit = s.limits.on_time.expect("the prototype's relay limit");
    let motor = sc.motor();
    let open = motor.plan(&s);
    let goal = spherestep::planning::plan::goal_of(&s, &open.rows).unwrap();
    let o = LoopOptions {
        closed: true,
        noise_deg: 0.5,
        seed: 1,
        max_steps: None,
        identify: false,
    };
    let cl = spherestep::commands::closed_loop::loop_settings(&o, open.rows.len() - 1).unwrap();
    let mut ctl = Controller::new(&motor, &s, &open, goal, cl).unwrap();
    // row 0 switched and settled; the ball measured 6 degrees off where the plan put it
    let row0 = open.rows[0].clone();
    let off = spherestep::model::geometry::rot_q(
        &spherestep::model::geometry::unit(nalgebra::Vector3::new(1.0, 0.3, 0.0)).unwrap(),
        spherestep::Radians(6f64.to_radians()),
    ) * row0.q;
    let d = ctl.observe(&off);
    assert_eq!(ctl.replans(), 1, "{d:?}");
    assert_eq!(d, Decision::Replanned);
    // row 0's coils: its dwell, its frames and the search
    let held = limit.dwell(row0.settle_time_s) + STEP_IO + limit.replan_reserve;
    let on = ctl.on_times();
    assert!(!on.is_empty());
    for (coil, h) in on {
        assert_eq!(h.on, held, "coil {coil:?}");
    }
    // and the new plan keeps every coil within the limit from there
    let mut counted = on.clone();
    for row in ctl.plan().iter().skip(1) {
        row.hold(&mut counted, &limit);
        assert!(
            on_time::over(&counted, limit.max_on).is_none(),
            "{counted:?}"
        );
    }
}
