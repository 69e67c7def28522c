//! `spherestep plot`: draws a plan, sweep or run CSV as SVG and PNG.

use anyhow::Result;
use std::io::Write;
use std::path::PathBuf;

/// The arguments of `spherestep plot`.
#[derive(clap::Args)]
pub struct Args {
    /// A plan CSV (axis error vs. rotation angle) or a sweep CSV (map of the worst axis error).
    pub csv: PathBuf,
    /// Folder for the pictures (default: next to the CSV).
    #[arg(long)]
    pub out: Option<PathBuf>,
    /// Title of the figure (default: from the file name).
    #[arg(long)]
    pub title: Option<String>,
}

impl Args {
    pub fn run(self, out: &mut dyn Write) -> Result<()> {
        let Args {
            csv,
            out: dir,
            title,
        } = self;
        for f in spherestep::figures::plot_csv(&csv, dir.as_deref(), title.as_deref())? {
            writeln!(out, "wrote {}", f.display())?;
        }
        Ok(())
    }
}
