//! `spherestep replay`: replays a plan on a relay board (or several), every coil off at the
//! end, on an error and on Ctrl-C; with `--sensor`, closing the loop through an orientation
//! sensor.

use anyhow::{Context, Result};
use spherestep::commands::closed_replay::{self, SensorOptions};
use spherestep::commands::replay::{self, Flagged, ReplayOptions};
use spherestep::relay::replay::{stdin_lines, Mode};
use spherestep::sensor::SensorFormat;
use std::io::Write;
use std::path::PathBuf;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;

/// The arguments of `spherestep replay`.
#[derive(clap::Args)]
pub struct Args {
    /// Plan CSV (as written by `plan`).
    pub plan: PathBuf,
    /// Scenario file (TOML) with the coil count and [relay] settings (default: prototype).
    pub scenario: Option<PathBuf>,
    /// Serial device, e.g. /dev/ttyUSB0 (not needed with --dry-run); with [[relay.boards]],
    /// given once per board in list order to override their ports.
    #[arg(long)]
    pub port: Vec<String>,
    /// Board protocol: lcus, kmtronic, numato or modbus (default: relay.board; single board).
    #[arg(long)]
    pub board: Option<spherestep::relay::BoardKind>,
    /// Baud rate (default: relay.baud, else the vendor's; single board).
    #[arg(long)]
    pub baud: Option<u32>,
    /// realtime (switch, wait the dwell) or step (wait for Enter; q quits).
    #[arg(long, default_value = "realtime")]
    pub mode: Mode,
    /// Fixed dwell per step, ms, used as given (default: settle time x relay.dwell_factor, at
    /// least relay.dwell_floor_ms).
    #[arg(long)]
    pub dwell_ms: Option<u64>,
    /// First step to replay (the step before is re-energised first to hold the ball).
    #[arg(long, default_value_t = 0)]
    pub from_step: usize,
    /// Print the frames and timing; open no port.
    #[arg(long)]
    pub dry_run: bool,
    /// Append a CSV of what was sent when (flushed per step).
    #[arg(long)]
    pub log: Option<PathBuf>,
    /// Read the relays back after each step; stop (all off) on a mismatch.
    #[arg(long)]
    pub verify: bool,
    /// TOML map file with the [relay] keys at the top (replaces the scenario's section).
    #[arg(long)]
    pub map: Option<PathBuf>,
    /// Close the loop: read the ball's orientation from this serial device after each step's
    /// dwell, and replan from it when it strays (realtime only, not with --dry-run or
    /// --from-step).
    #[arg(long, requires = "sensor_format")]
    pub sensor: Option<String>,
    /// The sensor's protocol: quat-csv (a `w,x,y,z` line per reading) or bno055 (UART).
    #[arg(long, requires = "sensor")]
    pub sensor_format: Option<SensorFormat>,
    /// The sensor's baud rate (default 115200).
    #[arg(long, requires = "sensor")]
    pub sensor_baud: Option<u32>,
    /// The BNO055's fusion mode: imu (accelerometer and gyroscope, the default: the
    /// magnetometer reads the motor's magnets) or ndof (with the magnetometer).
    #[arg(long, requires = "sensor")]
    pub sensor_mode: Option<spherestep::sensor::bno055::FusionMode>,
    /// How long to wait for a reading, ms (default 500).
    #[arg(long, requires = "sensor")]
    pub sensor_timeout_ms: Option<u64>,
    /// The sensor's expected noise, degrees (0 to 10): replan beyond max(1, 3 x noise) degrees
    /// from the plan, done within max(1.5, 2 x noise) degrees of the goal.
    #[arg(long, requires = "sensor", default_value_t = 0.0)]
    pub sensor_noise_deg: f64,
    /// With --sensor: at most this many steps (default: 3 x the plan's steps + 6).
    #[arg(long, requires = "sensor")]
    pub max_steps: Option<usize>,
    /// With --sensor: do not fit the wells to the measured steps (by default, once the
    /// scenario's predictions are off by more than the replan threshold, the loop steers with
    /// the wells that predict the measured steps best).
    #[arg(long, requires = "sensor")]
    pub no_identify: bool,
    /// With --sensor: play the plan as it is and read the sensor after every step, never
    /// replanning (an excitation run from `plan --excite`, logged with --log for `fit --log`).
    #[arg(long, requires = "sensor", conflicts_with_all = ["max_steps", "no_identify"])]
    pub no_replan: bool,
}

impl Args {
    /// The closed loop's sensor, with `--sensor`.
    fn sensor_options(&self) -> Option<SensorOptions> {
        let (device, format) = (self.sensor.clone()?, self.sensor_format?);
        Some(SensorOptions {
            baud: self.sensor_baud,
            mode: self.sensor_mode,
            timeout_ms: self.sensor_timeout_ms,
            noise_deg: self.sensor_noise_deg,
            max_steps: self.max_steps,
            identify: !self.no_identify,
            replan: !self.no_replan,
            ..SensorOptions::new(device, format)
        })
    }

    fn options(self) -> ReplayOptions {
        ReplayOptions {
            plan: self.plan,
            scenario: self.scenario,
            map: self.map,
            ports: self.port,
            board: self.board,
            baud: self.baud,
            mode: self.mode,
            dwell_ms: self.dwell_ms,
            from_step: self.from_step,
            dry_run: self.dry_run,
            log: self.log,
            verify: self.verify,
        }
    }

    pub fn run(self, out: &mut dyn Write) -> Result<()> {
        let stop = Arc::new(AtomicBool::new(false));
        let flag = stop.clone();
        ctrlc::set_handler(move || flag.store(true, Ordering::SeqCst))
            .context("installing the Ctrl-C/SIGTERM handler")?;
        if let Some(so) = self.sensor_options() {
            closed_replay::run(&self.options(), &so, stop, out).map_err(Flagged)?;
            return Ok(());
        }
        let input = (self.mode == Mode::Step && !self.dry_run).then(stdin_lines);
        replay::run(&self.options(), stop, input, out).map_err(Flagged)?;
        Ok(())
    }
}
