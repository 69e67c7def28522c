//! `spherestep prototype`: regenerates the built-in prototype's coordinate files.

use anyhow::Result;
use spherestep::commands::{self as app};
use std::io::Write;
use std::path::PathBuf;

/// The arguments of `spherestep prototype`.
#[derive(clap::Args)]
pub struct Args {
    /// Folder to write rotor.csv and stator.csv into.
    #[arg(long, default_value = "scenarios/prototype")]
    pub out: PathBuf,
}

impl Args {
    pub fn run(self, out: &mut dyn Write) -> Result<()> {
        let Args { out: dir } = self;
        app::write_prototype(&dir)?;
        writeln!(out, "wrote {}/rotor.csv and stator.csv", dir.display())?;
        Ok(())
    }
}
