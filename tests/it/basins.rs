//! The fast settle against the reference on random sets: the same equilibrium, the
//! same settled flag and the same settle time, for both well shapes, light, medium and heavy
//! damping and 2 to 5 pairs. The full 4,000-per-kind measurement is research/basins.rs.

use crate::basins_common::{both, compare, random_sets, setup, Rng, Shape};
use rayon::prelude::*;

/// Sets per kind: enough to meet the hard cases (a lone pair's free rotation, pairs beyond
/// reach, saddles) while the reference at rtol 1e-10 keeps the test to seconds.
const SETS: usize = 240;

fn check(shape: Shape, damping_ratio: f64, seed: u64) {
    let (torques, body, params) = setup(shape, damping_ratio);
    let mut rng = Rng::new(seed);
    let q0 = rng.orientation();
    let mut sets = Vec::new();
    for pairs in 2..=5 {
        sets.extend(random_sets(&torques, &q0, pairs, SETS / 4, &mut rng));
    }
    let results: Vec<_> = sets
        .par_iter()
        .map(|s| both(&torques, s, &q0, body, params))
        .collect();
    let (mut other, mut outside, mut settled) = (0, Vec::new(), 0);
    for (set, (fast, reference)) in sets.iter().zip(&results) {
        let c = compare(fast, reference);
        settled += reference.settled as usize;
        other += c.other_basin as usize;
        if !c.agrees {
            outside.push((set.clone(), c, fast.settle_time_s, reference.settle_time_s));
        }
    }
    let label = format!("{shape:?}, damping {damping_ratio} of critical");
    assert!(settled > SETS / 2, "{label}: only {settled} settled");
    assert_eq!(other, 0, "{label}: {other} sets in another equilibrium");
    // The settle test can pass first in a brief dip of a lightly damped oscillation, and which
    // dip a run sees hangs on its errors: some such sets are allowed (the reference applies the
    // test within its steps; on research/basins.rs 2 to 2.5% of light-damping sets and about 1%
    // of the others are outside the bounds), never a different equilibrium or flag. Before the
    // reference looked within its steps, light damping put 6 to 7% outside.
    let allowed = if damping_ratio < 0.5 {
        SETS / 16
    } else {
        SETS / 30
    };
    assert!(
        outside
            .iter()
            .all(|(_, c, _, _)| c.same_flag && c.angle < 1e-4),
        "{label}: {outside:?}"
    );
    assert!(
        outside.len() <= allowed,
        "{label}: {} of {} sets outside the settle-time bound: {outside:?}",
        outside.len(),
        sets.len()
    );
}

#[test]
fn gaussian_wells_light_damping() {
    check(Shape::Gaussian, 0.2, 1);
}

#[test]
fn gaussian_wells_medium_damping() {
    check(Shape::Gaussian, 0.7, 2);
}

#[test]
fn gaussian_wells_heavy_damping() {
    check(Shape::Gaussian, 2.0, 3);
}

#[test]
fn cosine_wells_light_damping() {
    check(Shape::Cosine, 0.2, 4);
}

#[test]
fn cosine_wells_medium_damping() {
    check(Shape::Cosine, 0.7, 5);
}

#[test]
fn cosine_wells_heavy_damping() {
    check(Shape::Cosine, 2.0, 6);
}

/// Both paths settle `set` from `q0`, within 1e-4 rad of each other.
fn settles_where_the_reference_does(
    torques: &spherestep::physics::torque::MagnetTorques,
    set: &[spherestep::model::geometry::Pair],
    q0: &spherestep::model::geometry::Orientation,
    body: spherestep::physics::dynamics::Body,
    params: spherestep::physics::dynamics::SettleParams,
) {
    let (fast, reference) = both(torques, set, q0, body, params);
    let c = compare(&fast, &reference);
    assert!(fast.settled && reference.settled);
    assert!(c.angle < 1e-4, "{} rad from the reference", c.angle);
}

/// A set whose magnet grazes its well's cut-off on the way (comes within 0.01 degrees of it
/// and turns back, at 3 rad/s): at the fast path's tolerance it ended 0.32 rad from the
/// reference's equilibrium (research/basins.rs, seed 19, the cosine light-damping kind); the
/// graze sends it to the tight fallback.
#[test]
fn a_set_that_grazes_a_cut_off_lands_where_the_reference_does() {
    let (torques, body, params) = setup(Shape::Cosine, 0.2);
    let q0 = Rng::new(19 + 4).orientation();
    let set = [
        spherestep::model::geometry::Pair::new(7, 45),
        spherestep::model::geometry::Pair::new(3, 72),
        spherestep::model::geometry::Pair::new(5, 24),
    ];
    settles_where_the_reference_does(&torques, &set, &q0, body, params);
}

/// A set of the 3-pair gaussian kind at 0.7 of critical damping (research/basins.rs, seed 17) whose magnet on coil 14 comes within
/// 6.8e-5 (in cosine) of its well's cut-off at 0.55 s and turns back at the fast path's
/// tolerance, where the reference crosses the cut-off: with the cut-off events alone it ended
/// 0.059 rad from the reference's equilibrium; the graze has its approach integrated again
/// tightly.
#[test]
fn a_set_whose_graze_the_reference_crosses_lands_where_the_reference_does() {
    let (torques, body, params) = setup(Shape::Gaussian, 0.7);
    let q0 = Rng::new(17).orientation();
    let p = spherestep::model::geometry::Pair::new;
    let set = [p(14, 29), p(1, 76), p(6, 54)];
    settles_where_the_reference_does(&torques, &set, &q0, body, params);
    // its trace: the tight approach, then the rest, in time order, ending where it settled
    let mut trace = Vec::new();
    let r = spherestep::physics::dynamics::settle_traced(
        &torques,
        &set,
        &q0,
        body,
        params,
        Some(&mut trace),
    );
    assert!(
        trace.windows(2).all(|w| w[0].0 <= w[1].0),
        "the trace goes back in time"
    );
    assert_eq!(trace.last().map(|s| s.0), Some(r.settle_time_s));
}

/// A planner-realistic set (gaussian wells of 10 degrees cut off at 25, three pairs, about 0.7
/// of critical damping; `tests/data/settle-graze-1.toml`) whose magnet 58 comes within 1e-3
/// degrees of coil 10's cut-off at 0.70 s on the reference and turns back: the loose approach
/// crossed it at 0.4 degrees a second, and the cut-off event switched the pair off there, so the
/// fast path ended 0.011 rad from the reference's equilibrium with coil 10's magnet out of reach
/// ("partly held"). A crossing that the margin's acceleration would have turned back within
/// the graze band is a graze: its approach is integrated again tightly.
#[test]
fn a_set_that_barely_crosses_a_cut_off_lands_where_the_reference_does() {
    let path =
        std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/settle-graze-1.toml");
    let sc = spherestep::Scenario::load(&path).expect("the case loads");
    let m = sc.motor();
    let p = spherestep::model::geometry::Pair::new;
    let set = [p(10, 58), p(12, 44), p(8, 42)];
    let q0 = spherestep::model::geometry::Orientation::from_quaternion(nalgebra::Quaternion::new(
        -0.910_115_825_669_253_8,
        0.001_257_121_376_956_828,
        0.305_294_782_303_331_9,
        -0.280_147_638_595_397_2,
    ));
    let (fast, reference) = both(&m.torques, &set, &q0, m.body, m.settle);
    let c = compare(&fast, &reference);
    assert!(fast.settled && reference.settled);
    assert!(c.angle < 1e-4, "{} rad from the reference", c.angle);
    // every magnet held on both paths (the reference's answer): none left beyond its cut-off
    let reach = m.torques.well.max_attraction().0;
    for r in [&fast, &reference] {
        let rot = r.q.to_rotation_matrix();
        for pair in &set {
            let d = spherestep::planning::commutation::pair_gap(&m.torques, &rot, *pair).0;
            assert!(d < reach, "{pair:?} at {} degrees", d.to_degrees());
        }
    }
}

/// The "coils" interaction (every magnet within reach of an energised coil pulls): without the
/// graze watch, coils 2, 0 and 9 from this start ended 0.078 rad from the reference's
/// equilibrium (cosine wells, 0.7 of critical damping: one of 4 sets in 12,000 of seed 17), as
/// a magnet grazed a cut-off on the way; the graze now sends it to the tight fallback.
#[test]
fn a_coils_set_that_grazes_a_cut_off_lands_where_the_reference_does() {
    let (mut torques, body, params) = setup(Shape::Cosine, 0.7);
    torques.interaction = spherestep::physics::torque::Interaction::Coils;
    let q0 = Rng::new(17 + 100 + 4).orientation();
    let set = [
        spherestep::model::geometry::Pair::new(2, 59),
        spherestep::model::geometry::Pair::new(0, 78),
        spherestep::model::geometry::Pair::new(9, 55),
    ];
    settles_where_the_reference_does(&torques, &set, &q0, body, params);
}

/// Both paths settle `set` from `q0` within the agreement bounds (orientation within 1e-4 rad,
/// settle time within 2% + 0.05 s), the fast path without its tight fallback (which takes
/// thousands of evaluations): its end phase did the work.
fn end_phase_settles_it_on_time(
    set: &[spherestep::model::geometry::Pair],
    q0: &spherestep::model::geometry::Orientation,
) {
    let (torques, body, params) = setup(Shape::Gaussian, 0.7);
    let (fast, reference) = both(&torques, set, q0, body, params);
    let c = compare(&fast, &reference);
    assert!(
        c.agrees,
        "settled at {} s, the reference at {} s, {} rad apart",
        fast.settle_time_s, reference.settle_time_s, c.angle
    );
    assert!(
        fast.evaluations < 1000,
        "{} evaluations: the tight fallback",
        fast.evaluations
    );
}

/// Two sets of the 3-pair gaussian kind at 0.7 of critical damping (research/basins.rs, seed 17) that come to a minimum with a
/// magnet within 0.4 and 0.08 degrees of its well's cut-off without crossing it on the way:
/// such a minimum is trusted (it used to send the settle to the tight fallback). In the first
/// the ball passes slowly near a saddle at 1.8 s, where the end phase's searches fail, and the
/// backoff they had grown to put the next search off by 32 steps, to 9.1 s; the stepper
/// meanwhile hovered near the minimum at its tolerance's noise floor, and the settle was
/// reported at 9.23 s, the reference's at 5.07 s. In the second the minimum is refused at first
/// because the motion about it would reach the cut-off; looked at again only after the backoff,
/// the settle came at 4.16 s, the reference's at 3.95 s.
#[test]
fn a_minimum_near_a_cut_off_never_crossed_is_settled_by_the_end_phase_on_time() {
    let q0 = Rng::new(17).orientation();
    let p = spherestep::model::geometry::Pair::new;
    end_phase_settles_it_on_time(&[p(11, 33), p(14, 53), p(12, 52)], &q0);
    end_phase_settles_it_on_time(&[p(10, 0), p(3, 21), p(12, 28)], &q0);
}
