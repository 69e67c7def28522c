//! `spherestep packing`: reports a scenario's packings (counts, separations, center lengths).

use anyhow::Result;
use spherestep::commands::{self as app};
use spherestep::io::scenario::Scenario;
use std::io::Write;
use std::path::PathBuf;

/// The arguments of `spherestep packing`.
#[derive(clap::Args)]
pub struct Args {
    /// Scenario file (TOML).
    pub scenario: PathBuf,
    /// Print JSON instead of a table.
    #[arg(long)]
    pub json: bool,
}

impl Args {
    pub fn run(self, out: &mut dyn Write) -> Result<()> {
        let Args { scenario, json } = self;
        let sc = Scenario::load(&scenario)?;
        app::packing_report(&sc, json, out)?;
        Ok(())
    }
}
