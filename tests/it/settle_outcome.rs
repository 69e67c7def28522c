//! What a settle came to: a set whose pairs are out of reach is not
//! "held" although nothing moves; a half-held set is its own outcome; the reason a settle
//! stopped is said in JSON and text.

use spherestep::commands::{settle_one, settle_sets, Holding};
use spherestep::io::scenario::Scenario;
use spherestep::model::geometry::Pair;
use spherestep::parse_pairs;
use spherestep::physics::dynamics::settle;

fn proto() -> Scenario {
    Scenario::load(std::path::Path::new("scenarios/prototype.toml")).unwrap()
}

fn identity() -> spherestep::model::geometry::Orientation {
    nalgebra::UnitQuaternion::identity()
}

/// Angle between a pair's magnet and coil at orientation `q`, radians.
fn gap(sc: &Scenario, q: &spherestep::model::geometry::Orientation, p: Pair) -> f64 {
    (q * sc.torques.rotor[p.magnet.0]).angle(&sc.torques.stator[p.coil.0])
}

#[test]
fn a_pair_out_of_reach_holds_nothing() {
    let sc = proto();
    let far = Pair::new(0, 15);
    let reach = sc.torques.well.max_attraction().0;
    assert!(
        gap(&sc, &identity(), far) > reach,
        "the test needs 0:15 out of reach"
    );
    let r = settle(&sc.torques, &[far], &identity(), sc.body, sc.settle);
    // Nothing pulls, so nothing moves: the settle test passes at once ...
    assert!(r.settled);
    // ... but the set holds nothing, and says so.
    let h = Holding::of(&sc.torques, &[far], &r.q);
    assert_eq!(h.held, vec![]);
    assert_eq!(h.not_held, vec![far]);
    assert_eq!(h.outcome(r.settled), "unheld");
    let mut out = Vec::new();
    settle_one(&sc, "0:15", &identity(), true, &mut out).unwrap();
    let v: serde_json::Value = serde_json::from_slice(&out).unwrap();
    assert_eq!(v["settled"], true);
    assert_eq!(v["outcome"], "unheld");
    assert_eq!(v["held"], "");
    assert_eq!(v["not_held"], "0:15");
    assert_eq!(v["stop"], "settled");
}

#[test]
fn a_half_held_set_is_its_own_outcome() {
    let sc = proto();
    let reach = sc.torques.well.max_attraction().0;
    let held = sc.check_active(&[Pair::new(0, 14), Pair::new(12, 26)], "t");
    assert!(held.is_ok());
    // 0:14 and 12:26 hold the ball together.
    let both = parse_pairs("0:14,12:26", "t").unwrap();
    let r = settle(&sc.torques, &both, &identity(), sc.body, sc.settle);
    let h = Holding::of(&sc.torques, &both, &r.q);
    assert_eq!(h.outcome(r.settled), "held");
    // 0:14 with a pair whose magnet stays far out of its coil's reach: partly held.
    let far = (0..sc.torques.rotor.len())
        .map(|m| Pair::new(12, m))
        .find(|&p| gap(&sc, &r.q, p) > reach + 0.5)
        .expect("some magnet is far from coil 12");
    let set = vec![Pair::new(0, 14), far];
    let r = settle(&sc.torques, &set, &identity(), sc.body, sc.settle);
    assert!(r.settled);
    let h = Holding::of(&sc.torques, &set, &r.q);
    assert_eq!(h.held, vec![Pair::new(0, 14)]);
    assert_eq!(h.not_held, vec![far]);
    assert_eq!(h.outcome(r.settled), "partly held");
    // The sets CSV says the same, per line.
    let mut out = Vec::new();
    settle_sets(&sc, &[both, set], &identity(), &mut out).unwrap();
    let text = String::from_utf8(out).unwrap();
    let lines: Vec<&str> = text.lines().collect();
    assert!(lines[0].ends_with(",settled,held,outcome"), "{}", lines[0]);
    assert!(lines[1].ends_with(",true,0:14;12:26,held"), "{}", lines[1]);
    assert!(lines[2].ends_with(",true,0:14,partly held"), "{}", lines[2]);
}

#[test]
fn an_undamped_ball_says_why_it_did_not_settle() {
    let mut sc = proto();
    sc.body.damping = 0.0;
    sc.settle.t_max = 2.0;
    let mut out = Vec::new();
    let r = settle_one(&sc, "0:14,12:26", &identity(), false, &mut out).unwrap();
    assert!(!r.settled);
    let text = String::from_utf8(out).unwrap();
    assert!(
        text.contains("settled: NO (not settled by t_max)"),
        "{text}"
    );
    assert!(text.contains("outcome: not settled"), "{text}");
}
