//! What a settle claims at the edges: an undamped ball never settles, every settle has a
//! bounded cost and says which limit stopped it, the reference says why it stopped.

use nalgebra::Vector3;
use spherestep::io::scenario::Scenario;
use spherestep::model::geometry::{rot_q, unit, Pair, Radians};
use spherestep::physics::dynamics::{settle, Method, SettleParams, Stop};

fn proto() -> Scenario {
    Scenario::load(std::path::Path::new("scenarios/prototype.toml")).unwrap()
}

#[test]
fn an_undamped_ball_is_never_settled() {
    // With c = 0 the default stepper's own dissipation used to settle
    // `0:14,12:26` at 41.3 s
    let mut sc = proto();
    sc.body.damping = 0.0;
    sc.settle.t_max = 100.0;
    let set = [Pair::new(0, 14), Pair::new(12, 26)];
    let q0 = spherestep::model::geometry::Orientation::identity();
    let r = settle(&sc.torques, &set, &q0, sc.body, sc.settle);
    assert!(!r.settled, "{r:?}");
    assert_eq!(r.stop, Stop::TimeLimit);
    assert_eq!(r.settle_time_s, 100.0);
    // and from a few other starts and sets
    for (k, axis) in [[1.0, 0.2, 0.0], [0.3, -1.0, 0.5], [0.0, 0.4, 1.0]]
        .iter()
        .enumerate()
    {
        let q0 = rot_q(&unit(Vector3::from(*axis)).unwrap(), Radians(0.1));
        // each coil with the magnet nearest to it, 0 to 20 degrees away: pairs that hold
        let near = |c: usize| {
            let m = spherestep::planning::commutation::nearest_magnet(
                &sc.torques,
                spherestep::model::geometry::CoilId(c),
                &q0,
            );
            Pair::new(c, m.0 .0)
        };
        let set = [near(k), near(7 + k)];
        sc.settle.t_max = 20.0;
        let r = settle(&sc.torques, &set, &q0, sc.body, sc.settle);
        assert!(!r.settled, "{set:?}: {r:?}");
    }
}

#[test]
fn a_lightly_damped_ball_settles_when_the_reference_says() {
    // 2% of the prototype's damping: the end comes late, and at the reference's time
    let mut sc = proto();
    sc.body.damping *= 0.02;
    sc.settle.t_max = 100.0;
    let set = [Pair::new(0, 14), Pair::new(12, 26)];
    let q0 = spherestep::model::geometry::Orientation::identity();
    let fast = settle(&sc.torques, &set, &q0, sc.body, sc.settle);
    let reference = settle(&sc.torques, &set, &q0, sc.body, sc.settle.reference());
    assert!(reference.settled, "{reference:?}");
    assert!(fast.settled, "{fast:?}");
    assert!(fast.q.angle_to(&reference.q) < 1e-4);
    let dt = (fast.settle_time_s - reference.settle_time_s).abs();
    assert!(
        dt <= 0.02 * reference.settle_time_s + 0.05,
        "{} vs {}",
        fast.settle_time_s,
        reference.settle_time_s
    );
}

#[test]
fn every_settle_has_a_bounded_cost_and_says_what_stopped_it() {
    // An inertia of 1e-12 (fast modes at c / I = 1e12 per second) ran for
    // ever; now the step cap stops it, and says so
    let mut sc = proto();
    sc.body.inertia = Vector3::repeat(1e-12);
    let set = [Pair::new(0, 14), Pair::new(12, 26)];
    let q0 = rot_q(&unit(Vector3::new(1.0, 0.2, 0.0)).unwrap(), Radians(0.1));
    let r = settle(&sc.torques, &set, &q0, sc.body, sc.settle);
    assert_eq!(r.stop, Stop::StepLimit, "{r:?}");
    assert!(!r.settled);
    assert!(r.evaluations <= 3 * spherestep::physics::integrator::MAX_ATTEMPTS + 100);
    // an impossible tolerance: the step size collapses, and the result says so
    let sc = proto();
    let tight = SettleParams {
        rtol: 1e-30,
        atol: 1e-30,
        ..sc.settle
    };
    let r = settle(&sc.torques, &set, &q0, sc.body, tight);
    assert!(
        matches!(r.stop, Stop::StepSizeUnderflow | Stop::StepLimit),
        "{r:?}"
    );
    assert!(!r.settled);
    let reference = SettleParams {
        method: Method::Dopri5,
        ..tight
    };
    let r = settle(&sc.torques, &set, &q0, sc.body, reference);
    assert!(
        matches!(r.stop, Stop::StepSizeUnderflow | Stop::StepLimit),
        "{r:?}"
    );
    assert!(!r.settled);
    assert!(!r.stop.describe().is_empty());
}
