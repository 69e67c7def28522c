//! Settles many active sets of the built-in prototype at once: every pair of coil 0's nearest
//! magnet with the nearest magnet of each other coil, from the identity, in parallel (the
//! results in the sets' order, the same on any number of threads), and prints where each set
//! holds the ball.
//!
//! ```text
//! cargo run --release --example settle_many
//! ```

use spherestep::model::geometry::rotation_angle;
use spherestep::planning::commutation::nearest_magnet;
use spherestep::{CoilId, Orientation, Pair, Scenario};

fn main() {
    let sc = Scenario::prototype();
    let motor = sc.motor();
    let q0 = Orientation::identity();
    let pair = |c: usize| Pair::new(c, nearest_magnet(&sc.torques, CoilId(c), &q0).0 .0);
    let sets: Vec<Vec<Pair>> = (1..sc.stator.len())
        .map(|c| vec![pair(0), pair(c)])
        .collect();
    let results = motor.settle_many(&sets, &q0);
    println!("set, settled, stop, turned_deg, settle_time_s");
    for (set, r) in sets.iter().zip(&results) {
        let names: Vec<String> = set.iter().map(|p| p.to_string()).collect();
        println!(
            "{}, {}, {:?}, {:.3}, {:.3}",
            names.join(";"),
            r.settled,
            r.stop,
            rotation_angle(&(q0.inverse() * r.q)).0.to_degrees(),
            r.settle_time_s
        );
    }
}
