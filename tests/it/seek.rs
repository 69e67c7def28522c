//! The search towards a goal orientation (planning::seek), which the closed loop steers with once
//! it has fitted the wells: it reaches the goal, and every step of its path is what the physics
//! does from the step before.

use spherestep::io::scenario::Scenario;
use spherestep::model::geometry::{rot_q, unit, Degrees};
use spherestep::physics::dynamics::settle;
use spherestep::planning::coilsets::coils_of;
use spherestep::planning::commutation::CommutationState;
use spherestep::planning::plan::PlanSettings;
use spherestep::planning::planner::plan;
use spherestep::planning::seek::Seek;
use std::path::Path;

#[test]
fn the_search_reaches_the_goal_through_steps_the_physics_takes() {
    let root_dir = Path::new(env!("CARGO_MANIFEST_DIR"));
    let sc = Scenario::load(&root_dir.join("scenarios/broad-wells.toml")).unwrap();
    let m = sc.motor();
    let p = plan(&m, &sc.plan);
    let row0 = &p.rows[0];
    let root = CommutationState {
        q: row0.q,
        active: row0.active.clone(),
        settle_time_s: row0.settle_time_s,
    };
    let axis = unit(nalgebra::Vector3::new(1.0, 1.0, 0.0)).unwrap();
    let goal = rot_q(&axis, Degrees(30.0).to_radians()) * row0.q;
    let s: &PlanSettings = &sc.plan;
    let seek = Seek {
        motor: &m,
        torques: &m.torques,
        per_step: s.pairs,
        max_coils_on: s.limits.max_coils_on,
        goal,
        ranked: None,
        on_time: None,
        held: Default::default(),
        not_first: Vec::new(),
    };
    let tolerance = Degrees(2.0).to_radians().0;
    let path = seek.search(&root, 8, 8, tolerance);
    // a closed loop back where it was does not take the same first step again
    let first = coils_of(&path.states[0].active);
    let other = Seek {
        not_first: vec![first.clone()],
        held: Default::default(),
        ..seek
    };
    let again = other.search(&root, 8, 8, tolerance);
    assert!(!again.states.is_empty());
    assert_ne!(coils_of(&again.states[0].active), first);
    assert!(!path.states.is_empty());
    let last = path.states.last().unwrap();
    assert!(
        last.q.angle_to(&goal) <= tolerance,
        "{} deg from the goal",
        last.q.angle_to(&goal).to_degrees()
    );
    // it stops at the first depth that reaches the tolerance, and says how near each came
    assert_eq!(path.nearest_by_depth.len(), path.states.len());
    assert!(path.nearest_by_depth.last().unwrap() <= &tolerance);
    assert!(path.settles > path.states.len());
    // each step, replayed as `simulate` settles it, lands where the search said
    let mut from = root.q;
    for st in &path.states {
        let r = settle(&m.torques, &st.active, &from, m.body, m.settle);
        assert!(r.settled);
        assert!(r.q.angle_to(&st.q) < 1e-6, "{}", r.q.angle_to(&st.q));
        from = st.q;
    }
}
