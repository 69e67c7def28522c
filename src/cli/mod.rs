//! The command line: one file per command, each holding its clap arguments and turning them
//! into calls of the library (`spherestep::commands` and the layers below). Errors are carried
//! as values to `main`, the one place that prints them.

mod batch;
#[cfg(feature = "design")]
mod design;
mod fit;
mod packing;
mod plan;
mod plot;
mod prototype;
mod replay;
mod run;
mod settle;
mod simulate;
mod view;
mod virtual_motor;
mod wells;

use clap::{Parser, Subcommand};
use spherestep::planning::options::DEFAULT_SEED;
use std::io::Write;
use std::path::PathBuf;

/// Where a command that makes a CSV (plan, simulate) sends it and its summary.
#[derive(clap::Args)]
pub struct CsvOutput {
    /// Write the CSV here (else it goes alone to standard output, the summary to standard
    /// error).
    #[arg(long)]
    pub out: Option<PathBuf>,
    /// Print a JSON summary.
    #[arg(long)]
    pub json: bool,
}

/// How a plan is played on a plant (run, simulate --plant): open or closed loop, the sensor.
#[derive(clap::Args)]
pub struct LoopArgs {
    /// Close the loop: after each step measure the plant's orientation (plus the sensor's
    /// noise) and, where it strays from the plan, replan the rest towards the same goal.
    #[arg(long)]
    pub closed_loop: bool,
    /// With --closed-loop: the sensor's noise, degrees (0 to 10): each measurement turned
    /// about a random axis by a normally distributed angle of this standard deviation.
    #[arg(long, default_value_t = 0.0, requires = "closed_loop")]
    pub sensor_noise_deg: f64,
    /// With --closed-loop: seed of the sensor's noise (the same seed, the same run).
    #[arg(long, default_value_t = DEFAULT_SEED, requires = "closed_loop")]
    pub seed: u64,
    /// With --closed-loop: at most this many steps (default: 3 x the planned steps + 6).
    #[arg(long, requires = "closed_loop")]
    pub max_steps: Option<usize>,
    /// With --closed-loop: do not fit the wells to the measured steps (by default, once the
    /// model's predictions are off by more than the replan threshold, the loop steers with the
    /// wells that predict the measured steps best).
    #[arg(long, requires = "closed_loop")]
    pub no_identify: bool,
}

impl LoopArgs {
    pub fn options(&self) -> spherestep::commands::closed_loop::LoopOptions {
        spherestep::commands::closed_loop::LoopOptions {
            closed: self.closed_loop,
            noise_deg: self.sensor_noise_deg,
            seed: self.seed,
            max_steps: self.max_steps,
            identify: !self.no_identify,
        }
    }
}

#[derive(Parser)]
#[command(
    name = "spherestep",
    version,
    about = "Commutation, planning, settling and relay replay for spherical stepper motors"
)]
pub struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// Report a scenario's packings: counts, separations, center lengths and their match.
    Packing(packing::Args),
    /// Settle the ball under one active set (--pairs) or many (--sets FILE, in parallel).
    Settle(settle::Args),
    /// Plan a motion: which coils to switch, in which order, to turn the ball about an axis.
    Plan(plan::Args),
    /// Replay a plan's coil sequence through the dynamic model and measure the "slop" (with
    /// --plant and --closed-loop: replan from measured orientations).
    Simulate(simulate::Args),
    /// Plan a motion in one scenario's physics and play it on a plant (another scenario's),
    /// open loop or closed loop on a (simulated, noisy) orientation sensor.
    Run(run::Args),
    /// Run many scenarios (plans and sweeps) in parallel: one CSV each, plus summary.csv.
    Batch(batch::Args),
    /// Search stator and rotor layouts (a scenario's [design] section) by NSGA-II: the front of
    /// worst and median axis error, final error, steps and coils; each generation a batch.
    #[cfg(feature = "design")]
    Design(design::Args),
    /// Replay a plan on a relay board (or several): switch each step's coils, wait, all off at
    /// the end (and on error or Ctrl-C). Settings come from the scenario's [relay] section or
    /// --map.
    Replay(replay::Args),
    /// A virtual motor for a replay to drive: relay boards and a sensor on pseudo-terminals,
    /// answering their protocols byte for byte, a ball moving under the plant's physics, the
    /// limits watched, faults injected on request.
    Virtual(virtual_motor::Args),
    /// Write one self-contained HTML page showing a plan in 3-D (opens from disk, no network).
    View(view::Args),
    /// Draw an existing result CSV (plan, sweep or run, told by its header) as SVG and PNG.
    Plot(plot::Args),
    /// Regenerate the built-in prototype's coordinate files from their generators.
    Prototype(prototype::Args),
    /// The torque on one magnet as it passes one energised coil, against the angle: a CSV in
    /// the `table` format (angle_deg,torque_nm), its picture and a summary.
    Wells(wells::Args),
    /// Fit the wells to the bench: a measured torque curve (--torque) and/or a closed-loop
    /// replay's log (--log); the parameters with their standard errors, the residuals, and the
    /// fitted scenario (--out).
    Fit(fit::Args),
}

impl Cli {
    /// Runs the command, writing its report to `out`.
    pub fn run(self, out: &mut dyn Write) -> anyhow::Result<()> {
        match self.command {
            Command::Packing(a) => a.run(out),
            Command::Settle(a) => a.run(out),
            Command::Plan(a) => a.run(out),
            Command::Simulate(a) => a.run(out),
            Command::Run(a) => a.run(out),
            Command::Batch(a) => a.run(out),
            #[cfg(feature = "design")]
            Command::Design(a) => a.run(out),
            Command::Replay(a) => a.run(out),
            Command::View(a) => a.run(out),
            Command::Virtual(a) => a.run(out),
            Command::Plot(a) => a.run(out),
            Command::Prototype(a) => a.run(out),
            Command::Wells(a) => a.run(out),
            Command::Fit(a) => a.run(out),
        }
    }
}
