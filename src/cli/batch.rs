//! `spherestep batch`: runs many scenarios (plans and sweeps) in parallel, one CSV each plus
//! summary.csv.

use anyhow::Result;
use spherestep::text::{printable, printable_lines};
use std::io::Write;
use std::path::PathBuf;

/// The arguments of `spherestep batch`.
#[derive(clap::Args)]
pub struct Args {
    /// Scenario files or folders of them.
    #[arg(required = true)]
    pub inputs: Vec<PathBuf>,
    /// Output folder.
    #[arg(long)]
    pub out: PathBuf,
    /// Worker threads, 1 to 256 (default: all cores). Output is the same for any number.
    #[arg(long)]
    pub jobs: Option<usize>,
    /// Run part I of N (0-based), e.g. 0/3; merge with a later run using --resume.
    #[arg(long)]
    pub shard: Option<String>,
    /// Skip scenarios whose output is up to date; merge finished shard parts.
    #[arg(long)]
    pub resume: bool,
    /// Also draw the pictures (Figures 5-8, sweep maps) and the 3-D page of each result.
    #[arg(long)]
    pub plots: bool,
}

impl Args {
    pub fn run(self, out: &mut dyn Write) -> Result<()> {
        let Args {
            inputs,
            out: out_dir,
            jobs,
            shard,
            resume,
            plots,
        } = self;
        let opts = spherestep::commands::batch::BatchOptions {
            out: out_dir,
            jobs,
            shard: shard
                .as_deref()
                .map(spherestep::commands::batch::Shard::parse)
                .transpose()?,
            resume,
            progress: true,
            plots,
        };
        let files = spherestep::commands::batch::collect_inputs(&inputs)?;
        let report = spherestep::commands::batch::run_batch(&files, &opts)?;
        writeln!(
            out,
            "{} computed, {} up to date, {} failed",
            report.ran.len(),
            report.skipped.len(),
            report.failed.len()
        )?;
        for w in &report.warnings {
            eprintln!("spherestep: warning: {}", printable(w));
        }
        for (name, err) in &report.failed {
            let (name, err) = (printable(name), printable_lines(err));
            eprintln!("spherestep: scenario {name} failed: {err}");
        }
        if !report.failed.is_empty() {
            anyhow::bail!("{} scenario(s) failed", report.failed.len());
        }
        Ok(())
    }
}
