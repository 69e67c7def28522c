//! `spherestep simulate`: replays a plan's coil sequence through the dynamic model and
//! measures the "slop".

use super::{CsvOutput, LoopArgs};
use anyhow::Result;
use spherestep::commands::args::check_out;
use spherestep::commands::waypoints::WaypointCheck;
use spherestep::commands::{self as app};
use spherestep::io::output::emit_csv;
use spherestep::io::scenario::Scenario;
use spherestep::io::simfile::write_sim;
use spherestep::planning::simulate::SimSummary;
use std::io::Write;
use std::path::PathBuf;

/// The arguments of `spherestep simulate`.
#[derive(clap::Args)]
pub struct Args {
    /// Plan CSV (from `plan --out`).
    pub plan: PathBuf,
    /// Scenario to simulate in (default: the built-in prototype); with --plant, the scenario
    /// the plan was made for (its pairs are checked against it).
    pub scenario: Option<PathBuf>,
    /// Replay in this scenario's physics instead (the plant: its wells, interaction, body and
    /// settle), to measure the model error of a plan made for another physics. Its packings
    /// must be the plan's.
    #[arg(long)]
    pub plant: Option<PathBuf>,
    /// With --closed-loop: the step model replans use (default: as `plan` in the scenario).
    #[arg(long)]
    pub model: Option<String>,
    #[command(flatten)]
    pub looping: LoopArgs,
    #[command(flatten)]
    pub output: CsvOutput,
}

impl Args {
    pub fn run(self, out: &mut dyn Write) -> Result<()> {
        let Args {
            plan,
            scenario,
            plant,
            model,
            looping,
            output: CsvOutput {
                out: out_file,
                json,
            },
        } = self;
        let sc = match scenario {
            Some(p) => Scenario::load(&p)?,
            None => Scenario::prototype(),
        };
        let plant = plant.map(|p| Scenario::load(&p)).transpose()?;
        if let Some(o) = &out_file {
            let mut read = vec![plan.clone()];
            read.extend(
                sc.files
                    .iter()
                    .chain(plant.iter().flat_map(|p| &p.files))
                    .cloned(),
            );
            check_out(o, &read)?;
        }
        if looping.closed_loop || model.is_some() {
            let Some(plant) = plant else {
                anyhow::bail!(
                    "--closed-loop and --model need --plant (the physics the ball obeys)"
                );
            };
            let overrides = app::PlanOverrides {
                model,
                ..Default::default()
            };
            let settings = app::plan_settings(&sc, &overrides)?;
            let mut stderr = std::io::stderr();
            let s = app::closed_loop::simulate_closed_loop(
                &sc,
                &plant,
                &settings,
                &plan,
                &looping.options(),
                app::closed_loop::Report {
                    file: out_file.as_deref(),
                    json,
                    out,
                    note: &mut stderr,
                },
            )?;
            if !s.run.reached {
                anyhow::bail!(
                    "the goal was not reached: {:.2} deg from it",
                    s.run.final_error_deg
                );
            }
            return Ok(());
        }
        let sim = app::simulate_plan_in(&sc, plant.as_ref(), &plan)?;
        let mut csv = Vec::new();
        write_sim(&sim, &mut csv)?;
        let mut stderr = std::io::stderr();
        let note = emit_csv(&csv, out_file.as_deref(), json, out, &mut stderr)?;
        let s = spherestep::planning::simulate::summary(&sim);
        let waypoints = spherestep::io::planfile::read_plan_waypoints(&plan)?
            .map(|serves| app::waypoints::check_waypoints(&serves, &sim));
        report(note, &s, waypoints.as_deref(), json)?;
        Ok(())
    }
}

/// The summary of an open-loop `simulate` (and, for a plan through waypoints, where the
/// simulated ball is at each), as JSON or as text.
fn report(
    note: &mut dyn Write,
    s: &SimSummary,
    waypoints: Option<&[WaypointCheck]>,
    json: bool,
) -> Result<()> {
    if json {
        let text = match waypoints {
            Some(w) => serde_json::to_string(&app::waypoints::SimulatedWaypoints {
                simulation: s,
                waypoints: w,
            })?,
            None => serde_json::to_string(s)?,
        };
        writeln!(note, "{text}")?;
        return Ok(());
    }
    writeln!(
        note,
        "{} steps: max deviation {:.3} deg, final deviation {:.3} deg, {} unsettled",
        s.steps, s.max_deviation_deg, s.final_deviation_deg, s.unsettled_steps
    )?;
    for w in waypoints.into_iter().flatten() {
        writeln!(
            note,
            "  waypoint {}: step {}, the simulated ball {:.2} deg from it",
            w.waypoint, w.step, w.error_deg
        )?;
    }
    Ok(())
}
