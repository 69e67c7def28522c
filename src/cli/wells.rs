//! `spherestep wells`: the torque on one magnet as it passes one energised coil, against the
//! angle (a CSV in the `table` format, its picture and a summary).

use super::CsvOutput;
use anyhow::Result;
use spherestep::commands::wells::{wells_command, DEFAULT_STEP_DEG};
use spherestep::io::scenario::Scenario;
use std::io::Write;
use std::path::PathBuf;

/// The arguments of `spherestep wells`.
#[derive(clap::Args)]
pub struct Args {
    /// Scenario file (TOML; default: the built-in prototype).
    pub scenario: Option<PathBuf>,
    /// Angle step of the curve, degrees.
    #[arg(long, default_value_t = DEFAULT_STEP_DEG)]
    pub step_deg: f64,
    /// With --out, the picture goes beside the CSV (the same name, .svg and .png).
    #[command(flatten)]
    pub output: CsvOutput,
}

impl Args {
    pub fn run(self, out: &mut dyn Write) -> Result<()> {
        let sc = match &self.scenario {
            Some(p) => Scenario::load(p)?,
            None => Scenario::prototype(),
        };
        let mut stderr = std::io::stderr();
        wells_command(
            &sc,
            self.step_deg,
            self.output.out.as_deref(),
            self.output.json,
            out,
            &mut stderr,
        )?;
        Ok(())
    }
}
