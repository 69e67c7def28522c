//! `spherestep run`: plans a motion in a scenario's physics and plays it on a plant, open or
//! closed loop; a CSV row per step and a summary.

use super::{CsvOutput, LoopArgs};
use anyhow::Result;
use spherestep::commands::closed_loop::{run_command, Report};
use spherestep::commands::{self as app};
use spherestep::io::scenario::Scenario;
use std::io::Write;
use std::path::PathBuf;

/// The arguments of `spherestep run`.
#[derive(clap::Args)]
pub struct Args {
    /// The scenario the plans are made in (TOML); its [plan] section gives defaults.
    pub scenario: PathBuf,
    /// The plant: the scenario whose physics the ball obeys (its packings must be the same).
    #[arg(long)]
    pub plant: PathBuf,
    /// Desired rotation axis x,y,z (world frame).
    #[arg(long, allow_hyphen_values = true)]
    pub axis: Option<String>,
    /// Target rotation angle, degrees.
    #[arg(long)]
    pub angle: Option<f64>,
    /// min-axis-error, max-angle, weighted or search.
    #[arg(long)]
    pub scheme: Option<String>,
    /// Step model: pivot, dynamic or coils (default: as `plan`).
    #[arg(long)]
    pub model: Option<String>,
    /// Pairs (or coils) on after each step: K or 2-K.
    #[arg(long)]
    pub pairs: Option<String>,
    /// Start orientation qx,qy,qz,qw.
    #[arg(long, allow_hyphen_values = true)]
    pub from: Option<String>,
    #[command(flatten)]
    pub looping: LoopArgs,
    #[command(flatten)]
    pub output: CsvOutput,
}

impl Args {
    pub fn run(self, out: &mut dyn Write) -> Result<()> {
        let sc = Scenario::load(&self.scenario)?;
        let plant = Scenario::load(&self.plant)?;
        let o = app::PlanOverrides {
            axis: self.axis,
            angle_deg: self.angle,
            scheme: self.scheme,
            model: self.model,
            pairs: self.pairs,
            from: self.from,
        };
        let settings = app::plan_settings(&sc, &o)?;
        let mut stderr = std::io::stderr();
        let s = run_command(
            &sc,
            &plant,
            &settings,
            &self.looping.options(),
            Report {
                file: self.output.out.as_deref(),
                json: self.output.json,
                out,
                note: &mut stderr,
            },
        )?;
        if !s.run.reached {
            anyhow::bail!(
                "the goal was not reached: {:.2} deg from it{}",
                s.run.final_error_deg,
                s.run.message.map(|m| format!(" ({m})")).unwrap_or_default()
            );
        }
        Ok(())
    }
}
