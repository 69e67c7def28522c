//! `spherestep run`: plans a motion in a scenario's physics and plays it on a plant, open or
//! closed loop; a CSV row per step and a summary.

use super::{CsvOutput, LoopArgs};
use anyhow::Result;
use spherestep::commands::args::check_out;
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
    #[command(flatten)]
    pub what: super::plan::PlanArgs,
    #[command(flatten)]
    pub looping: LoopArgs,
    #[command(flatten)]
    pub output: CsvOutput,
}

impl Args {
    pub fn run(self, out: &mut dyn Write) -> Result<()> {
        let sc = Scenario::load(&self.scenario)?;
        let plant = Scenario::load(&self.plant)?;
        if let Some(o) = &self.output.out {
            check_out(o, &[&sc.files[..], &plant.files[..]].concat())?;
        }
        let o = self.what.overrides();
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
