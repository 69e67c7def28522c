//! How far can one switching step turn the ball in a scenario's physics? From equilibria the
//! ball can be held in (reached by switching from the scenario's start), settles every set of
//! 1 to 4 coils in reach and prints the largest rotation one step makes. A motion of angle A
//! needs at least A / (largest step) steps, whatever plans it (the rotation angle obeys the
//! triangle inequality).
//!
//! ```text
//! cargo run --release --example largest_step -- SCENARIO.toml [STATES]
//! ```

use anyhow::{Context, Result};
use spherestep::io::scenario::Scenario;
use spherestep::model::geometry::{rotation_angle, CoilId, Orientation};
use spherestep::physics::dynamics::settle_many;
use spherestep::planning::coilsets::{coils_in_reach, label};
use std::path::Path;

fn sets_of(reach: &[CoilId], max: usize) -> Vec<Vec<CoilId>> {
    let mut out: Vec<Vec<CoilId>> = vec![Vec::new()];
    let mut all = Vec::new();
    for _ in 0..max {
        let mut next = Vec::new();
        for s in &out {
            let from = s
                .last()
                .map_or(0, |c| reach.iter().position(|r| r == c).unwrap() + 1);
            for c in &reach[from..] {
                let mut t = s.clone();
                t.push(*c);
                next.push(t);
            }
        }
        all.extend(next.iter().cloned());
        out = next;
    }
    all
}

fn main() -> Result<()> {
    let args: Vec<String> = std::env::args().collect();
    let path = args
        .get(1)
        .context("usage: largest_step SCENARIO.toml [STATES]")?;
    let states: usize = args.get(2).map_or(Ok(12), |s| s.parse())?;
    let sc = Scenario::load(Path::new(path))?;
    let m = sc.motor();
    let mut pool: Vec<Orientation> = vec![Orientation::identity()];
    let mut best = 0.0f64;
    let mut k = 0;
    while k < pool.len().min(states) {
        let q = pool[k];
        let reach = coils_in_reach(&m.torques, &q);
        let sets = sets_of(&reach, 4);
        let pairs: Vec<_> = sets.iter().map(|c| label(&m.torques, c, &q)).collect();
        let rs = settle_many(&m.torques, &pairs, &q, m.body, m.settle);
        let mut angles: Vec<(f64, usize)> = rs
            .iter()
            .enumerate()
            .filter(|(_, r)| r.settled)
            .map(|(i, r)| (rotation_angle(&(r.q * q.inverse())).0.to_degrees(), i))
            .collect();
        angles.sort_by(|a, b| b.0.total_cmp(&a.0));
        let top = angles.first().map_or(0.0, |a| a.0);
        best = best.max(if k == 0 { 0.0 } else { top });
        println!(
            "state {k}: {} sets, {} settled, largest step {:.2} deg, 10th {:.2} deg",
            sets.len(),
            angles.len(),
            top,
            angles.get(9).map_or(0.0, |a| a.0)
        );
        // keep a few of the equilibria reached, spread over the step sizes
        for a in angles.iter().step_by((angles.len() / 4).max(1)).take(4) {
            pool.push(rs[a.1].q);
        }
        k += 1;
    }
    println!("largest step from a held state: {best:.2} deg");
    Ok(())
}
