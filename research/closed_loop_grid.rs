//! The closed loop against open loop on plants unlike the model: for each plant and axis, the
//! model's plan (90 degrees by default) is played on the plant open loop and closed loop with a
//! simulated sensor, for each seed; `--max-steps` is twice the plant's own fewest steps (a
//! beam-32 search in the plant's exact physics, from where the model's initial set leaves the
//! ball, to within 3 degrees of the goal; the nearest it comes within 12 steps if never). One
//! CSV row per run on stdout, a table per plant on stderr.
//!
//! ```text
//! cargo run --release --example closed_loop_grid -- MODEL.toml PLANT.toml [PLANT.toml ...] \
//!     [--axes 0,0,1:0,1,0:1,0,0:1,1,1] [--seeds 1-5] [--noise-deg 1] [--angle 90]
//! ```

use anyhow::{bail, Context, Result};
use spherestep::commands::args::parse_axis;
use spherestep::io::scenario::Scenario;
use spherestep::model::geometry::{Degrees, Radians};
use spherestep::physics::dynamics::settle;
use spherestep::planning::closed_loop::{goal_of, run_closed_loop, LoopSettings};
use spherestep::planning::commutation::CommutationState;
use spherestep::planning::plan::PlanSettings;
use spherestep::planning::planner::plan;
use spherestep::planning::seek::Seek;
use std::path::Path;

/// Within this of the goal a run counts as there (degrees).
const WITHIN_DEG: f64 = 3.0;

fn main() -> Result<()> {
    let mut args: Vec<String> = std::env::args().skip(1).collect();
    let mut take = |flag: &str, default: &str| -> String {
        match args.iter().position(|a| a == flag) {
            Some(i) if i + 1 < args.len() => {
                let v = args.remove(i + 1);
                args.remove(i);
                v
            }
            _ => default.to_string(),
        }
    };
    let axes = take("--axes", "0,0,1:0,1,0:1,0,0:1,1,1");
    let seeds = take("--seeds", "1-5");
    let noise_deg: f64 = take("--noise-deg", "1").parse().context("--noise-deg")?;
    let angle_deg: f64 = take("--angle", "90").parse().context("--angle")?;
    if args.len() < 2 {
        bail!("usage: closed_loop_grid MODEL.toml PLANT.toml [PLANT.toml ...] [--axes A:B] [--seeds 1-5] [--noise-deg 1] [--angle 90]");
    }
    let (lo, hi) = seeds.split_once('-').unwrap_or((&seeds, &seeds));
    let seeds: Vec<u64> = (lo.parse::<u64>()?..=hi.parse::<u64>()?).collect();
    let model = Scenario::load(Path::new(&args[0]))?;
    let mm = model.motor();
    println!("plant,axis,seed,fewest,max_steps,loop,steps,replans,final_error_deg,reached,replan_ms_median,replan_ms_max,message");
    let mut all = (0, 0, 0);
    let mut replan_ms: Vec<f64> = Vec::new();
    for plant_path in &args[1..] {
        let plant = Scenario::load(Path::new(plant_path))?;
        let pm = plant.motor();
        let (mut closed_ok, mut open_ok, mut n) = (0, 0, 0);
        for a in axes.split(':') {
            let axis = parse_axis(a, "--axes")?;
            let settings = PlanSettings {
                axis,
                angle: Degrees(angle_deg).to_radians(),
                ..model.plan.clone()
            };
            let p = plan(&mm, &settings);
            let goal = goal_of(&settings, &p.rows).context("no plan")?;
            // the plant's own fewest steps from where the model's initial set leaves the ball
            let r0 = settle(
                &pm.torques,
                &p.rows[0].active,
                &p.rows[0].q,
                pm.body,
                pm.settle,
            );
            let root = CommutationState {
                q: r0.q,
                active: p.rows[0].active.clone(),
                settle_time_s: 0.0,
            };
            let seek = Seek {
                motor: &pm,
                torques: &pm.torques,
                per_step: settings.pairs,
                max_coils_on: settings.limits.max_coils_on,
                goal,
                ranked: None,
                on_time: settings.limits.on_time,
                held: Default::default(),
                not_first: Vec::new(),
            };
            let ahead = seek.search(&root, 12, 32, WITHIN_DEG.to_radians());
            let best = ahead
                .nearest_by_depth
                .iter()
                .enumerate()
                .min_by(|a, b| a.1.total_cmp(b.1))
                .map(|(k, _)| k);
            let fewest = ahead
                .nearest_by_depth
                .iter()
                .position(|d| d.to_degrees() <= WITHIN_DEG)
                .or(best)
                .map_or(12, |k| k + 1);
            let max_steps = 2 * fewest;
            for &seed in &seeds {
                let noise = Radians(noise_deg.to_radians());
                for closed in [false, true] {
                    let cl = if closed {
                        LoopSettings::for_noise(noise, seed, max_steps)
                    } else {
                        LoopSettings::open(noise, seed)
                    };
                    let run = run_closed_loop(&mm, &pm, &settings, &p, goal, &cl);
                    replan_ms.extend(&run.replan_ms);
                    let s = &run.summary;
                    let ok = s.final_error_deg <= WITHIN_DEG;
                    if closed {
                        closed_ok += ok as usize;
                        n += 1;
                    } else {
                        open_ok += ok as usize;
                    }
                    println!(
                        "{},{},{},{},{},{},{},{},{:.3},{},{:.1},{:.1},\"{}\"",
                        plant.name,
                        a.replace(',', " "),
                        seed,
                        fewest,
                        max_steps,
                        if closed { "closed" } else { "open" },
                        s.steps,
                        s.replans,
                        s.final_error_deg,
                        s.reached,
                        s.replan_ms_median,
                        s.replan_ms_max,
                        s.message.as_deref().unwrap_or("").replace('"', "'")
                    );
                }
            }
            eprintln!(
                "{} about {a}: fewest {fewest} (nearest {:.2} deg)",
                plant.name,
                ahead
                    .nearest_by_depth
                    .iter()
                    .fold(f64::INFINITY, |m, d| m.min(*d))
                    .to_degrees()
            );
        }
        eprintln!(
            "{}: closed {closed_ok}/{n} within {WITHIN_DEG} deg, open {open_ok}/{n}",
            plant.name
        );
        all.0 += closed_ok;
        all.1 += open_ok;
        all.2 += n;
    }
    eprintln!(
        "all: closed {}/{} within {WITHIN_DEG} deg, open {}/{}",
        all.0, all.2, all.1, all.2
    );
    replan_ms.sort_by(f64::total_cmp);
    let at = |p: f64| replan_ms[((replan_ms.len() - 1) as f64 * p).round() as usize];
    if !replan_ms.is_empty() {
        eprintln!(
            "replans: {}, median {:.1} ms, 90th percentile {:.1} ms, largest {:.1} ms",
            replan_ms.len(),
            at(0.5),
            at(0.9),
            at(1.0)
        );
    }
    Ok(())
}
