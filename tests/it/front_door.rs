//! `plan` and `simulate` without `--out` write the CSV alone to standard output (the summary
//! goes to standard error), so that `spherestep plan s.toml > plan.csv` is a plan file that
//! `simulate`, `plot` and `replay` read.

use crate::common;

use std::process::{Command, Stdio};

/// Runs the binary with standard output redirected into `file` (as the shell's `>` does);
/// returns the exit code and standard error.
fn run_into(args: &[&str], file: &std::path::Path) -> (i32, String) {
    let out = Command::new(common::bin())
        .args(args)
        .stdout(Stdio::from(std::fs::File::create(file).unwrap()))
        .output()
        .unwrap();
    (
        out.status.code().unwrap_or(-1),
        String::from_utf8_lossy(&out.stderr).into_owned(),
    )
}

#[test]
fn plan_and_simulate_pipe_their_csv_alone() {
    let t = tempfile::tempdir().unwrap();
    let plan = t.path().join("plan.csv");
    let (code, err) = run_into(
        &[
            "plan",
            "scenarios/prototype.toml",
            "--axis",
            "0,0,1",
            "--angle",
            "30",
        ],
        &plan,
    );
    assert_eq!(code, 0, "{err}");
    assert!(
        err.contains("steps about") && err.contains("reached"),
        "summary on stderr: {err}"
    );
    let text = std::fs::read_to_string(&plan).unwrap();
    assert!(text.starts_with("step,pivot_coil,"), "{text}");
    assert!(
        !text.contains("steps about"),
        "no summary in the CSV: {text}"
    );
    let rows = spherestep::io::planfile::parse_plan(&text, &plan).unwrap();
    assert!(rows.len() >= 2);

    // The redirected plan goes on through simulate (itself redirected), plot and replay.
    let sim = t.path().join("sim.csv");
    let (code, err) = run_into(&["simulate", plan.to_str().unwrap()], &sim);
    assert_eq!(code, 0, "{err}");
    assert!(err.contains("max deviation"), "summary on stderr: {err}");
    let sim_text = std::fs::read_to_string(&sim).unwrap();
    assert!(sim_text.starts_with("step,qx,qy,qz,qw"), "{sim_text}");
    assert_eq!(sim_text.lines().count(), rows.len() + 1, "{sim_text}");
    assert!(!sim_text.contains("max deviation"), "{sim_text}");

    let log = t.path().join("plot.txt");
    let (code, err) = run_into(&["plot", plan.to_str().unwrap()], &log);
    assert_eq!(code, 0, "{err}");
    assert!(t.path().join("plan.png").is_file());
    let (code, err) = run_into(
        &[
            "replay",
            plan.to_str().unwrap(),
            "--board",
            "numato",
            "--dry-run",
        ],
        &log,
    );
    assert_eq!(code, 0, "{err}");
    // The view reads the simulate output too.
    let (code, err) = run_into(
        &[
            "view",
            plan.to_str().unwrap(),
            "--sim",
            sim.to_str().unwrap(),
            "--out",
            t.path().join("v.html").to_str().unwrap(),
        ],
        &log,
    );
    assert_eq!(code, 0, "{err}");

    // With --out (or --json) the summary stays on standard output.
    let (code, err) = run_into(
        &[
            "plan",
            "scenarios/prototype.toml",
            "--angle",
            "30",
            "--out",
            t.path().join("p2.csv").to_str().unwrap(),
        ],
        &log,
    );
    assert_eq!(code, 0, "{err}");
    assert!(std::fs::read_to_string(&log)
        .unwrap()
        .contains("steps about"));
    assert!(!err.contains("steps about"), "{err}");
}
