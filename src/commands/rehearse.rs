//! `spherestep virtual`: reads the plant (a scenario: its motor, its `[relay]` boards, coil map
//! and limits), checks the options, and runs the virtual motor of `crate::rehearse` on
//! pseudo-terminals until the replaying side is done or a signal comes; then the summary.

use crate::commands::args::{as_flag, parse_mount};
use crate::error::{Error, Input, Result};
use crate::io::output::check_not_input;
use crate::io::planfile::read_plan;
use crate::io::scenario::Scenario;
use crate::model::geometry::{CoilId, Degrees, Orientation, Pair};
use crate::rehearse::plant::Ball;
use crate::rehearse::{BoardSetup, Faults, Options, Summary};
use crate::relay::{BoardKind, Channel, Slot};
use crate::sensor::SensorFormat;
use std::collections::BTreeMap;
use std::path::PathBuf;
use std::time::Duration;

/// The fastest virtual clock accepted, times the wall clock.
pub const MAX_SPEED: f64 = 1000.0;

/// The options of `spherestep virtual`, as the command line gives them.
#[derive(Debug, Clone)]
pub struct VirtualOptions {
    /// The plant: a scenario (its physics, `[relay]` section, start orientation).
    pub plant: PathBuf,
    /// One board of this protocol instead of the plant's `[relay]` boards.
    pub board: Option<BoardKind>,
    /// A sensor's pseudo-terminal, answering this protocol.
    pub sensor: Option<SensorFormat>,
    /// The sensor's noise, degrees (0 to 10; seeded).
    pub sensor_noise_deg: f64,
    /// The seed of the sensor's noise and of its garbled readings.
    pub seed: u64,
    /// The virtual clock runs this many times as fast as the wall clock (above 0, at most
    /// [`MAX_SPEED`]).
    pub speed: f64,
    /// `qx,qy,qz,qw`: the sensor's mounting on the ball.
    pub mount: Option<String>,
    /// A directory for stable names of the ports (`board0`, ..., `sensor`).
    pub link_dir: Option<PathBuf>,
    /// A CSV log of every frame and event.
    pub log: Option<PathBuf>,
    /// A plan whose pairs say which magnet each coil pulls (pair interaction), and whose row
    /// 0 is where the ball starts.
    pub plan: Option<PathBuf>,
    /// The board the board faults act on (default 0).
    pub fault_board: usize,
    /// Fault: that board's port vanishes after this many frames.
    pub drop_after_frames: Option<usize>,
    /// Fault: that board stops answering after this many frames, its port open.
    pub silent_after_frames: Option<usize>,
    /// Fault: the sensor goes silent after this many readings.
    pub sensor_stall_after: Option<usize>,
    /// Fault: this fraction (0 to 1) of the sensor's readings are corrupted.
    pub sensor_garble: f64,
    /// `CH` (board 0) or `B:CH`.
    pub stuck_relay: Option<String>,
    /// Stop after this many seconds of wall clock.
    pub max_seconds: Option<f64>,
}

impl VirtualOptions {
    /// The defaults for a plant: no sensor, no noise, seed 1, speed 1, no faults.
    pub fn new(plant: impl Into<PathBuf>) -> VirtualOptions {
        VirtualOptions {
            plant: plant.into(),
            board: None,
            sensor: None,
            sensor_noise_deg: 0.0,
            seed: 1,
            speed: 1.0,
            mount: None,
            link_dir: None,
            log: None,
            plan: None,
            fault_board: 0,
            drop_after_frames: None,
            silent_after_frames: None,
            sensor_stall_after: None,
            sensor_garble: 0.0,
            stuck_relay: None,
            max_seconds: None,
        }
    }
}

fn arg(arg: &str, expected: impl Into<String>) -> Error {
    Error::Arg {
        arg: arg.into(),
        expected: expected.into(),
    }
}

/// The boards of the plant (or `--board`): protocol, channels, slave address.
fn boards(sc: &Scenario, o: &VirtualOptions) -> Result<Vec<BoardSetup>> {
    let r = &sc.relay;
    if !r.boards.is_empty() {
        if o.board.is_some() {
            return Err(arg(
                "--board",
                format!(
                    "no --board: {} lists its boards as [[relay.boards]]",
                    sc.path.display()
                ),
            ));
        }
        return Ok((r.boards.iter())
            .map(|b| BoardSetup {
                kind: b.kind,
                channels: b.channels,
                slave_address: b.slave_address,
            })
            .collect());
    }
    let kind = o.board.or(r.board).ok_or_else(|| {
        arg(
            "--board",
            format!(
                "lcus, kmtronic, numato or modbus ({} has no relay.board)",
                sc.path.display()
            ),
        )
    })?;
    Ok(vec![BoardSetup {
        kind,
        channels: r.channels.unwrap_or(kind.default_channels()),
        slave_address: r.slave_address,
    }])
}

/// `CH` (board 0) or `B:CH`, on a board of the list.
fn stuck_relay(text: &str, boards: &[BoardSetup]) -> Result<Slot> {
    let bad = || {
        arg(
            "--stuck-relay",
            format!("a channel CH (board 0) or BOARD:CH, from 1, on one of the {} board(s), got '{text}'", boards.len()),
        )
    };
    let (b, ch) = match text.split_once(':') {
        Some((b, c)) => (b.trim().parse::<usize>().map_err(|_| bad())?, c),
        None => (0, text),
    };
    let ch = ch.trim().parse::<u16>().map_err(|_| bad())?;
    match boards.get(b) {
        Some(s) if (1..=s.channels).contains(&ch) => Ok(Slot {
            board: b,
            channel: Channel(ch),
        }),
        _ => Err(bad()),
    }
}

/// Reads the plant and checks every option: what the virtual motor runs with.
pub fn prepare(o: &VirtualOptions) -> Result<Options> {
    let max_seconds = check_numbers(o)?;
    let mount: Orientation = match &o.mount {
        None => Orientation::identity(),
        Some(m) => parse_mount(m, "--mount")?,
    };
    let sc = Scenario::load(&o.plant)?;
    if let Some(log) = &o.log {
        // the log is written from the start: never over a file the virtual motor reads
        let mut read = sc.files.clone();
        read.extend(o.plan.iter().cloned());
        check_not_input(log, &read).map_err(|e| as_flag(e, Input::Output, "--log"))?;
    }
    let boards = boards(&sc, o)?;
    let coil_of = coil_of(&sc, &boards);
    if o.fault_board >= boards.len() {
        return Err(arg(
            "--fault-board",
            format!(
                "a board of the plant, 0 to {}, got {}",
                boards.len() - 1,
                o.fault_board
            ),
        ));
    }
    let stuck = match &o.stuck_relay {
        None => None,
        Some(t) => Some(stuck_relay(t, &boards)?),
    };
    let (start, hint) = start_and_hint(&sc, o)?;
    Ok(Options {
        boards,
        coil_of,
        max_coils_on: sc.relay.max_coils_on,
        max_on_time: sc.relay.max_on_time,
        ball: Ball::new(sc.torques.clone(), sc.body, sc.settle, start, hint),
        sensor: o.sensor,
        sensor_noise: Degrees(o.sensor_noise_deg).to_radians(),
        seed: o.seed,
        speed: o.speed,
        mount,
        link_dir: o.link_dir.clone(),
        log: o.log.clone(),
        faults: Faults {
            board: o.fault_board,
            drop_after_frames: o.drop_after_frames,
            silent_after_frames: o.silent_after_frames,
            sensor_stall_after: o.sensor_stall_after,
            sensor_garble: o.sensor_garble,
            stuck_relay: stuck,
        },
        max_seconds,
    })
}

/// Checks the options that are numbers (speed, noise, faults, time limit) before the plant is
/// read: the time limit.
fn check_numbers(o: &VirtualOptions) -> Result<Option<Duration>> {
    if !(o.speed.is_finite() && o.speed > 0.0 && o.speed <= MAX_SPEED) {
        return Err(arg(
            "--speed",
            format!(
                "a number > 0 and <= {MAX_SPEED}, got {}",
                crate::text::shown(o.speed)
            ),
        ));
    }
    if !(o.sensor_noise_deg.is_finite() && (0.0..=10.0).contains(&o.sensor_noise_deg)) {
        return Err(arg(
            "--sensor-noise-deg",
            format!(
                "degrees from 0 to 10, got {}",
                crate::text::shown(o.sensor_noise_deg)
            ),
        ));
    }
    if !(o.sensor_garble.is_finite() && (0.0..=1.0).contains(&o.sensor_garble)) {
        return Err(arg(
            "--sensor-garble",
            format!(
                "a fraction from 0 to 1, got {}",
                crate::text::shown(o.sensor_garble)
            ),
        ));
    }
    if o.sensor.is_none() && (o.sensor_stall_after.is_some() || o.sensor_garble > 0.0) {
        let which = match o.sensor_stall_after {
            Some(_) => "--sensor-stall-after",
            None => "--sensor-garble",
        };
        return Err(arg(
            which,
            "a sensor to fault: give --sensor quat-csv or bno055",
        ));
    }
    if o.drop_after_frames == Some(0) {
        return Err(arg("--drop-after-frames", "a number of frames >= 1, got 0"));
    }
    if o.drop_after_frames.is_some() && o.silent_after_frames.is_some() {
        return Err(arg(
            "--silent-after-frames",
            "one board fault at a time: not with --drop-after-frames",
        ));
    }
    match o.max_seconds {
        None => Ok(None),
        Some(s) if s.is_finite() && s > 0.0 && s <= 1e6 => Ok(Some(Duration::from_secs_f64(s))),
        Some(s) => Err(arg(
            "--max-seconds",
            format!("seconds > 0 and <= 1000000, got {}", crate::text::shown(s)),
        )),
    }
}

/// The coil on each relay of `boards` (the plant's coil map; a single board's slots all on
/// board 0); coils mapped to no channel of the boards are left out.
fn coil_of(sc: &Scenario, boards: &[BoardSetup]) -> BTreeMap<Slot, CoilId> {
    let mut coil_of = BTreeMap::new();
    for c in 0..sc.stator.points.len() {
        let Some(mut slot) = sc.relay.map.slot(CoilId(c)) else {
            continue;
        };
        if sc.relay.boards.is_empty() {
            slot.board = 0;
        }
        if boards
            .get(slot.board)
            .is_some_and(|b| (1..=b.channels).contains(&slot.channel.0))
        {
            coil_of.insert(slot, CoilId(c));
        }
    }
    coil_of
}

/// Where the ball starts and the pairs each row of `--plan` holds (the scenario's start and
/// none without a plan); the plan's pairs checked against the scenario.
fn start_and_hint(sc: &Scenario, o: &VirtualOptions) -> Result<(Orientation, Vec<Vec<Pair>>)> {
    let Some(p) = &o.plan else {
        return Ok((sc.plan.start, Vec::new()));
    };
    let rows = read_plan(p)?;
    for r in &rows {
        sc.check_active(&r.active, &format!("{}: step {}", p.display(), r.step))?;
    }
    let start = rows.first().map_or(sc.plan.start, |r| r.q);
    let hint: Vec<Vec<Pair>> = rows.into_iter().map(|r| r.active).collect();
    Ok((start, hint))
}

/// Runs the virtual motor with `o` until the replaying side is done or `stop` is set;
/// `ready` is told the ports as soon as they exist.
#[cfg(all(feature = "hardware", unix))]
pub fn run(
    o: &VirtualOptions,
    stop: std::sync::Arc<std::sync::atomic::AtomicBool>,
    ready: &mut dyn FnMut(&[crate::rehearse::live::PortInfo]),
) -> std::result::Result<Summary, VirtualError> {
    let opts = prepare(o)?;
    Ok(crate::rehearse::live::run(&opts, stop, ready)?)
}

/// Why `virtual` failed.
#[derive(Debug, thiserror::Error)]
pub enum VirtualError {
    /// The options, the plant's scenario or its plan were refused.
    #[error(transparent)]
    Input(#[from] Error),
    /// The virtual motor could not run (its pseudo-terminals, links or log).
    #[error(transparent)]
    Rehearse(#[from] crate::rehearse::RehearseError),
}
