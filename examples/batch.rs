//! Runs a batch of scenarios as `spherestep batch` does: each scenario's plan (or sweep) to a
//! CSV, with a content hash beside it, and `summary.csv`; run again with `resume`, the results
//! that are up to date are skipped.
//!
//! ```text
//! cargo run --release --example batch [-- OUT_DIR]
//! ```

use anyhow::Result;
use spherestep::commands::batch::{collect_inputs, run_batch, BatchOptions};
use std::path::PathBuf;

fn main() -> Result<()> {
    let out = std::env::args()
        .nth(1)
        .map(PathBuf::from)
        .unwrap_or_else(|| std::env::temp_dir().join("spherestep-batch"));
    let inputs = collect_inputs(&[
        PathBuf::from("scenarios/paper-fig7-z.toml"),
        PathBuf::from("scenarios/paper-fig8-y.toml"),
    ])?;
    let mut opts = BatchOptions {
        out: out.clone(),
        jobs: None,
        shard: None,
        resume: false,
        progress: false,
        plots: false,
    };
    let first = run_batch(&inputs, &opts)?;
    println!("computed {:?} into {}", first.ran, out.display());
    opts.resume = true;
    let again = run_batch(&inputs, &opts)?;
    println!(
        "again with resume: computed {:?}, up to date {:?}",
        again.ran, again.skipped
    );
    for (name, error) in first.failed.iter().chain(&again.failed) {
        eprintln!("{name}: {error}");
    }
    Ok(())
}
