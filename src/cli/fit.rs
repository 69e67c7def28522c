//! `spherestep fit`: a scenario's wells fitted to a bench's torque curve and/or a closed-loop
//! replay's log, reported and written as a scenario.

use anyhow::Result;
use spherestep::commands::fit::{fit_command, FitAs, FitInputs};
use spherestep::io::scenario::Scenario;
use std::io::Write;
use std::path::PathBuf;

/// The arguments of `spherestep fit`.
#[derive(clap::Args)]
pub struct Args {
    /// Scenario file (TOML) whose wells are fitted (default: the built-in prototype).
    pub scenario: Option<PathBuf>,
    /// A torque curve measured on the bench: a CSV with columns angle_deg (degrees) and
    /// torque_nm (N m), one coil's torque on one magnet (as `spherestep wells` writes it).
    #[arg(long)]
    pub torque: Option<PathBuf>,
    /// A closed-loop replay's log (`replay --sensor --log`): each step's coils and the
    /// sensor's reading after it.
    #[arg(long)]
    pub log: Option<PathBuf>,
    /// With --log: keep the last N measured steps out of the fit and report their prediction
    /// errors.
    #[arg(long, default_value_t = 0, requires = "log")]
    pub holdout: usize,
    /// Write the fitted scenario (TOML) here.
    #[arg(long)]
    pub out: Option<PathBuf>,
    /// What the torque curve is fitted as: `physical` (a physical scenario's core_gain and
    /// gap_m; its default), `wells` (gaussian and cosine wells, the better chosen; the default
    /// for any other scenario), `gaussian` or `cosine`.
    #[arg(long = "as", value_name = "AS", value_parser = FitAs::NAMES)]
    pub fit_as: Option<String>,
    /// Print the report as JSON.
    #[arg(long)]
    pub json: bool,
}

impl Args {
    pub fn run(self, out: &mut dyn Write) -> Result<()> {
        let sc = match &self.scenario {
            Some(p) => Scenario::load(p)?,
            None => Scenario::prototype(),
        };
        let inputs = FitInputs {
            torque: self.torque.as_deref(),
            log: self.log.as_deref(),
            holdout: self.holdout,
            out: self.out.as_deref(),
            fit_as: self.fit_as.as_deref().and_then(FitAs::parse),
        };
        fit_command(&sc, &inputs, self.json, out)?;
        Ok(())
    }
}
