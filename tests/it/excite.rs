//! `plan --excite`: an excitation run is what the hardware may play (the supply with the set
//! before, the on-time limit as `replay` counts it: its dry run takes the file), every row is
//! where the motor's settle takes the ball from the row before, and one seed gives one file.

use crate::common::{excite, run};
use spherestep::io::planfile::read_plan;
use spherestep::io::scenario::Scenario;
use spherestep::physics::dynamics::settle;
use std::collections::BTreeSet;

/// The prototype with a supply of 3 coils and a 3 s on-time limit: a coil held through two
/// slow steps is over it, so most draws are refused (817 for 41 rows with seed 5; with a 2 s
/// limit no run of 40 steps is found).
const TIGHT: &str = "name = \"tight\"\n[rotor]\npreset = \"prototype\"\n[stator]\n\
                     preset = \"prototype\"\n[relay]\nboard = \"numato\"\nmax_coils_on = 3\n\
                     max_on_time_s = 3.0\n";

#[test]
fn an_excitation_run_is_what_the_supply_and_the_on_time_limit_allow_and_where_the_ball_settles() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let sc_path = d.join("tight.toml");
    std::fs::write(&sc_path, TIGHT).unwrap();
    let plan = d.join("excite.csv");
    let summary = excite(sc_path.to_str().unwrap(), "40", "5", &plan);
    let rows = read_plan(&plan).unwrap();
    assert_eq!(rows.len(), 41);
    assert_eq!(summary["steps"], 40);
    // some draws were refused (by the supply, the on-time limit or an unsettled set)
    assert!(summary["draws"].as_u64().unwrap() > 41, "{summary}");
    let sc = Scenario::load(&sc_path).unwrap();
    let motor = sc.motor();
    let mut q = sc.plan.start;
    let mut before: BTreeSet<usize> = BTreeSet::new();
    let mut sizes = BTreeSet::new();
    for r in &rows {
        let set: BTreeSet<usize> = r.active.iter().map(|p| p.coil.0).collect();
        assert_eq!(set.len(), r.active.len(), "a coil twice: {r:?}");
        sizes.insert(set.len());
        assert!(set.union(&before).count() <= 3, "{before:?} then {set:?}");
        assert_ne!(set, before);
        // the new pairs are the coils the set before did not have
        let new: BTreeSet<usize> = r.new.iter().map(|p| p.coil.0).collect();
        assert_eq!(new, &set - &before);
        // where the motor's settle takes the ball from the row before (the file's numbers are
        // read back renormalised, within an ulp)
        let s = settle(&motor.torques, &r.active, &q, motor.body, motor.settle);
        assert!(s.settled && r.settled);
        let (off, late) = (s.q.angle_to(&r.q), s.arrival_time_s - r.settle_time_s);
        assert!(
            off < 1e-9 && late.abs() < 1e-9,
            "step {}: {off} rad, {late} s",
            r.step
        );
        q = r.q;
        before = set;
    }
    assert_eq!(sizes, BTreeSet::from([2, 3]));
    // the replay's own schedule check (supply, on-time with its dwells) takes the file
    let args = ["replay", plan.to_str().unwrap(), sc_path.to_str().unwrap()];
    let (code, out, err) = run(&[&args[..], &["--dry-run"]].concat());
    assert_eq!(code, 0, "{out}{err}");
    assert!(
        out.contains("41 step(s) replayed; all coils off"),
        "{out}{err}"
    );
    // the same seed, the same bytes; another seed, another run
    let again = d.join("again.csv");
    excite(sc_path.to_str().unwrap(), "40", "5", &again);
    assert_eq!(
        std::fs::read(&plan).unwrap(),
        std::fs::read(&again).unwrap()
    );
    excite(sc_path.to_str().unwrap(), "40", "6", &again);
    assert_ne!(
        std::fs::read(&plan).unwrap(),
        std::fs::read(&again).unwrap()
    );
}

#[test]
fn an_excitation_run_that_the_supply_cannot_power_is_refused_naming_it() {
    let dir = tempfile::tempdir().unwrap();
    let sc_path = dir.path().join("one.toml");
    std::fs::write(
        &sc_path,
        TIGHT.replace("max_coils_on = 3", "max_coils_on = 2"),
    )
    .unwrap();
    let (code, out, err) = run(&["plan", sc_path.to_str().unwrap(), "--excite", "5"]);
    assert_ne!(code, 0, "{out}");
    assert!(!err.contains("panicked"), "{err}");
    assert!(
        err.contains("so it needs a supply of 3 coils or more, but the supply powers 2"),
        "{err}"
    );
    for (args, want) in [
        (
            vec!["--excite", "0"],
            "argument --excite: expected 1 to 10000 steps, got 0",
        ),
        (vec!["--seed", "3"], "--excite"),
        (
            vec!["--excite", "4", "--axis", "1,0,0"],
            "cannot be used with",
        ),
    ] {
        let all = [&["plan", "scenarios/prototype.toml"][..], &args].concat();
        let (code, out, err) = run(&all);
        assert_ne!(code, 0, "{args:?}: {out}");
        assert!(err.contains(want), "{args:?}: wanted `{want}` in {err}");
    }
}
