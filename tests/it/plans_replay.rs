//! The default plans are replayable: planned on the prototype about X, Y, Z and (1, 1, 1) by 90
//! degrees, each passes replay's own schedule check (the dry run's: coils on at once and one
//! coil's on-time with the replay's dwells) with the scenario's relay limits.

use spherestep::commands::{plan_settings, PlanOverrides};
use spherestep::io::scenario::Scenario;
use std::path::Path;

#[test]
fn the_default_plans_pass_replays_schedule_check() {
    let sc = Scenario::load(Path::new("scenarios/prototype.toml")).unwrap();
    for axis in ["1,0,0", "0,1,0", "0,0,1", "1,1,1"] {
        let s = plan_settings(
            &sc,
            &PlanOverrides {
                axis: Some(axis.into()),
                angle_deg: Some(90.0),
                ..Default::default()
            },
        )
        .unwrap();
        assert_eq!(s.limits.on_time, Some(sc.relay.on_time_limit()));
        assert_eq!(s.limits.max_coils_on, sc.relay.max_coils_on);
        let p = sc.motor().plan(&s);
        let off = p.summary(&s).final_orientation_error_deg;
        assert!(off < 2.0, "about {axis}: {:?}", p.message);
        let checked = crate::common::replay_check(&sc, &p.rows);
        assert!(checked.is_ok(), "about {axis}: {:?}", checked.err());
    }
}

#[test]
fn a_limit_no_plan_can_keep_is_said_in_the_message() {
    // a coil may stay on for no more than the dwell floor: no step can hold the ball
    let dir = tempfile::tempdir().unwrap();
    let f = dir.path().join("tight.toml");
    std::fs::write(&f, "[relay]\nmax_on_time_s = 0.3\n").unwrap();
    let sc = Scenario::load(&f).unwrap();
    let p = sc.motor().plan(&sc.plan);
    assert!(!p.reached);
    let m = p.message.unwrap_or_default();
    assert!(m.contains("relay.max_on_time_s"), "{m}");
}
