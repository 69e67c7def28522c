//! Input that would silently give a wrong answer is refused, naming the file (or argument), the
//! field or line, and what was expected: coordinate files without a header, coincident magnets
//! or coils, stray separators in pairs, a zero baud rate, plan files without row 0 or with a
//! negative settle time, a device (`/dev/zero`) where a file is meant.

use crate::common;

use spherestep::io::scenario::Scenario;
use spherestep::parse_pairs;
use std::path::Path;

use common::run;

fn load(dir: &Path, toml: &str) -> Result<Scenario, String> {
    let p = dir.join("motor.toml");
    std::fs::write(&p, toml).unwrap();
    Scenario::load(&p).map_err(|e| e.to_string())
}

fn assert_has(text: &str, needles: &[&str]) {
    for n in needles {
        assert!(text.contains(n), "expected '{n}' in: {text}");
    }
}

#[test]
fn coordinate_csv_without_header_is_refused_not_shortened() {
    let t = tempfile::tempdir().unwrap();
    std::fs::write(
        t.path().join("stator3.csv"),
        "0,0,-1\n0.3,0,-0.95\n0,0.3,-0.95\n",
    )
    .unwrap();
    let e = load(t.path(), "[stator]\nfile = \"stator3.csv\"\n").unwrap_err();
    assert_has(
        &e,
        &[
            "motor.toml",
            "stator.file",
            "stator3.csv",
            "line 1",
            "x,y,z",
        ],
    );
    // With the header all three coils are there, and a bad row names its line in the file.
    std::fs::write(
        t.path().join("stator3.csv"),
        "x,y,z\n0,0,-1\n0.3,0,-0.95\n0,0.3,-0.95\n",
    )
    .unwrap();
    let sc = load(t.path(), "[stator]\nfile = \"stator3.csv\"\n").unwrap();
    assert_eq!(sc.stator.len(), 3);
    std::fs::write(t.path().join("stator3.csv"), "x,y,z\n0,0,-1\n0.3,a,-0.95\n").unwrap();
    let e = load(t.path(), "[stator]\nfile = \"stator3.csv\"\n").unwrap_err();
    assert_has(&e, &["line 3", "'a' is not a number"]);
}

#[test]
fn torque_table_without_header_is_refused() {
    let t = tempfile::tempdir().unwrap();
    std::fs::write(t.path().join("g.csv"), "0,0\n10,0.5\n30,0\n").unwrap();
    let e = load(
        t.path(),
        "[magnets]\nshape = \"table\"\ntable = \"g.csv\"\n",
    )
    .unwrap_err();
    assert_has(
        &e,
        &["magnets.table", "g.csv", "line 1", "angle_deg,torque_nm"],
    );
    std::fs::write(
        t.path().join("g.csv"),
        "angle_deg,torque_nm\n0,0\n10,0.5\n30,0\n",
    )
    .unwrap();
    load(
        t.path(),
        "[magnets]\nshape = \"table\"\ntable = \"g.csv\"\n",
    )
    .unwrap();
}

#[test]
fn coincident_magnets_and_coils_are_refused_with_both_indices() {
    let t = tempfile::tempdir().unwrap();
    let e = load(
        t.path(),
        "[rotor]\npoints = [[0, 0, 1], [1, 0, 0], [0, 1, 0], [0, 0, 2]]\n",
    )
    .unwrap_err();
    assert_has(&e, &["motor.toml", "rotor.points", "magnets 0 and 3"]);
    std::fs::write(
        t.path().join("st.csv"),
        "x,y,z\n0,0,-1\n0.3,0,-0.95\n0,0.3,-0.95\n0.6,0,-1.9\n",
    )
    .unwrap();
    let e = load(t.path(), "[stator]\nfile = \"st.csv\"\n").unwrap_err();
    assert_has(&e, &["stator.file", "coils 1 and 3"]);
    // Close but distinct points are fine.
    load(t.path(), "[rotor]\npoints = [[0, 0, 1], [0.001, 0, 1]]\n").unwrap();
}

#[test]
fn pairs_with_a_stray_separator_are_refused() {
    for bad in ["0:14,,", "0:14,,3:5", ";0:14", "0:14;", " , "] {
        let e = parse_pairs(bad, "--pairs").unwrap_err().to_string();
        assert_has(&e, &["--pairs", "coil:magnet"]);
    }
    assert_eq!(parse_pairs(" 0:14 ; 3:5 ", "--pairs").unwrap().len(), 2);
    let (code, _, err) = run(&["settle", "scenarios/prototype.toml", "--pairs", "0:14,,"]);
    assert_eq!(code, 1, "{err}");
    assert_has(&err, &["--pairs", "empty pair"]);
}

/// A 2-step plan file (row 0 and two steps) with the given settle time of step 1 and first
/// step number.
fn plan_file(dir: &Path, first: usize, settle: &str) -> String {
    let p = dir.join("plan.csv");
    std::fs::write(
        &p,
        format!(
            "step,pivot_coil,pivot_magnet,new_coil,new_magnet,active,qx,qy,qz,qw,step_angle_deg,step_axis_error_deg,cum_angle_deg,cum_axis_error_deg,settle_time_s\n\
             {first},,,0;1,10;11,0:10;1:11,0,0,0,1,0,0,0,0,0.12\n\
             {},0,10,2,12,0:10;2:12,0,0,0.1,0.995,11.4,0.5,11.4,0.5,{settle}\n",
            first + 1
        ),
    )
    .unwrap();
    p.to_string_lossy().into_owned()
}

#[test]
fn replay_refuses_zero_baud_and_bad_plans() {
    let t = tempfile::tempdir().unwrap();
    let good = plan_file(t.path(), 0, "0.2");
    let (code, out, err) = run(&["replay", &good, "--board", "modbus", "--dry-run"]);
    assert_eq!(code, 0, "{out}{err}");
    let (code, out, err) = run(&[
        "replay",
        &good,
        "--board",
        "modbus",
        "--dry-run",
        "--baud",
        "0",
    ]);
    assert_eq!(code, 1, "{out}{err}");
    assert_has(&err, &["--baud", "from 1 to 4000000", "got 0"]);
    assert!(!out.contains("01 05"), "nothing sent: {out}");

    let negative = plan_file(t.path(), 0, "-0.5");
    let (code, out, err) = run(&["replay", &negative, "--board", "modbus", "--dry-run"]);
    assert_eq!(code, 1, "{out}{err}");
    assert_has(
        &err,
        &["plan.csv", "line 3", "settle_time_s", ">= 0", "-0.5"],
    );

    let no_row_0 = plan_file(t.path(), 1, "0.2");
    let (code, out, err) = run(&["replay", &no_row_0, "--board", "modbus", "--dry-run"]);
    assert_eq!(code, 1, "{out}{err}");
    assert_has(&err, &["plan.csv", "line 2", "step 0", "got 1"]);
    let (code, _, err) = run(&["simulate", &no_row_0]);
    assert_eq!(code, 1, "{err}");
    assert_has(&err, &["step 0"]);
}

/// The physical prototype's `[magnets]` with `from` replaced by `to` (a line of the file).
fn physical_with(from: &str, to: &str) -> String {
    let text = std::fs::read_to_string("scenarios/prototype-physical.toml").unwrap();
    assert!(text.contains(from), "{from}");
    text.replace(from, to)
}

/// A well whose strongest torque is below `settle.torque_tol` passes the settle
/// test everywhere at t = 0: every set "held", pivot plans with settle time 0 at every step.
/// Such a scenario is refused at load, naming the field that makes the well and the tolerance.
#[test]
fn a_well_weaker_than_the_torque_tolerance_is_refused() {
    let t = tempfile::tempdir().unwrap();
    // a well this weak once passed the settle test at t = 0: "settled: yes at t = 0.000000 s", held
    let weak = t.path().join("weak.toml");
    std::fs::write(&weak, "[magnets]\nstrength_j = 1e-6\n").unwrap();
    let (code, out, err) = run(&["settle", weak.to_str().unwrap(), "--pairs", "0:14;3:24"]);
    assert_eq!(code, 1, "{out}{err}");
    assert!(!out.contains("settled: yes"), "{out}");
    assert_has(
        &err,
        &["weak.toml", "`magnets.strength_j`", "settle.torque_tol"],
    );
    let e = load(t.path(), "[magnets]\nstrength_j = 1e-6\n").unwrap_err();
    assert_has(
        &e,
        &[
            "motor.toml",
            "`magnets.strength_j`",
            "settle.torque_tol = 0.0001 N m",
            "got 3.4751",
        ],
    );
    // the dipole of a coil with next to no turns: its peak torque is 1e-304 N m
    let e = load(
        t.path(),
        &physical_with("coil_turns = 2000", "coil_turns = 1e-300"),
    )
    .unwrap_err();
    assert_has(&e, &["`magnets`", "settle.torque_tol", "e-304 N m"]);
    // a tolerance above the peak is the same mistake, and a weak well under a tighter
    // tolerance is a scenario like any other (its settle takes time)
    let e = load(t.path(), "[settle]\ntorque_tol = 1.0\n").unwrap_err();
    assert_has(&e, &["`magnets.strength_j`", "settle.torque_tol = 1 N m"]);
    let sc = load(
        t.path(),
        "[magnets]\nstrength_j = 1e-6\n[settle]\ntorque_tol = 1e-9\nomega_tol = 1e-6\n",
    )
    .unwrap();
    let q0 = nalgebra::UnitQuaternion::from_scaled_axis(nalgebra::Vector3::new(0.02, 0.0, 0.0));
    let r = spherestep::physics::dynamics::settle(
        &sc.torques,
        &parse_pairs("0:14;3:24", "--pairs").unwrap(),
        &q0,
        sc.body,
        sc.settle,
    );
    assert!(r.settle_time_s > 0.0, "{r:?}");
}

/// Messages that named the wrong cause.
#[test]
fn messages_name_the_cause() {
    let t = tempfile::tempdir().unwrap();
    // an infinite current was blamed on coil_ampere_turns, a negative one too
    for (bad, got) in [("inf", "got inf"), ("-0.8", "got -0.8")] {
        let e = load(
            t.path(),
            &physical_with("coil_current_a = 0.8", &format!("coil_current_a = {bad}")),
        )
        .unwrap_err();
        assert_has(&e, &["`magnets.coil_current_a`", got]);
        assert!(!e.contains("coil_ampere_turns"), "{e}");
    }
    // a huge disc was blamed on magnet_moment_am2, its volume spelt out in 300 digits
    let e = load(
        t.path(),
        &physical_with("magnet_diameter_m = 0.01905", "magnet_diameter_m = 1e300"),
    )
    .unwrap_err();
    assert_has(&e, &["`magnets.magnet_diameter_m`", "volume", "1e300"]);
    assert!(!e.contains("magnet_moment_am2") && e.len() < 300, "{e}");
    // "expected the parts attract nowhere" said the opposite of what was expected
    let e = load(
        t.path(),
        &physical_with(
            "coil_turns = 2000\ncoil_current_a = 0.8",
            "coil_ampere_turns = 5e-324",
        ),
    )
    .unwrap_err();
    assert_has(
        &e,
        &["`magnets`: expected parts whose coil attracts a magnet"],
    );
    assert!(!e.contains("expected the parts attract nowhere"), "{e}");
    // a missing rotor file named neither the scenario nor the field
    let e = load(t.path(), "[rotor]\nfile = \"nope.csv\"\n").unwrap_err();
    assert_has(&e, &["motor.toml", "`rotor.file`", "nope.csv"]);
    // an empty board said "expected expected"
    let e = load(t.path(), "[relay]\nboard = \"\"\n").unwrap_err();
    assert_has(
        &e,
        &["`relay.board`: expected lcus, kmtronic, numato or modbus, got ''"],
    );
    let e = load(t.path(), "[[relay.boards]]\nboard = \"x\"\n").unwrap_err();
    assert!(!e.contains("expected expected"), "{e}");
    // more pairs per step than the supply powers: "no sequence within its budget", 0 settles
    let (code, _, err) = run(&[
        "plan",
        "scenarios/prototype.toml",
        "--pairs",
        "5",
        "--angle",
        "30",
    ]);
    assert_eq!(code, 1, "{err}");
    assert_has(&err, &["--pairs", "5 pairs", "max_coils_on is 4"]);
    assert!(!err.contains("budget"), "{err}");
    let e = load(
        t.path(),
        "[plan]\npairs_per_step = 5\nmodel = \"dynamic\"\n",
    )
    .unwrap_err();
    assert_has(&e, &["`plan.pairs_per_step`", "max_coils_on is 4"]);
    // a well so strong that the motion overflows was "the step size collapsed"
    let strong = t.path().join("strong.toml");
    std::fs::write(&strong, "[magnets]\nstrength_j = 1e300\n").unwrap();
    let (_, out, err) = run(&["settle", strong.to_str().unwrap(), "--pairs", "0:14;3:24"]);
    assert_has(
        &out,
        &["overflowed double precision", "energy: -4.178940e299 J"],
    );
    assert!(!out.contains("collapsed") && out.len() < 600, "{out}{err}");
}

/// Runs the binary with `args`, waiting at most a minute: a run still going then (reading a
/// device without end) is killed and the test fails instead of hanging. Exit code and stderr.
fn run_bounded(args: &[&str]) -> (Option<i32>, String) {
    use std::io::Read;
    let mut child = std::process::Command::new(common::bin())
        .args(args)
        .stdin(std::process::Stdio::null())
        .stdout(std::process::Stdio::null())
        .stderr(std::process::Stdio::piped())
        .spawn()
        .unwrap();
    let mut stderr = child.stderr.take().unwrap();
    let reader = std::thread::spawn(move || {
        let mut s = String::new();
        let _ = stderr.read_to_string(&mut s);
        s
    });
    for _ in 0..600 {
        if let Some(status) = child.try_wait().unwrap() {
            return (status.code(), reader.join().unwrap());
        }
        std::thread::sleep(std::time::Duration::from_millis(100));
    }
    let _ = child.kill();
    let _ = child.wait();
    panic!(
        "`spherestep {}` still running after a minute: killed",
        args.join(" ")
    );
}

/// Where a file is meant, a device is refused before a byte of it is read (it used to be read
/// without end: 4.8 GB of `/dev/zero` after 3 s), naming the file and what was expected.
#[test]
fn devices_are_refused_where_a_file_is_meant() {
    let t = tempfile::tempdir().unwrap();
    let z = t.path().join("zero-rotor.toml");
    std::fs::write(&z, "[rotor]\nfile = \"/dev/zero\"\n").unwrap();
    let sc = "scenarios/prototype.toml";
    let cases: [&[&str]; 5] = [
        &["plan", z.to_str().unwrap()],
        &["simulate", "/dev/zero", sc],
        &["plan", sc, "--waypoints", "/dev/zero"],
        &["settle", sc, "--sets", "/dev/zero"],
        &["replay", "/dev/zero", sc, "--dry-run"],
    ];
    for args in cases {
        let (code, err) = run_bounded(args);
        assert_eq!(code, Some(1), "{args:?}: {err}");
        assert_has(
            &err,
            &[
                "/dev/zero",
                "expected a regular file, got a character device",
            ],
        );
        assert!(!err.contains("panicked"), "{args:?}: {err}");
    }
    let (_, err) = run_bounded(&["plan", z.to_str().unwrap()]);
    assert_has(&err, &["zero-rotor.toml", "rotor.file"]);
}
