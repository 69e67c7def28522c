//! The closed loop's fit of the wells (planning::identify): the candidate that made the
//! measured steps is the one chosen (refined to the plant's own reach where the grid has no
//! such point), and the model is kept while it predicts them.

use spherestep::io::scenario::Scenario;
use spherestep::model::geometry::{CoilId, Orientation, Radians};
use spherestep::physics::dynamics::settle;
use spherestep::physics::torque::Interaction;
use spherestep::planning::coilsets::{coils_in_reach, label};
use spherestep::planning::commutation::Motor;
use spherestep::planning::identify::{Identifier, Observation, Shape};
use std::path::Path;

fn load(name: &str) -> Scenario {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    Scenario::load(&root.join(name)).unwrap()
}

/// Four steps the `plant` takes from `q0`, each switching on two or three of the coils in
/// reach, as an exact sensor measures them.
fn steps_in(plant: &Motor, q0: Orientation) -> Vec<Observation> {
    let mut out = Vec::new();
    let mut q = q0;
    for k in 0..4 {
        let reach = coils_in_reach(&plant.torques, &q);
        let coils: Vec<CoilId> = [k, k + 2, k + 5]
            .iter()
            .take(2 + k % 2)
            .map(|&i| reach[i % reach.len()])
            .collect();
        let active = label(&plant.torques, &coils, &q);
        let r = settle(&plant.torques, &active, &q, plant.body, plant.settle);
        out.push(Observation {
            from: q,
            active,
            to: r.q,
        });
        q = r.q;
    }
    out
}

#[test]
fn the_fit_finds_the_wells_that_made_the_steps() {
    let model = load("scenarios/prototype.toml");
    let plant = load("scenarios/broad-wells.toml");
    let obs = steps_in(&plant.motor(), Orientation::identity());
    let mut id = Identifier::new(&model.torques, Radians(0.0));
    let grid = id.len();
    for o in &obs {
        id.observe(&model.motor(), o);
    }
    // every candidate scored on the first step, at least those kept on the others
    assert!(
        id.settles() >= grid + 3 * id.len(),
        "{} {}",
        id.settles(),
        id.len()
    );
    // the pair model's sharp wells do not make these steps ...
    assert!(
        id.rms(0).0.to_degrees() > 5.0,
        "{}",
        id.rms(0).0.to_degrees()
    );
    // ... the plant's broad wells, every coil pulling, do (to the settle's tolerance)
    let k = id.steer().expect("a candidate is chosen over the model");
    let c = id.candidate(k);
    let p = c.params.expect("a fitted candidate has parameters");
    assert!(
        p.shape == Shape::Cosine
            && p.interaction == Interaction::Coils
            && (p.reach_deg - 40.0).abs() <= 2.5,
        "{}",
        c.name
    );
    assert!(
        id.rms(k).0.to_degrees() < 0.05,
        "{}",
        id.rms(k).0.to_degrees()
    );
}

#[test]
fn the_model_is_kept_while_it_predicts_the_steps() {
    let model = load("scenarios/broad-wells.toml");
    let obs = steps_in(&model.motor(), Orientation::identity());
    let mut id = Identifier::new(&model.torques, Radians(0.0));
    for o in &obs {
        id.observe(&model.motor(), o);
    }
    // the same settles: the same orientations (to the rounding of the angle between them)
    assert!(id.rms(0).0 < 1e-7, "{}", id.rms(0).0);
    assert_eq!(id.steer(), None);
    assert_eq!(id.best(), 0);
}

#[test]
fn the_fit_refines_a_reach_between_the_grid_points_and_a_physics_that_holds_nothing_loses() {
    // cosine wells reaching 37 degrees, every coil pulling: between the grid's 35 and 40
    let model = load("scenarios/prototype.toml");
    let mut plant = load("scenarios/plants/cosine-35-coils.toml");
    let truth = spherestep::planning::identify::WellParams {
        shape: Shape::Cosine,
        reach_deg: 37.0,
        stiffness: 4.0,
        interaction: Interaction::Coils,
    };
    plant.torques = truth.torques(&plant.torques);
    let obs = steps_in(&plant.motor(), Orientation::identity());
    let mut id = Identifier::new(&model.torques, Radians(0.0));
    for o in &obs {
        id.observe(&model.motor(), o);
    }
    let k = id.steer().expect("a candidate is chosen over the model");
    let p = id.candidate(k).params.unwrap();
    assert!(
        p.shape == Shape::Cosine && p.interaction == Interaction::Coils,
        "{}",
        id.candidate(k).name
    );
    // the chosen wells make the steps as the plant did
    assert!(
        id.rms(k).0.to_degrees() < 0.1,
        "{}",
        id.rms(k).0.to_degrees()
    );
    // and every step the model cannot make costs it the cap
    assert!(id.score(0) >= 3.0 * spherestep::planning::identify::CAP);
}
