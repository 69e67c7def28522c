//! `spherestep view`: writes the self-contained 3-D page of a plan.

use anyhow::Result;
use spherestep::commands::args::{as_flag, check_out, parse_axis};
use spherestep::error::Input;
use spherestep::io::scenario::Scenario;
use std::io::Write;
use std::path::PathBuf;

/// The arguments of `spherestep view`.
#[derive(clap::Args)]
pub struct Args {
    /// Plan file (CSV, as written by `plan`).
    pub plan: PathBuf,
    /// Scenario file (TOML) with the packings; default: the built-in prototype.
    pub scenario: Option<PathBuf>,
    /// The HTML page to write.
    #[arg(long)]
    pub out: PathBuf,
    /// Simulate results (CSV with columns step,qx,qy,qz,qw) to draw as a ghost ball.
    #[arg(long)]
    pub sim: Option<PathBuf>,
    /// Desired rotation axis x,y,z (default: the axis of the plan's total rotation).
    #[arg(long, allow_hyphen_values = true)]
    pub axis: Option<String>,
}

impl Args {
    pub fn run(self, out: &mut dyn Write) -> Result<()> {
        let Args {
            plan,
            scenario,
            out: page,
            sim,
            axis,
        } = self;
        let sc = match scenario {
            Some(p) => Scenario::load(&p)?,
            None => Scenario::prototype(),
        };
        let mut read = vec![plan.clone()];
        read.extend(sc.files.iter().cloned().chain(sim.clone()));
        check_out(&page, &read)?;
        let axis = axis.map(|a| parse_axis(&a, "--axis")).transpose()?;
        let data = spherestep::figures::view::write_view(&plan, &sc, sim.as_deref(), axis, &page)
            .map_err(|e| as_flag(e, Input::Simulation, "--sim"))?;
        writeln!(out, "wrote {} ({} steps)", page.display(), data.steps.len())?;
        Ok(())
    }
}
