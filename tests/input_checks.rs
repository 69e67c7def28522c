//! Input that would silently give a wrong answer is refused, naming the file (or argument), the
//! field or line, and what was expected: coordinate files without a header, coincident magnets
//! or coils, stray separators in pairs, a zero baud rate, plan files without row 0 or with a
//! negative settle time.

mod common;

use spherestep::io::scenario::Scenario;
use spherestep::model::geometry::parse_pairs;
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
