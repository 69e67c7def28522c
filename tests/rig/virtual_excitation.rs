//! An excitation run from `plan --excite`, replayed on the virtual motor with a sensor and
//! `--no-replan` (played as it is, read after every step), logged, and the log fitted with
//! `fit --log`: the hidden motor's wells (gaussian, 7 degrees wide, reaching 22; the
//! prototype's are 10 and 30) come back from the hardware path end to end. The virtual clock
//! runs 5 times the wall clock and each step dwells 0.8 s of wall (4 s on the virtual clock,
//! longer than every settle of the run), so the sensor reads a ball at rest; the sensor's
//! noise is 1 degree. Nothing asserts how fast anything ran.
#![cfg(unix)]

use crate::common;

use std::path::Path;
use std::time::{Duration, Instant};

const GUARD: Duration = Duration::from_secs(300);

const HIDDEN: &str = "name = \"hidden\"\n[magnets]\nshape = \"gaussian\"\nstrength_j = 0.2\n\
                      width_deg = 7.0\nmax_attraction_deg = 22.0\n[relay]\nboard = \"numato\"\n\
                      max_on_time_s = 1000\n";

fn write(dir: &Path, name: &str, text: &str) -> String {
    let p = dir.join(name);
    std::fs::write(&p, text).unwrap();
    p.display().to_string()
}

#[test]
fn an_excitation_run_replayed_with_a_sensor_and_not_replanned_fits_the_hidden_wells() {
    let _one = crate::one_at_a_time();
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let plant = write(d, "plant.toml", HIDDEN);
    // the replay's motor: the prototype, its on-time limit lifted for the fixed dwells
    let model = write(
        d,
        "model.toml",
        "name = \"model\"\n[relay]\nboard = \"numato\"\nmax_on_time_s = 1000\n",
    );
    let plan_path = d.join("excite.csv");
    common::excite("scenarios/prototype.toml", "30", "1", &plan_path);
    let plan = plan_path.display().to_string();
    let links = d.join("dev");
    let deadline = Instant::now() + GUARD;
    let mut v = common::start_virtual(&plant, &plan, &links, ("5", "1"), deadline);
    let log = d.join("log.csv").display().to_string();
    let (status, stdout, stderr) = common::replay_beside(
        &mut v,
        (&plan, &model),
        &links,
        (&log, "800"),
        &["--no-replan"],
        deadline,
    );
    let _ = v.kill();
    let _ = v.wait();
    assert!(status.success(), "{stdout}{stderr}");
    assert!(stdout.contains("measured open loop: "), "{stdout}");
    assert!(
        stdout.contains("measured open loop done: 30 step(s) played and read"),
        "{stdout}"
    );
    // the plan's own rows, none replanned
    let logged = std::fs::read_to_string(&log).unwrap();
    let actions: Vec<&str> = (logged.lines().skip(1))
        .filter_map(|l| l.split(',').nth(2))
        .collect();
    assert!(!actions.contains(&"replan"), "{logged}");
    assert_eq!(actions.iter().filter(|&&a| a == "sensor").count(), 31);
    // the log fitted from the unaltered prototype, and the hidden wells' own predictions of
    // the held-out steps (the fit of the plant's scenario starts from them: its "before")
    let fit = |scenario: &str| {
        let args = ["fit", scenario, "--log", &log, "--holdout", "10", "--json"];
        let (code, out, err) = common::run(&args);
        assert_eq!(code, 0, "{out}{err}");
        let report: serde_json::Value = serde_json::from_str(out.trim()).unwrap();
        assert_eq!(report["logged_steps"], 30, "{report}");
        report
    };
    let held_out = |report: &serde_json::Value, key: &str| -> Vec<f64> {
        (report["steps"][key].as_array().unwrap().iter())
            .map(|v| v.as_f64().unwrap())
            .collect()
    };
    let report = fit("scenarios/prototype.toml");
    let truth = held_out(&fit(&plant), "holdout_before_deg");
    let width = &report["steps"]["estimates"][0];
    assert_eq!(width["key"], "width_deg");
    let (w, se) = (
        width["value"].as_f64().unwrap(),
        width["std_error"].as_f64().unwrap(),
    );
    let after = held_out(&report, "holdout_after_deg");
    eprintln!("width {w} +- {se}; held out, fitted {after:.2?}, the hidden wells {truth:.2?}");
    // the replay's timing picks which of the sensor's noisy lines is read, and the relays of a
    // transition switch a frame apart: the run differs from one replay to the next, and the
    // width with it (7.11 and 7.35 +- 0.43, 7.22 +- 0.06 in three runs). The width's error is
    // conditional on the reach, which these steps fix only to a grid step (19 against the
    // hidden 22): the reach's own error moves the width by a few tenths that the width's error
    // leaves out, so half a degree is added to three of its errors. The prototype's 10 degrees
    // stays far outside.
    assert!(
        se < 1.0 && (w - 7.0).abs() < 3.0 * se + 0.5,
        "width {w} +- {se}: {report}"
    );
    // every held-out step the hidden wells predict within 2 degrees, the fit predicts within
    // half a degree of them
    for (k, (a, t)) in after.iter().zip(&truth).enumerate() {
        assert!(
            *t > 2.0 || *a <= t.max(2.0) + 0.5,
            "step {k}: {after:?} {truth:?}"
        );
    }
}
