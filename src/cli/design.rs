//! `spherestep design`: the layout optimiser, a scenario's `[design]` section searched by
//! NSGA-II, each generation a shardable, resumable batch.

use anyhow::Result;
use spherestep::commands::batch::Shard;
use spherestep::commands::design::{run_design, DesignOptions};
use spherestep::text::printable;
use std::io::Write;
use std::path::PathBuf;

/// The arguments of `spherestep design`.
#[derive(clap::Args)]
pub struct Args {
    /// The scenario with a [design] section.
    pub spec: PathBuf,
    /// Output folder: front.csv, layouts/, history.csv and each generation's batches.
    #[arg(long)]
    pub out: PathBuf,
    /// The evolution's seed (the same seed, the same front).
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    /// Worker threads, 1 to 256 (default: all cores). Output is the same for any number.
    #[arg(long)]
    pub jobs: Option<usize>,
    /// Compute part I of N (0-based) of the first stage not finished, e.g. 0/3; the stage is
    /// merged once every part is there.
    #[arg(long)]
    pub shard: Option<String>,
    /// Take the stages already computed (a killed run goes on where it stopped).
    #[arg(long)]
    pub resume: bool,
}

impl Args {
    pub fn run(self, out: &mut dyn Write) -> Result<()> {
        let opts = DesignOptions {
            out: self.out,
            seed: self.seed,
            jobs: self.jobs,
            shard: self.shard.as_deref().map(Shard::parse).transpose()?,
            resume: self.resume,
            progress: true,
        };
        let report = run_design(&self.spec, &opts)?;
        for w in &report.warnings {
            eprintln!("spherestep: warning: {}", printable(w));
        }
        if let Some(stage) = &report.waiting {
            writeln!(
                out,
                "shard done: {} waits for its other parts ({} generations finished)",
                printable(stage),
                report.generations
            )?;
            return Ok(());
        }
        writeln!(
            out,
            "{} generations, {} layouts planned on the coarse axes, {} on the full axes; \
             front of {}:",
            report.generations,
            report.evaluations,
            report.full_evaluations,
            report.front.len()
        )?;
        for (id, o) in &report.front {
            writeln!(
                out,
                "  {id}: {} coils, axis error worst {:.2} deg, worst quarter {:.2} deg, median \
                 {:.2} deg, worst final error {:.2} deg, median steps {}, worst steps {}",
                o.coils,
                o.worst_axis_error_deg,
                o.tail_axis_error_deg,
                o.median_axis_error_deg,
                o.worst_final_error_deg,
                o.median_steps,
                o.worst_steps
            )?;
        }
        Ok(())
    }
}
