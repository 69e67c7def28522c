//! How few steps does a motion need in a scenario's physics? From the initial commutation
//! state of a plan (the scenario's own, or another model's played in this physics as the
//! closed loop starts), searches level by level with `planning::seek` (every coil set the
//! supply allows, the BEAM states nearest the goal kept at each depth) and prints, per number
//! of steps, the nearest the ball can come to the goal R_target R_0: how few steps a
//! controller that knew this physics exactly would need, as far as a beam that wide sees.
//!
//! ```text
//! cargo run --release --example fewest_steps -- PLANT.toml X,Y,Z ANGLE_DEG [MODEL.toml] [DEPTH] [BEAM] [PLAYED]
//! ```
//!
//! PLAYED: first play this many of the model plan's steps in the plant (as an open loop does
//! before a closed loop can tell its model is wrong), then look ahead.

use anyhow::{bail, Context, Result};
use spherestep::io::scenario::Scenario;
use spherestep::model::geometry::{rot_q, unit, Degrees};
use spherestep::physics::dynamics::settle;
use spherestep::planning::commutation::CommutationState;
use spherestep::planning::plan::PlanSettings;
use spherestep::planning::planner::plan;
use spherestep::planning::seek::Seek;
use std::path::Path;

fn main() -> Result<()> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    if args.len() < 3 {
        bail!(
            "usage: fewest_steps PLANT.toml X,Y,Z ANGLE_DEG [MODEL.toml] [DEPTH] [BEAM] [PLAYED]"
        );
    }
    let plant = Scenario::load(Path::new(&args[0]))?;
    let v: Vec<f64> = args[1]
        .split(',')
        .map(|x| x.trim().parse::<f64>())
        .collect::<Result<_, _>>()
        .context("axis: expected x,y,z")?;
    if v.len() != 3 {
        bail!("axis: expected x,y,z");
    }
    let axis = unit(nalgebra::Vector3::new(v[0], v[1], v[2])).context("axis: not zero")?;
    let angle = Degrees(args[2].parse().context("angle: expected degrees")?).to_radians();
    let model = match args.get(3) {
        Some(m) => Scenario::load(Path::new(m))?,
        None => plant.clone(),
    };
    let depth: usize = args.get(4).map_or(Ok(10), |s| s.parse())?;
    let beam: usize = args.get(5).map_or(Ok(32), |s| s.parse())?;
    let played: usize = args.get(6).map_or(Ok(0), |s| s.parse())?;
    let settings = PlanSettings {
        axis,
        angle,
        ..model.plan.clone()
    };
    let p = plan(&model.motor(), &settings);
    let row0 = p.rows.first().context("the model finds no initial state")?;
    // the initial set switched on in the plant, from where the model says it holds the ball,
    // then PLAYED of the plan's steps
    let m = plant.motor();
    let mut root = CommutationState {
        q: row0.q,
        active: row0.active.clone(),
        settle_time_s: 0.0,
    };
    for row in p.rows.iter().take(played + 1) {
        let r = settle(&m.torques, &row.active, &root.q, m.body, m.settle);
        root = CommutationState {
            q: r.q,
            active: row.active.clone(),
            settle_time_s: r.settle_time_s,
        };
    }
    let goal = rot_q(&axis, angle) * row0.q;
    let seek = Seek {
        motor: &m,
        torques: &m.torques,
        per_step: settings.pairs,
        max_coils_on: settings.limits.max_coils_on,
        goal,
        ranked: None,
        on_time: settings.limits.on_time,
        held: Default::default(),
        not_first: Vec::new(),
    };
    println!(
        "start {:.2} deg from the goal after {played} of the plan's steps; beam {beam}",
        root.q.angle_to(&goal).to_degrees()
    );
    let ahead = seek.search(&root, depth, beam, 0.0);
    for (k, d) in ahead.nearest_by_depth.iter().enumerate() {
        println!("after {:2} steps: nearest {:.2} deg", k + 1, d.to_degrees());
    }
    println!("{} settles", ahead.settles);
    Ok(())
}
