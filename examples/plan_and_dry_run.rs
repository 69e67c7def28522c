//! Plans a motion on the built-in prototype (90 degrees about Y, the default planner), writes the
//! plan file, and replays it as a dry run: every frame a Numato relay board would be sent, with
//! the dwells, on a simulated clock and with no port opened.
//!
//! ```text
//! cargo run --release --example plan_and_dry_run [-- OUT.csv]
//! ```

use anyhow::{Context, Result};
use nalgebra::{Unit, Vector3};
use spherestep::commands::replay::{self, ReplayOptions};
use spherestep::io::planfile::write_plan;
use spherestep::relay::BoardKind;
use spherestep::{max_axis_error_deg, Degrees, Scenario};
use std::path::{Path, PathBuf};
use std::sync::atomic::AtomicBool;
use std::sync::Arc;

fn main() -> Result<()> {
    let out = std::env::args()
        .nth(1)
        .map(PathBuf::from)
        .unwrap_or_else(|| std::env::temp_dir().join("spherestep-plan-y.csv"));
    let scenario = Path::new("scenarios/prototype.toml");
    let sc = Scenario::load(scenario)?;
    let mut settings = sc.plan.clone();
    settings.axis = Unit::new_normalize(Vector3::y());
    settings.angle = Degrees(90.0).to_radians();
    let plan = sc.motor().plan(&settings);
    println!(
        "{} steps, worst axis error {:.2} deg, reached: {}",
        plan.rows.len() - 1,
        max_axis_error_deg(&plan.rows),
        plan.reached
    );
    let mut file = std::fs::File::create(&out).with_context(|| format!("{}", out.display()))?;
    write_plan(&plan.rows, &mut file)?;
    println!("plan written to {}", out.display());

    let mut opts = ReplayOptions::new(&out);
    opts.scenario = Some(scenario.to_path_buf());
    opts.board = Some(BoardKind::Numato);
    opts.dry_run = true;
    let stop = Arc::new(AtomicBool::new(false));
    let summary = replay::run(&opts, stop, None, &mut std::io::stdout())?;
    println!("{} steps replayed (dry run)", summary.steps_done);
    Ok(())
}
