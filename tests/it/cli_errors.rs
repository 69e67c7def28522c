//! Bad input gets a clear error naming the file, the field and what was expected, a non-zero
//! exit code, and never a panic.

use crate::common;

use std::path::Path;
use std::process::Command;

fn run(args: &[&str]) -> (i32, String, String) {
    let out = Command::new(common::bin()).args(args).output().unwrap();
    (
        out.status.code().unwrap_or(-1),
        String::from_utf8_lossy(&out.stdout).into_owned(),
        String::from_utf8_lossy(&out.stderr).into_owned(),
    )
}

fn scenario(dir: &Path, name: &str, text: &str) -> String {
    let p = dir.join(name);
    std::fs::write(&p, text).unwrap();
    p.to_string_lossy().into_owned()
}

/// Runs `settle` on a scenario and checks the failure names the file and all of `needles`.
fn fails_with(text: &str, pairs: &str, needles: &[&str]) {
    let dir = tempfile::tempdir().unwrap();
    let file = scenario(dir.path(), "bad.toml", text);
    let (code, _, err) = run(&["settle", &file, "--pairs", pairs]);
    assert_ne!(code, 0, "must fail: {err}");
    assert_ne!(code, 101, "a panic is not an error message: {err}");
    assert!(!err.contains("panicked"), "{err}");
    assert!(err.contains("bad.toml"), "names the file: {err}");
    for n in needles {
        assert!(err.contains(n), "expected '{n}' in: {err}");
    }
}

#[test]
fn malformed_toml() {
    fails_with("[magnets\nshape = 1", "0:14", &["bad.toml"]);
}

#[test]
fn unknown_key() {
    fails_with(
        "[magnets]\nstrenght_j = 0.2\n",
        "0:14",
        &["strenght_j", "unknown field"],
    );
}

#[test]
fn wrong_shape_name() {
    fails_with(
        "[magnets]\nshape = \"square\"\n",
        "0:14",
        &["square", "gaussian"],
    );
}

#[test]
fn unknown_settle_method() {
    fails_with(
        "[settle]\nmethod = \"rk4\"\n",
        "0:14",
        &["rk4", "bs32", "dopri5"],
    );
}

#[test]
fn zero_vector_in_points() {
    fails_with(
        "[stator]\npoints = [[0, 0, -1], [0, 0, 0]]\n",
        "0:14",
        &["stator.points[1]", "non-zero"],
    );
}

#[test]
fn nan_vector_in_points() {
    fails_with(
        "[rotor]\npoints = [[0, 0, -1], [nan, 0, 1]]\n",
        "0:0",
        &["rotor.points[1]", "finite"],
    );
}

#[test]
fn negative_tolerance() {
    fails_with(
        "[settle]\ntorque_tol = -1e-4\n",
        "0:14",
        &["settle.torque_tol", "> 0", "-0.0001"],
    );
}

#[test]
fn bad_inertia_entry() {
    fails_with(
        "[body]\ninertia_kg_m2 = [0.02, 0.0, 0.02]\n",
        "0:14",
        &["body.inertia_kg_m2[1]"],
    );
}

#[test]
fn missing_table_file() {
    fails_with(
        "[magnets]\nshape = \"table\"\ntable = \"nope.csv\"\n",
        "0:14",
        &["nope.csv"],
    );
}

#[test]
fn index_out_of_range() {
    let (code, _, err) = run(&["settle", "scenarios/prototype.toml", "--pairs", "0:14,16:3"]);
    assert_eq!(code, 1);
    assert!(
        err.contains("--pairs") && err.contains("coil index below 16"),
        "{err}"
    );
    let (code, _, err) = run(&["settle", "scenarios/prototype.toml", "--pairs", "0:80"]);
    assert_eq!(code, 1);
    assert!(err.contains("magnet index below 80"), "{err}");
}

#[test]
fn coil_twice() {
    let (code, _, err) = run(&["settle", "scenarios/prototype.toml", "--pairs", "3:14,3:20"]);
    assert_eq!(code, 1);
    assert!(err.contains("coil 3 twice"), "{err}");
}

#[test]
fn malformed_pairs_and_orientation() {
    let (code, _, err) = run(&["settle", "scenarios/prototype.toml", "--pairs", "0-14"]);
    assert_eq!(code, 1);
    assert!(err.contains("coil:magnet") && err.contains("0-14"), "{err}");
    let (code, _, err) = run(&[
        "settle",
        "scenarios/prototype.toml",
        "--pairs",
        "0:14",
        "--from",
        "0,0,0,0",
    ]);
    assert_eq!(code, 1);
    assert!(err.contains("--from") && err.contains("non-zero"), "{err}");
}

#[test]
fn bad_line_in_a_sets_file() {
    let dir = tempfile::tempdir().unwrap();
    let sets = dir.path().join("sets.txt");
    std::fs::write(&sets, "0:14,7:68\n# comment\n\n0:14,7:99\n").unwrap();
    let (code, out, err) = run(&[
        "settle",
        "scenarios/prototype.toml",
        "--sets",
        sets.to_str().unwrap(),
    ]);
    assert_eq!(code, 1);
    assert!(out.is_empty());
    assert!(
        err.contains("sets.txt: line 4") && err.contains("below 80"),
        "{err}"
    );
}

#[test]
fn missing_scenario_file() {
    let (code, _, err) = run(&["settle", "no/such.toml", "--pairs", "0:14"]);
    assert_eq!(code, 1);
    assert!(err.contains("no/such.toml"), "{err}");
}

#[test]
fn settle_json_has_the_documented_keys() {
    let (code, out, err) = run(&[
        "settle",
        "scenarios/prototype.toml",
        "--pairs",
        "0:14,7:68",
        "--json",
    ]);
    assert_eq!(code, 0, "{err}");
    let v: serde_json::Value = serde_json::from_str(out.trim()).unwrap();
    for k in [
        "q",
        "settle_time_s",
        "evaluations",
        "steps",
        "energy_j",
        "residual_torque_nm",
        "settled",
    ] {
        assert!(v.get(k).is_some(), "missing {k} in {out}");
    }
    assert_eq!(v["q"].as_array().unwrap().len(), 4);
    assert_eq!(v["settled"], true);
    assert!(v["residual_torque_nm"].as_f64().unwrap() < 1e-4);
}

#[test]
fn settle_reference_runs_dopri5_to_the_same_equilibrium() {
    let settle = |extra: &[&str]| {
        let mut args = vec![
            "settle",
            "scenarios/prototype.toml",
            "--pairs",
            "0:14,7:45,12:26",
            "--from",
            "0.007302,0.036506,0.014601,0.9992",
            "--json",
        ];
        args.extend_from_slice(extra);
        let (code, out, err) = run(&args);
        assert_eq!(code, 0, "{err}");
        serde_json::from_str::<serde_json::Value>(out.trim()).unwrap()
    };
    let fast = settle(&[]);
    let reference = settle(&["--reference"]);
    let q = |v: &serde_json::Value| -> Vec<f64> {
        v["q"]
            .as_array()
            .unwrap()
            .iter()
            .map(|x| x.as_f64().unwrap())
            .collect()
    };
    let dot: f64 = q(&fast).iter().zip(q(&reference)).map(|(a, b)| a * b).sum();
    let angle = 2.0 * dot.abs().min(1.0).acos();
    assert!(angle < 1e-4, "{angle} rad apart");
    assert_eq!(fast["settled"], true);
    assert_eq!(reference["settled"], true);
    // rtol 1e-10 costs many more evaluations than the default's rtol 1e-2
    let evals = |v: &serde_json::Value| v["evaluations"].as_u64().unwrap();
    assert!(evals(&reference) > 5 * evals(&fast), "{fast} {reference}");
}

#[test]
fn sets_csv_rows_follow_the_file_order_and_are_deterministic() {
    let dir = tempfile::tempdir().unwrap();
    let sets = dir.path().join("sets.txt");
    std::fs::write(&sets, "0:14,7:68\n1:44,9:42\n0:14,12:45,7:68\n").unwrap();
    let args = [
        "settle",
        "scenarios/prototype.toml",
        "--sets",
        sets.to_str().unwrap(),
    ];
    let (code, a, err) = run(&args);
    assert_eq!(code, 0, "{err}");
    let (_, b, _) = run(&args);
    assert_eq!(a, b);
    let lines: Vec<&str> = a.lines().collect();
    assert_eq!(lines.len(), 4);
    assert!(lines[0].starts_with("line,active,qx,qy,qz,qw,settle_time_s"));
    assert!(lines[1].starts_with("1,0:14;7:68,"));
    assert!(lines[3].starts_with("3,0:14;12:45;7:68,"));
}

/// A turn of more than 180 degrees can never be measured as reached (the
/// cumulative rotation's angle lies in (-180, 180]); it is refused with the reason, on the
/// command line and in a scenario, instead of searching until the budget runs out.
#[test]
fn targets_beyond_180_degrees_are_refused_with_the_reason() {
    let (code, _, err) = run(&["plan", "scenarios/prototype.toml", "--angle", "200"]);
    assert_eq!(code, 1);
    assert!(err.contains("argument --angle"), "{err}");
    assert!(err.contains("(0, 180] degrees, got 200"), "{err}");
    assert!(err.contains("moves of at most 180 degrees"), "{err}");
    let dir = tempfile::tempdir().unwrap();
    let dir = dir.path();
    let file = scenario(dir, "long.toml", "[plan]\nangle_deg = 270\n");
    let (code, _, err) = run(&["plan", &file]);
    assert_eq!(code, 1);
    assert!(
        err.contains("`plan.angle_deg`") && err.contains("got 270"),
        "{err}"
    );
    let file = scenario(dir, "sweep.toml", "[sweep]\nangles_deg = [90, 181]\n");
    let (code, _, err) = run(&["plan", &file]);
    assert_eq!(code, 1);
    assert!(err.contains("`sweep.angles_deg[1]`"), "{err}");
}

#[test]
fn relay_durations_beyond_their_bounds_are_refused_not_panicked_on() {
    // durations too long for any clock: refused with the field and the bound, in the scenario's
    // [relay], in [[relay.boards]] and in a --map file
    let cases = [
        (
            "[relay]\ntimeout_ms = 1e300\n",
            "relay.timeout_ms",
            "<= 60000, got 1e300",
        ),
        (
            "[relay]\ntimeout_ms = 60001\n",
            "relay.timeout_ms",
            "<= 60000",
        ),
        (
            "[relay]\nmax_on_time_s = 2e19\n",
            "relay.max_on_time_s",
            "<= 86400",
        ),
        (
            "[relay]\ndwell_floor_ms = 1e300\n",
            "relay.dwell_floor_ms",
            "<= 3600000",
        ),
        (
            "[[relay.boards]]\nboard = \"lcus\"\ntimeout_ms = 1e300\n",
            "relay.boards[0].timeout_ms",
            "<= 60000",
        ),
    ];
    for (text, field, bound) in cases {
        fails_with(text, "0:14", &[field, bound]);
    }
    let dir = tempfile::tempdir().unwrap();
    let plan = dir.path().join("plan.csv");
    let (code, _, err) = run(&[
        "plan",
        "scenarios/prototype.toml",
        "--tolerance-deg",
        "2",
        "--out",
        plan.to_str().unwrap(),
    ]);
    assert_eq!(code, 0, "{err}");
    let map = scenario(dir.path(), "boards.toml", "max_on_time_s = 1e300\n");
    let (code, _, err) = run(&[
        "replay",
        plan.to_str().unwrap(),
        "--map",
        &map,
        "--board",
        "lcus",
        "--dry-run",
    ]);
    assert_ne!(code, 0, "{err}");
    assert_ne!(code, 101, "a panic is not an error message: {err}");
    assert!(
        err.contains("boards.toml") && err.contains("max_on_time_s") && err.contains("<= 86400"),
        "{err}"
    );
    // the bounds themselves are accepted
    let ok = scenario(
        dir.path(),
        "edge.toml",
        "[relay]\ntimeout_ms = 60000\nmax_on_time_s = 86400\ndwell_floor_ms = 3600000\n",
    );
    let (code, _, err) = run(&["settle", &ok, "--pairs", "0:14"]);
    assert_eq!(code, 0, "{err}");
}

#[test]
fn a_batch_with_a_scenario_of_overlong_durations_reports_it_and_keeps_the_others() {
    let dir = tempfile::tempdir().unwrap();
    let scenarios = dir.path().join("scenarios");
    std::fs::create_dir(&scenarios).unwrap();
    std::fs::write(scenarios.join("a-good.toml"), "name = \"good\"\n").unwrap();
    std::fs::write(
        scenarios.join("b-bad.toml"),
        "[relay]\ntimeout_ms = 1e300\n",
    )
    .unwrap();
    let out = dir.path().join("out");
    let (code, stdout, err) = run(&[
        "batch",
        scenarios.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
    ]);
    assert_ne!(code, 0, "{stdout}{err}");
    assert_ne!(code, 101, "a panic is not an error message: {err}");
    assert!(
        err.contains("b-bad.toml") && err.contains("relay.timeout_ms"),
        "{err}"
    );
    // the good scenario's result is written all the same
    let good = std::fs::read_to_string(out.join("good.csv")).unwrap();
    assert!(good.lines().count() > 1, "{good}");
}

/// `--out` naming one of the command's inputs (the scenario, the plan, the
/// plant, a sets file, a sim file, a file the scenario reads) is refused before computing,
/// naming both, and the input is left as it was; another spelling of the same file or a link
/// to it is the same file.
#[test]
fn out_naming_an_input_is_refused_and_the_input_kept() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let path = |n: &str| d.join(n).to_string_lossy().into_owned();
    let sc = scenario(d, "p.toml", "[plan]\nangle_deg = 20\n");
    let plant = scenario(d, "q.toml", "[plan]\nangle_deg = 20\n");
    std::fs::copy("scenarios/prototype/rotor.csv", d.join("pts.csv")).unwrap();
    let from_file = scenario(d, "r.toml", "[rotor]\nfile = \"pts.csv\"\n");
    let plan = path("plan.csv");
    let sim = path("sim.csv");
    let well = path("well.csv");
    for args in [
        vec!["plan", &sc, "--out", &plan],
        vec!["simulate", &plan, &sc, "--out", &sim],
        vec!["wells", &sc, "--step-deg", "1", "--out", &well],
    ] {
        let (code, _, err) = run(&args);
        assert_eq!(code, 0, "{args:?}: {err}");
    }
    let table = scenario(
        d,
        "t.toml",
        "[magnets]\nshape = \"table\"\ntable = \"well.csv\"\n",
    );
    let sets = path("sets.txt");
    std::fs::write(&sets, "0:14,7:68\n").unwrap();
    std::fs::create_dir_all(d.join("sub")).unwrap();
    let other_spelling = format!("{}/sub/../p.toml", d.display());
    let link = path("link.csv");
    std::os::unix::fs::symlink(&plan, &link).unwrap();
    let pts = path("pts.csv");
    let cases: Vec<(Vec<&str>, &str)> = vec![
        (vec!["plan", &sc, "--out", &sc], &sc),
        (vec!["plan", &sc, "--out", &other_spelling], &sc),
        (vec!["plan", &from_file, "--out", &pts], &pts),
        (vec!["simulate", &plan, "--out", &plan], &plan),
        (vec!["simulate", &plan, "--out", &link], &plan),
        (vec!["simulate", &plan, &sc, "--out", &sc], &sc),
        (
            vec!["simulate", &plan, &sc, "--plant", &plant, "--out", &plant],
            &plant,
        ),
        (
            vec![
                "simulate",
                &plan,
                &sc,
                "--plant",
                &plant,
                "--closed-loop",
                "--out",
                &plan,
            ],
            &plan,
        ),
        (vec!["run", &sc, "--plant", &plant, "--out", &plant], &plant),
        (vec!["settle", &sc, "--sets", &sets, "--out", &sets], &sets),
        (vec!["wells", &table, "--out", &well], &well),
        (vec!["wells", &sc, "--out", &sc], &sc),
        (vec!["view", &plan, "--out", &plan], &plan),
        (vec!["view", &plan, &sc, "--sim", &sim, "--out", &sim], &sim),
    ];
    for (args, input) in &cases {
        let before = std::fs::read(input).unwrap();
        let (code, _, err) = run(args);
        assert_eq!(code, 1, "{args:?}: {err}");
        let out = args[args.len() - 1];
        assert!(
            err.contains(&format!("argument --out: expected a file that is not one of the command's inputs, got {out}, the same file as {input}")),
            "{args:?}: {err}"
        );
        assert_eq!(
            std::fs::read(input).unwrap(),
            before,
            "{args:?} changed {input}"
        );
    }
    // batch: a scenario whose result would land on a file another scenario reads
    let scen = d.join("scen");
    std::fs::create_dir_all(&scen).unwrap();
    std::fs::write(
        scen.join("a.toml"),
        "name = \"pts\"\n[plan]\nangle_deg = 20\n",
    )
    .unwrap();
    std::fs::write(
        scen.join("b.toml"),
        "[rotor]\nfile = \"../pts.csv\"\n[plan]\nangle_deg = 20\n",
    )
    .unwrap();
    let before = std::fs::read(&pts).unwrap();
    let (code, _, err) = run(&[
        "batch",
        scen.to_str().unwrap(),
        "--out",
        d.to_str().unwrap(),
    ]);
    assert_eq!(code, 1, "{err}");
    assert!(
        err.contains(&pts)
            && err.contains(&format!("the same file as {}/../pts.csv", scen.display())),
        "{err}"
    );
    assert_eq!(
        std::fs::read(&pts).unwrap(),
        before,
        "the rotor file changed"
    );
    assert!(d.join("b.csv").is_file(), "the other scenario still runs");
}

/// Numbers in messages are shown in exponent form when extreme (no
/// 309-digit integers), and control characters in a scenario's name are escaped, never sent to
/// the terminal raw.
#[test]
fn extreme_numbers_and_control_characters_are_shown_escaped() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let cases = [
        (
            "[body]\ndamping_nms = -1e308\n",
            "`body.damping_nms`",
            "got -1e308",
        ),
        (
            "[magnets]\nstrength_j = -1e308\n",
            "`magnets.strength_j`",
            "got -1e308",
        ),
        (
            "[magnets]\nmax_attraction_deg = 1e308\n",
            "`magnets.max_attraction_deg`",
            "got 1e308",
        ),
        (
            "[settle]\nt_max_s = -1e300\n",
            "`settle.t_max_s`",
            "got -1e300",
        ),
        (
            "[plan]\nangle_deg = 1e308\n",
            "`plan.angle_deg`",
            "got 1e308",
        ),
        (
            "[report]\nreference_deg = -1e308\n",
            "`report.reference_deg`",
            "got -1e308",
        ),
        (
            "[rotor]\npoints = [[1e308, 1e308, 0]]\n",
            "`rotor.points[0]`",
            "got [1e308, 1e308, 0]",
        ),
    ];
    for (text, field, got) in cases {
        let file = scenario(d, "big.toml", text);
        let (code, _, err) = run(&["packing", &file]);
        assert_eq!(code, 1, "{text}: {err}");
        assert!(err.contains(field) && err.contains(got), "{text}: {err}");
        assert!(!err.contains("0000000000"), "{text}: {err}");
    }
    let (code, _, err) = run(&["plan", "scenarios/prototype.toml", "--angle", "1e308"]);
    assert_eq!(code, 1);
    assert!(
        err.contains("got 1e308") && !err.contains("0000000000"),
        "{err}"
    );

    let evil = scenario(
        d,
        "evil.toml",
        "name = \"evil\\u001b[31mred\\u0007\\u0000\"\n[plan]\nangle_deg = 20\n",
    );
    let shown = "evil\\u{1b}[31mred\\u{7}\\0";
    let plan = d.join("plan.csv").to_string_lossy().into_owned();
    for args in [
        vec!["packing", &evil],
        vec!["plan", &evil, "--out", &plan],
        vec!["wells", &evil, "--step-deg", "1", "--out", &plan],
    ] {
        let (code, out, err) = run(&args);
        assert_eq!(code, 0, "{args:?}: {err}");
        let all = format!("{out}{err}");
        assert!(
            !all.contains(['\u{1b}', '\u{7}', '\0']),
            "{args:?}: raw control characters: {all:?}"
        );
        assert!(all.contains(shown), "{args:?}: {all}");
    }
}
