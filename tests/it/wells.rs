//! `spherestep wells`: the torque on one magnet passing one coil is the
//! analytic well, the curve written is a `table` that reads back to the same settles, and the
//! command writes the CSV, its picture and refuses a bad step.

use crate::common;

use common::{identity, nearest_magnet, run};
use nalgebra::Vector3;
use spherestep::commands::wells::{curve_csv, summarise, well_curve, DEFAULT_STEP_DEG};
use spherestep::io::scenario::Scenario;
use spherestep::model::geometry::{rot_q, unit, CoilId, Pair, Radians};
use spherestep::physics::dynamics::settle;
use std::path::Path;

fn load(name: &str) -> Scenario {
    Scenario::load(Path::new(name)).unwrap()
}

#[test]
fn the_curve_is_the_analytic_well() {
    // gaussian: g(d) = k d / sigma^2 exp(-d^2 / (2 sigma^2)), k = 0.25 J, sigma = 10 degrees
    let sc = load("scenarios/prototype.toml");
    let curve = well_curve(&sc.torques.well, DEFAULT_STEP_DEG).unwrap();
    assert_eq!(curve.len(), 1501);
    assert_eq!(curve[0], (0.0, 0.0));
    assert_eq!(curve[1500].0, 30.0);
    let (k, s) = (0.25, 10f64.to_radians());
    for &(deg, g) in &curve {
        let d = deg.to_radians();
        let analytic = k * d / (s * s) * (-d * d / (2.0 * s * s)).exp();
        assert!((g - analytic).abs() < 1e-9, "{deg} deg: {g} vs {analytic}");
    }
    let sum = summarise(&sc.torques.well, &curve);
    assert_eq!(sum.peak_angle_deg, 10.0);
    assert!((sum.peak_torque_nm - k / s * (-0.5f64).exp()).abs() < 1e-9);
    // cosine: g(d) = k sin d
    let broad = load("scenarios/broad-wells.toml");
    let curve = well_curve(&broad.torques.well, 0.5).unwrap();
    assert_eq!(curve.last().unwrap().0, 40.0);
    for &(deg, g) in &curve {
        assert!(
            (g - 1.35 * deg.to_radians().sin()).abs() < 1e-9,
            "{deg} deg"
        );
    }
}

#[test]
fn a_curve_read_back_as_a_table_settles_the_same() {
    let dir = tempfile::tempdir().unwrap();
    let sc = load("scenarios/prototype.toml");
    let curve = well_curve(&sc.torques.well, DEFAULT_STEP_DEG).unwrap();
    std::fs::write(dir.path().join("torque.csv"), curve_csv(&curve).unwrap()).unwrap();
    let table_toml = dir.path().join("table.toml");
    std::fs::write(
        &table_toml,
        "[magnets]\nshape = \"table\"\ntable = \"torque.csv\"\nmax_attraction_deg = 30.0\n",
    )
    .unwrap();
    let table = Scenario::load(&table_toml).unwrap();
    // both settled tightly, so that what is compared is the wells, not the settle test
    let tight = |s: &Scenario| spherestep::physics::dynamics::SettleParams {
        torque_tol: 1e-10,
        omega_tol: 1e-8,
        t_max: 30.0,
        ..s.settle.reference()
    };
    let q0 = rot_q(&unit(Vector3::new(0.2, 1.0, 0.4)).unwrap(), Radians(0.08));
    let pair = |c: usize| Pair {
        coil: CoilId(c),
        magnet: nearest_magnet(&sc, c, &identity()).0,
    };
    for set in [vec![pair(0), pair(7)], vec![pair(0), pair(7), pair(12)]] {
        let a = settle(&sc.torques, &set, &q0, sc.body, tight(&sc));
        let b = settle(&table.torques, &set, &q0, table.body, tight(&table));
        assert!(a.settled && b.settled, "{a:?} {b:?}");
        let apart = a.q.angle_to(&b.q);
        assert!(apart < 1e-6, "{set:?}: {apart} rad apart");
        assert!(
            apart > 0.0,
            "a table is an interpolation, not the same function"
        );
    }
}

#[test]
fn the_command_writes_the_csv_and_its_picture_and_refuses_a_bad_step() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("soft.csv");
    let (code, stdout, stderr) = run(&[
        "wells",
        "scenarios/soft-wells.toml",
        "--out",
        out.to_str().unwrap(),
        "--json",
    ]);
    assert_eq!(code, 0, "{stderr}");
    let s: serde_json::Value = serde_json::from_str(stdout.trim()).unwrap();
    assert_eq!(s["peak_angle_deg"], 14.0);
    assert_eq!(s["cutoff_deg"], 30.0);
    let text = std::fs::read_to_string(&out).unwrap();
    assert!(
        text.starts_with("angle_deg,torque_nm\n0,0\n0.02,"),
        "{text:.60}"
    );
    for ext in ["svg", "png"] {
        let pic = dir.path().join(format!("soft.{ext}"));
        assert!(std::fs::metadata(&pic).unwrap().len() > 1000, "{ext}");
    }
    // without --out the CSV alone goes to standard output
    let (code, stdout, stderr) = run(&["wells", "--step-deg", "1"]);
    assert_eq!(code, 0, "{stderr}");
    assert_eq!(stdout.lines().count(), 32);
    assert!(
        stderr.contains("peak pull 0.8688 N m at 10.00 deg"),
        "{stderr}"
    );
    for bad in ["0", "-1", "NaN", "11"] {
        let bad = format!("--step-deg={bad}");
        let (code, _, stderr) = run(&["wells", &bad]);
        assert_eq!(code, 1);
        assert!(
            stderr.contains("--step-deg") && stderr.contains("[0.001, 10]"),
            "{stderr}"
        );
    }
}

/// A step so small that the curve cannot be held (`1e-300`: more rows than
/// memory has addresses; `1e-7`: gigabytes) is refused with the bound, not a panic or a
/// machine out of memory.
#[test]
fn tiny_angle_steps_are_refused_with_the_bound() {
    for (bad, shown) in [
        ("1e-300", "1e-300"),
        ("1e-7", "1e-7"),
        ("0.0009", "0.0009"),
        ("5e-324", "5e-324"),
    ] {
        let arg = format!("--step-deg={bad}");
        let (code, stdout, stderr) = run(&["wells", &arg]);
        assert_eq!(code, 1, "{bad}: {stderr}");
        assert!(stdout.is_empty(), "{bad}");
        assert!(
            stderr.contains(&format!(
                "argument --step-deg: expected an angle step in [0.001, 10] degrees, got {shown}"
            )),
            "{bad}: {stderr}"
        );
    }
    let (code, stdout, stderr) = run(&["wells", "--step-deg", "0.001"]);
    assert_eq!(code, 0, "{stderr}");
    assert_eq!(
        stdout.lines().count(),
        30_002,
        "0 to 30 degrees by 0.001, and the header"
    );
}
