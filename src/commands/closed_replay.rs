//! `spherestep replay PLAN SCENARIO --sensor DEV ...`: the closed loop on the hardware. Reads
//! what `replay` reads and prepares the same checked schedule, builds the controller as
//! `simulate --closed-loop` does from a plan file (the scenario's motor and plan settings with
//! the plan file's own target, its last row the goal), opens the sensor and then the boards,
//! and hands them to the rig (`crate::rig`).

use super::closed_loop::{loop_settings, plan_file_loop, LoopOptions};
use super::replay::{inputs, Flags, ReplayOptions};
use crate::error::{Error, Result};
use crate::io::scenario::Scenario;
use crate::model::geometry::Orientation;
use crate::planning::cancel::Cancel;
use crate::planning::closed_loop::{Controller, LoopSettings};
use crate::planning::commutation::Motor;
use crate::planning::plan::{Plan, PlanSettings};
use crate::relay::replay::{check_log, open_ports, Prepared};
use crate::relay::Link;
use crate::rig::{execute_closed, refuse_options, ClosedSummary, Sensing};
use crate::sensor::bno055::FusionMode;
use crate::sensor::{self, OrientationSensor, SensorFormat};
use std::io::Write;
use std::sync::atomic::AtomicBool;
use std::sync::Arc;
use std::time::Duration;

/// The sensor of a closed-loop replay, as the command line gives it.
#[derive(Debug, Clone, PartialEq)]
pub struct SensorOptions {
    /// The sensor's serial device (`--sensor`).
    pub device: String,
    /// `--sensor-format`.
    pub format: SensorFormat,
    /// `--sensor-baud` (default: the format's).
    pub baud: Option<u32>,
    /// `--sensor-mode`: the BNO055's fusion mode (default IMU, no magnetometer).
    pub mode: Option<FusionMode>,
    /// `--sensor-timeout-ms`: how long to wait for a reading (default 500).
    pub timeout_ms: Option<u64>,
    /// `--sensor-noise-deg`: the sensor's expected noise; sets the replan and goal thresholds.
    pub noise_deg: f64,
    /// `--max-steps` (default: 3 x the plan's steps + 6).
    pub max_steps: Option<usize>,
    /// Fit the wells to the measured steps and steer with the fit where the scenario's model
    /// is wrong (`--no-identify` turns it off).
    pub identify: bool,
    /// Replan from the measurements (`--no-replan` turns it off: the plan is played as it is
    /// and read after every step, as an excitation run for `fit --log` wants).
    pub replan: bool,
}

impl SensorOptions {
    /// A sensor on `device` speaking `format`, everything else at its default.
    pub fn new(device: impl Into<String>, format: SensorFormat) -> SensorOptions {
        SensorOptions {
            device: device.into(),
            format,
            baud: None,
            mode: None,
            timeout_ms: None,
            noise_deg: 0.0,
            max_steps: None,
            identify: true,
            replan: true,
        }
    }

    /// The sensor's baud rate, bits per second: `--sensor-baud`, else the format's default.
    pub fn baud(&self) -> u32 {
        self.baud.unwrap_or(self.format.default_baud())
    }

    /// The BNO055's fusion mode: `--sensor-mode`, else IMU.
    pub fn mode(&self) -> FusionMode {
        self.mode.unwrap_or_default()
    }

    /// How long a reading is awaited: `--sensor-timeout-ms`, else the sensor layer's default.
    pub fn timeout(&self) -> Duration {
        self.timeout_ms
            .map_or(sensor::DEFAULT_TIMEOUT, Duration::from_millis)
    }
}

/// Everything read and checked before a port is opened.
pub struct ClosedInputs {
    /// The replay of the plan as it is, checked as a whole.
    pub prep: Prepared,
    /// The scenario, the map applied.
    pub scenario: Scenario,
    /// The scenario's plan settings with the plan file's target.
    pub settings: PlanSettings,
    /// The plan as read from its file (the open-loop plan the loop starts from).
    pub open: Plan,
    /// The plan's last orientation.
    pub goal: Orientation,
    /// The controller's settings, worked out from the options and the plan.
    pub cl: LoopSettings,
}

/// Reads the plan, scenario and map, checks the options and the schedule of the plan, and
/// works out the controller's settings; opens nothing.
pub fn prepare_closed(opts: &ReplayOptions, so: &SensorOptions) -> Result<ClosedInputs> {
    refuse_options(&opts.drive(), opts.dry_run)?;
    check_sensor_options(so)?;
    let (rows, scenario, relay) = inputs(opts)?;
    let f = plan_file_loop(&scenario, &scenario.plan, rows, &opts.plan)?;
    let o = LoopOptions {
        closed: so.replan,
        noise_deg: so.noise_deg,
        seed: 0,
        max_steps: so.max_steps,
        identify: so.identify,
    };
    let rows = &f.plan.rows;
    let cl = loop_settings(&o, rows.len() - 1)?;
    let prep = crate::relay::replay::prepare(rows, relay, scenario.stator.len(), opts.drive())?
        .worded(&Flags);
    check_log(&prep, true)?;
    check_sensor_timeout(so, prep.settings.max_on_time)?;
    if let Some(i) = prep
        .boards
        .iter()
        .position(|b| b.port.as_deref() == Some(so.device.as_str()))
    {
        return Err(Error::Arg {
            arg: "--sensor".into(),
            expected: format!(
                "the sensor's own serial device, got {}, board {i}'s port",
                so.device
            ),
        });
    }
    // the replans count the dwells the replay keeps
    let mut settings = f.settings;
    if let (Some(l), Some(ms)) = (settings.limits.on_time.as_mut(), opts.dwell_ms) {
        l.fixed_dwell = Some(Duration::from_millis(ms));
    }
    Ok(ClosedInputs {
        prep,
        scenario,
        settings,
        open: f.plan,
        goal: f.goal,
        cl,
    })
}

/// The longest `--sensor-timeout-ms` accepted.
pub const MAX_SENSOR_TIMEOUT: Duration = Duration::from_secs(60);

/// The sensor is awaited with the step's coils on: its timeout must leave them room under the
/// on-time limit (the replay also switches everything off before the limit whatever the
/// timeout, see `rig`), and is at most [`MAX_SENSOR_TIMEOUT`].
fn check_sensor_timeout(so: &SensorOptions, max_on_time: Duration) -> Result<()> {
    let t = so.timeout();
    let bound = max_on_time.min(MAX_SENSOR_TIMEOUT);
    if t >= bound {
        let why = if max_on_time <= MAX_SENSOR_TIMEOUT {
            format!(
                "shorter than relay.max_on_time_s ({} ms: the coils stay on while the sensor is awaited)",
                max_on_time.as_millis()
            )
        } else {
            format!("at most {} ms", MAX_SENSOR_TIMEOUT.as_millis() - 1)
        };
        return Err(Error::Arg {
            arg: "--sensor-timeout-ms".into(),
            expected: format!("a timeout {why}, got {} ms", t.as_millis()),
        });
    }
    Ok(())
}

fn check_sensor_options(so: &SensorOptions) -> Result<()> {
    if let Some(b) = so.baud.filter(|b| !(1..=4_000_000).contains(b)) {
        return Err(Error::Arg {
            arg: "--sensor-baud".into(),
            expected: format!("a baud rate from 1 to 4000000, got {b}"),
        });
    }
    if so.timeout_ms == Some(0) {
        return Err(Error::Arg {
            arg: "--sensor-timeout-ms".into(),
            expected: "a timeout of at least 1 ms, got 0".into(),
        });
    }
    if let (Some(m), SensorFormat::QuatCsv) = (so.mode, so.format) {
        return Err(Error::Arg {
            arg: "--sensor-mode".into(),
            expected: format!(
                "no --sensor-mode with a quat-csv sensor (the mode is the BNO055's; the sketch behind a quat-csv port chooses its own fusion), got {}",
                m.name()
            ),
        });
    }
    if so.device.trim().is_empty() {
        return Err(Error::Arg {
            arg: "--sensor".into(),
            expected: "a serial device such as /dev/ttyACM0, got an empty string".into(),
        });
    }
    Ok(())
}

/// Runs the closed loop of `inputs` over `links` (one per board) and `sensor` (both opened by
/// the caller).
pub fn execute(
    inputs: &ClosedInputs,
    links: Vec<Link>,
    sensor: Box<dyn OrientationSensor>,
    stop: Arc<AtomicBool>,
    out: &mut dyn Write,
) -> Result<ClosedSummary> {
    // the replans can be abandoned when the coils must go off (rig)
    let cancel = Cancel::new();
    let motor = Motor {
        cancel: cancel.clone(),
        ..inputs.scenario.motor()
    };
    let controller = Controller::new(
        &motor,
        &inputs.settings,
        &inputs.open,
        inputs.goal,
        inputs.cl,
    )
    .ok_or_else(|| Error::Parse {
        file: inputs.scenario.path.clone(),
        message: "the plan has no initial commutation state".into(),
    })?;
    let sensing = Sensing {
        sensor,
        controller,
        settings: inputs.cl,
        stator_coils: inputs.scenario.stator.len(),
        mount: inputs.scenario.sensor.mount,
        cancel,
    };
    Ok(execute_closed(&inputs.prep, links, sensing, stop, out)?)
}

/// `spherestep replay ... --sensor DEV`: prepares, opens the sensor (a failure there touches no
/// board), then the boards' ports, and runs the closed loop.
pub fn run(
    opts: &ReplayOptions,
    so: &SensorOptions,
    stop: Arc<AtomicBool>,
    out: &mut dyn Write,
) -> Result<ClosedSummary> {
    let inputs = prepare_closed(opts, so)?;
    let sensor = sensor::open(so.format, so.mode(), &so.device, so.baud(), so.timeout())?;
    let links = open_ports(&inputs.prep)?;
    execute(&inputs, links, sensor, stop, out)
}
