//! Hardware replay of a plan (`spherestep replay`): turns each step's active set into relay
//! switching, on one board or on several (`[[relay.boards]]`, one driver each, every coil on
//! its board and channel), in order (new coils on before released ones off, by default), waits
//! the dwell (realtime) or for Enter (step mode), and always ends with every channel of every
//! board off: at the end, on an error, on Ctrl-C/SIGTERM/SIGHUP (a flag the caller sets), and
//! when a port fails (the all-off is still sent to every other board, and every failure is
//! reported with its board and port). The limits (coils on at once, one coil's continuous
//! on-time) are checked on the whole schedule, counting the coils of all boards, before any
//! byte is sent. `--dry-run` runs the same code on links that only record, with a simulated
//! clock. `--log` writes what was sent when (and, with several boards, to which board).
//!
//! The runner owns every coil deadline (the one mechanism for the on-time guarantee): a coil
//! counts as on from the moment its frame is sent, and the runner's [`Watch`] holds the earliest
//! time a coil reaches its guard (its limit less [`on_time::guard_margin`]). Every wait (a dwell,
//! Enter in step mode, a board's reply or blocked write, and in a closed loop the sensor and the
//! decision) ends there: every coil is switched off (a board that did not answer last) and the
//! replay stops, saying how long the coil was on when its board's all-off went out.

use super::watch::Watch;
use super::{
    connect, hex, BoardKind, BoardSpec, Channel, CoilMap, Link, OnTimeAdvice, RelayBoard,
    RelayError, RelaySettings, Setting, Slot, SwitchOrder,
};
use crate::model::geometry::CoilId;
use crate::planning::on_time;
use crate::planning::plan::PlanRow;
use std::collections::{BTreeMap, BTreeSet};
use std::io::{BufRead, Write};
use std::path::{Path, PathBuf};
use std::str::FromStr;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::mpsc::{Receiver, RecvTimeoutError};
use std::sync::Arc;
use std::time::{Duration, Instant};

/// How the replay advances.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Mode {
    /// Switch, wait the dwell, go on (the paper's "pseudo-realtime").
    Realtime,
    /// Wait for Enter before each step (`q` quits).
    Step,
}

impl FromStr for Mode {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        match s.trim().to_ascii_lowercase().as_str() {
            "realtime" => Ok(Mode::Realtime),
            "step" => Ok(Mode::Step),
            _ => Err(format!("expected realtime or step, got '{s}'")),
        }
    }
}

/// One relay switched: a coil, on its board (0 with a single board) and channel.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Switch {
    pub coil: CoilId,
    pub board: usize,
    pub channel: Channel,
    pub on: bool,
}

impl Switch {
    /// Where the relay is.
    pub fn slot(&self) -> Slot {
        Slot {
            board: self.board,
            channel: self.channel,
        }
    }
}

/// One entry of the schedule: a plan step (or, when resuming, the re-energising of the step
/// before the first one replayed).
#[derive(Debug, Clone, PartialEq)]
pub struct Entry {
    pub step: usize,
    /// Re-energises `step`'s active set to hold the ball before resuming at `step + 1`.
    pub hold: bool,
    /// The switching, in the order it is sent.
    pub switches: Vec<Switch>,
    /// What is on after the entry, by board and channel.
    pub on_after: BTreeMap<Slot, CoilId>,
    /// The most coils on at any moment of the entry, all boards together.
    pub peak: usize,
    /// Time to wait after switching (realtime).
    pub dwell: Duration,
    /// The dwell comes from a settle time that is no settle: the step never settled in the
    /// plan (`settled = false`, its settle time t_max), so the replay says so when it waits.
    pub unsettled: bool,
}

/// The whole replay, worked out and checked before anything is sent.
#[derive(Debug, Clone, PartialEq)]
pub struct Schedule {
    pub entries: Vec<Entry>,
}

/// The dwell of a plan row: the override as given, or settle time x factor, at least the floor
/// (the planners' own computation, [`crate::planning::on_time::OnTimeLimit::dwell`]).
pub fn dwell(
    row: &PlanRow,
    settings: &RelaySettings,
    dwell_override: Option<Duration>,
) -> Duration {
    let limit = on_time::OnTimeLimit {
        fixed_dwell: dwell_override,
        ..settings.on_time_limit()
    };
    limit.dwell(row.settle_time_s)
}

/// `schedule_on` for a single board of type `board` with `channels` channels.
#[allow(clippy::too_many_arguments)]
pub fn schedule(
    rows: &[PlanRow],
    settings: &RelaySettings,
    board: BoardKind,
    channels: u16,
    stator_coils: usize,
    dwell_override: Option<Duration>,
    from_step: usize,
    mode: Mode,
) -> Result<Schedule, RelayError> {
    let spec = BoardSpec {
        kind: board,
        channels,
        baud: board.default_baud(),
        slave_address: settings.slave_address,
        timeout: settings.timeout,
        port: None,
    };
    let dwell = dwell_override;
    schedule_on(
        rows,
        settings,
        &[spec],
        stator_coils,
        dwell,
        from_step,
        mode,
    )
}

/// Works out the schedule of a plan on `boards` and checks it: every coil on the stator and
/// driven by a channel of a board, never more than `max_coils_on` coils on (all boards
/// together), and (realtime) no coil on longer than `max_on_time` in a row.
pub fn schedule_on(
    rows: &[PlanRow],
    settings: &RelaySettings,
    boards: &[BoardSpec],
    stator_coils: usize,
    dwell_override: Option<Duration>,
    from_step: usize,
    mode: Mode,
) -> Result<Schedule, RelayError> {
    if from_step >= rows.len() {
        return Err(RelayError::Setting {
            setting: Setting::FromStep,
            expected: format!(
                "a step of the plan, 0..={}, got {from_step}",
                rows.len().saturating_sub(1)
            ),
        });
    }
    let first = from_step.saturating_sub(1);
    let from = Resume {
        on: BTreeMap::new(),
        hold_first: from_step > 0,
    };
    let entries = entries_from(
        &rows[first..],
        settings,
        boards,
        stator_coils,
        dwell_override,
        from,
    )?;
    if mode == Mode::Realtime {
        let listed = !settings.boards.is_empty();
        check_on_time(&entries, settings.max_on_time, listed, BTreeMap::new())?;
    }
    Ok(Schedule { entries })
}

/// Where a run of entries starts from: what is on before it, and whether its first entry
/// re-energises a step (a resume) rather than switches one.
#[derive(Debug, Clone, Default)]
pub(super) struct Resume {
    pub on: BTreeMap<Slot, CoilId>,
    pub hold_first: bool,
}

/// The entries of `rows`, in order, switching from what `from` says is on: every coil on the
/// stator and driven by a channel of a board, never more than `max_coils_on` coils on (all
/// boards together, counting the transitions).
pub(super) fn entries_from(
    rows: &[PlanRow],
    settings: &RelaySettings,
    boards: &[BoardSpec],
    stator_coils: usize,
    dwell_override: Option<Duration>,
    from: Resume,
) -> Result<Vec<Entry>, RelayError> {
    let mut entries = Vec::new();
    let mut prev = from.on;
    for (k, row) in rows.iter().enumerate() {
        let mut target = BTreeMap::new();
        for p in &row.active {
            let slot = slot_of(p.coil, row.step, settings, boards, stator_coils)?;
            target.insert(slot, p.coil);
        }
        let (switches, peak) = transition(&prev, &target, settings.order);
        if peak > settings.max_coils_on {
            return Err(too_many_on(row.step, peak, &prev, &target, settings));
        }
        entries.push(Entry {
            step: row.step,
            hold: k == 0 && from.hold_first,
            switches,
            on_after: target.clone(),
            peak,
            dwell: dwell(row, settings, dwell_override),
            unsettled: !row.settled && dwell_override.is_none(),
        });
        prev = target;
    }
    Ok(entries)
}

/// The switching from what is on (`prev`, by board and channel) to `target`, in the order it
/// is sent, and the most coils on at any moment of it.
fn transition(
    prev: &BTreeMap<Slot, CoilId>,
    target: &BTreeMap<Slot, CoilId>,
    order: SwitchOrder,
) -> (Vec<Switch>, usize) {
    let switches = |from: &BTreeMap<Slot, CoilId>, to: &BTreeMap<Slot, CoilId>, on| {
        from.iter()
            .filter(|(slot, _)| !to.contains_key(slot))
            .map(|(&slot, &coil)| Switch {
                coil,
                board: slot.board,
                channel: slot.channel,
                on,
            })
            .collect::<Vec<_>>()
    };
    let ons = switches(target, prev, true);
    let offs = switches(prev, target, false);
    match order {
        SwitchOrder::MakeBeforeBreak => (
            ons.iter().chain(&offs).copied().collect(),
            prev.len() + ons.len(),
        ),
        SwitchOrder::BreakBeforeMake => (
            offs.iter().chain(&ons).copied().collect(),
            prev.len().max(target.len()),
        ),
    }
}

/// The error of a step that would have `peak` coils on at once, naming them.
fn too_many_on(
    step: usize,
    peak: usize,
    prev: &BTreeMap<Slot, CoilId>,
    target: &BTreeMap<Slot, CoilId>,
    settings: &RelaySettings,
) -> RelayError {
    let coils: BTreeSet<CoilId> = prev.values().chain(target.values()).copied().collect();
    let names: Vec<String> = coils.iter().map(|c| c.to_string()).collect();
    RelayError::TooManyOn {
        step,
        count: peak,
        max: settings.max_coils_on,
        coils: format!("coils {}", names.join(", ")),
    }
}

/// The board and channel driving `coil` in plan step `step`, checked against the stator and
/// the boards.
fn slot_of(
    coil: CoilId,
    step: usize,
    settings: &RelaySettings,
    boards: &[BoardSpec],
    stator_coils: usize,
) -> Result<Slot, RelayError> {
    let unmapped = |reason: String| RelayError::Unmapped { step, coil, reason };
    if coil.0 >= stator_coils {
        return Err(unmapped(format!(
            "is not on the stator (the scenario has {stator_coils} coils)"
        )));
    }
    let slot = settings
        .map
        .slot(coil)
        .ok_or_else(|| unmapped(unmapped_reason(&settings.map)))?;
    if settings.boards.is_empty() {
        let (board, channels) = boards
            .first()
            .map_or((BoardKind::Lcus, 0), |b| (b.kind, b.channels));
        return single_channel(slot, board, channels).map_err(unmapped);
    }
    match boards.get(slot.board) {
        Some(b) if (1..=b.channels).contains(&slot.channel.0) => Ok(slot),
        Some(b) => Err(unmapped(format!(
            "is mapped to board {} channel {}, but board {} ({} board) has channels 1..={}",
            slot.board, slot.channel, slot.board, b.kind, b.channels
        ))),
        None => Err(unmapped(format!(
            "is mapped to board {}, but [[relay.boards]] lists {} boards",
            slot.board,
            boards.len()
        ))),
    }
}

/// Why no channel drives a coil, for each kind of map.
fn unmapped_reason(map: &CoilMap) -> String {
    match map {
        CoilMap::Laid(counts) => {
            let total: usize = counts.iter().map(|&n| usize::from(n)).sum();
            format!(
                "lies past the {total} channels of the {} boards (without [relay.map] the coils are laid onto [[relay.boards]] in order; give it a \"board:channel\" in [relay.map])",
                counts.len()
            )
        }
        CoilMap::Slots(_) => {
            "no relay channel drives (add it to [relay.map] as \"board:channel\", or to the map file)".into()
        }
        _ => "no relay channel drives (add it to [relay.map] or the map file)".into(),
    }
}

/// Checks a single board's channel against its count (the reason when it is past it).
fn single_channel(slot: Slot, board: BoardKind, channels: u16) -> Result<Slot, String> {
    let ch = slot.channel;
    if ch.0 > channels {
        let hint = if board == BoardKind::Lcus {
            format!(
                " (LCUS boards have at most {} channels: drive 16 coils from a 16-channel numato or modbus board, or map the coils this plan uses onto channels 1..={channels})",
                super::lcus::MAX_CHANNELS
            )
        } else {
            " (set relay.channels, or map the coil to a lower channel)".into()
        };
        return Err(format!(
            "is mapped to channel {ch}, but the {board} board has {channels} channels{hint}"
        ));
    }
    Ok(slot)
}

/// What is on before a run of entries, for the on-time check: by board and channel, the coil,
/// the step it went on in and how long it has been on.
pub(super) type OnTimes = BTreeMap<Slot, (CoilId, usize, Duration)>;

/// Simulates the schedule: a coil's continuous on-time is the sum of the dwells while it stays
/// on, after the time it has been on already (`on`, empty for a schedule switched from all
/// off). `listed`: name the board in the error.
pub(super) fn check_on_time(
    entries: &[Entry],
    max: Duration,
    listed: bool,
    on: OnTimes,
) -> Result<(), RelayError> {
    let mut held: on_time::OnTimes<Slot> = on
        .iter()
        .map(|(&s, &(_, since_step, on))| (s, on_time::Held { since_step, on }))
        .collect();
    for e in entries {
        on_time::hold(&mut held, e.on_after.keys().copied(), e.step, e.dwell);
        if let Some((slot, h)) = on_time::over(&held, max) {
            // what is held is what is on after the entry
            let coil = e.on_after.get(&slot).copied().unwrap_or(CoilId(0));
            let unsettled: Vec<String> = entries
                .iter()
                .filter(|x| x.unsettled && (h.since_step..=e.step).contains(&x.step))
                .map(|x| x.step.to_string())
                .collect();
            let unsettled = match unsettled.is_empty() {
                true => String::new(),
                false => format!(
                    " (step {} never settled in the plan: its settle time is t_max)",
                    unsettled.join(", ")
                ),
            };
            return Err(RelayError::OnTooLong {
                coil,
                board: listed.then_some(slot.board),
                channel: slot.channel,
                when: format!(
                    "would stay on from step {} through step {}{unsettled} for",
                    h.since_step, e.step
                ),
                on: h.on,
                max,
                advice: OnTimeAdvice::Dwell,
            });
        }
    }
    Ok(())
}

/// Everything resolved from the options before a port is opened.
#[derive(Debug, Clone)]
pub struct Prepared {
    pub settings: RelaySettings,
    /// The boards, in order (one with the single-board form), ports resolved with `--port`.
    pub boards: Vec<BoardSpec>,
    pub schedule: Schedule,
    pub drive: Drive,
}

impl Prepared {
    /// Whether the boards come from `[[relay.boards]]`: the output and the log then say which
    /// board each frame went to, and errors name the board.
    pub fn listed(&self) -> bool {
        !self.settings.boards.is_empty()
    }
}

/// How to replay: the choices of the command line that the relay layer needs.
#[derive(Debug, Clone)]
pub struct Drive {
    /// Overrides `relay.board` (single board only).
    pub board: Option<BoardKind>,
    /// Overrides `relay.baud` (single board only).
    pub baud: Option<u32>,
    /// `--port`: the single board's device, or one per `[[relay.boards]]` entry, in order
    /// (overriding their `port`); empty when not given.
    pub ports: Vec<String>,
    pub mode: Mode,
    /// A fixed dwell for every step instead of settle time x factor (used as given: the floor is for the derived dwells).
    pub dwell_ms: Option<u64>,
    /// First step to replay; the step before is re-energised first to hold the ball.
    pub from_step: usize,
    /// CSV log of what was sent when (appended to when it exists).
    pub log: Option<PathBuf>,
    /// Read the relays back after each step (every board that can) and stop on a mismatch.
    pub verify: bool,
}

/// Resolves the boards (type, channels, baud rate, port) of `settings` under the overrides of
/// `drive` and works out the checked schedule of `rows` on a stator of `stator_coils` coils.
pub fn prepare(
    rows: &[PlanRow],
    settings: RelaySettings,
    stator_coils: usize,
    drive: Drive,
) -> Result<Prepared, RelayError> {
    let boards = if settings.boards.is_empty() {
        vec![single_board(&settings, &drive)?]
    } else {
        listed_boards(&settings, &drive)?
    };
    let schedule = schedule_on(
        rows,
        &settings,
        &boards,
        stator_coils,
        drive.dwell_ms.map(Duration::from_millis),
        drive.from_step,
        drive.mode,
    )?;
    Ok(Prepared {
        settings,
        boards,
        schedule,
        drive,
    })
}

/// The board of the single-board form: `--board`/`--baud` over the settings, one `--port`.
fn single_board(settings: &RelaySettings, drive: &Drive) -> Result<BoardSpec, RelayError> {
    let board = drive
        .board
        .or(settings.board)
        .ok_or_else(|| RelayError::Setting {
            setting: Setting::Board,
            expected: "lcus, kmtronic, numato or modbus (or `board` in the [relay] section)".into(),
        })?;
    let channels = settings.channels.unwrap_or(board.default_channels());
    // The same check `connect` makes, before anything else.
    connect(board, channels, settings.slave_address, Link::dry_run())?;
    if let Some(b) = drive.baud.filter(|b| !(1..=4_000_000).contains(b)) {
        return Err(RelayError::Setting {
            setting: Setting::Baud,
            expected: format!("a baud rate from 1 to 4000000, got {b}"),
        });
    }
    if drive.ports.len() > 1 {
        return Err(RelayError::Setting {
            setting: Setting::Port,
            expected: format!(
                "one serial device for the board, got {} (several boards are listed as [[relay.boards]] in [relay])",
                drive.ports.len()
            ),
        });
    }
    Ok(BoardSpec {
        kind: board,
        channels,
        baud: drive.baud.or(settings.baud).unwrap_or(board.default_baud()),
        slave_address: settings.slave_address,
        timeout: settings.timeout,
        port: drive.ports.first().cloned(),
    })
}

/// The boards of `[[relay.boards]]`, their ports overridden by `--port` (once per board, in
/// order); `--board` and `--baud` are refused (each entry has its own).
fn listed_boards(settings: &RelaySettings, drive: &Drive) -> Result<Vec<BoardSpec>, RelayError> {
    let refuse = |setting: Setting, key: &str| RelayError::Setting {
        setting,
        expected: format!(
            "none with [[relay.boards]] (each entry gives its board's `{key}`; this setting \
             applies to the single-board form only)"
        ),
    };
    if drive.board.is_some() {
        return Err(refuse(Setting::Board, "board"));
    }
    if drive.baud.is_some() {
        return Err(refuse(Setting::Baud, "baud"));
    }
    let mut boards = settings.boards.clone();
    if !drive.ports.is_empty() {
        if drive.ports.len() != boards.len() {
            return Err(RelayError::Setting {
                setting: Setting::Port,
                expected: format!(
                    "once per board of [[relay.boards]], in list order ({} boards), or not at all; got {}",
                    boards.len(),
                    drive.ports.len()
                ),
            });
        }
        for (i, (b, p)) in boards.iter_mut().zip(&drive.ports).enumerate() {
            if let Some(j) = drive.ports[..i].iter().position(|q| q == p) {
                return Err(RelayError::Setting {
                    setting: Setting::Port,
                    expected: format!(
                        "a different device for each board, got {p} for boards {j} and {i}"
                    ),
                });
            }
            b.port = Some(p.clone());
        }
    }
    for (i, b) in boards.iter().enumerate() {
        connect(b.kind, b.channels, b.slave_address, Link::dry_run())
            .map_err(|e| on_board(i, &configured_port(b), e))?;
    }
    Ok(boards)
}

/// How a board's port is named before it is opened (and in a dry run).
fn configured_port(spec: &BoardSpec) -> String {
    spec.port.clone().unwrap_or_else(|| "no port".into())
}

/// An error on board `index` (on `port`), for the multi-board form.
fn on_board(index: usize, port: &str, error: RelayError) -> RelayError {
    RelayError::OnBoard {
        index,
        port: port.to_string(),
        error: Box::new(error),
    }
}

/// Opens every board's serial port (8N1, its baud rate and timeout); every board needs one.
/// With several boards, when a port cannot be opened the boards already open are switched all
/// off (their state is unknown) before the error, naming the board, is returned.
///
/// # Errors
///
/// [`RelayError::Setting`] for a board without a port, [`RelayError::Open`] (naming the board
/// with several) for a port that cannot be opened.
#[cfg(feature = "hardware")]
pub fn open_ports(prep: &Prepared) -> Result<Vec<Link>, RelayError> {
    let listed = prep.listed();
    let ports = prep
        .boards
        .iter()
        .enumerate()
        .map(|(i, b)| {
            b.port.as_deref().ok_or_else(|| RelayError::Setting {
                setting: Setting::Port,
                expected: if listed {
                    format!("a serial device for board {i}: its `port` in [[relay.boards]], or one device per board in list order (or a dry run)")
                } else {
                    "a serial device such as /dev/ttyUSB0 (or a dry run)".into()
                },
            })
        })
        .collect::<Result<Vec<&str>, RelayError>>()?;
    let mut links = Vec::with_capacity(ports.len());
    for (i, (spec, port)) in prep.boards.iter().zip(ports).enumerate() {
        match Link::open_serial(port, spec.baud, spec.timeout) {
            Ok(l) => links.push(l),
            Err(e) if !listed => return Err(e),
            Err(e) => return Err(switch_off_opened(prep, links, on_board(i, port, e))),
        }
    }
    Ok(links)
}

/// Switches the boards already opened all off after `cause` (a port that failed to open).
#[cfg(feature = "hardware")]
fn switch_off_opened(prep: &Prepared, links: Vec<Link>, cause: RelayError) -> RelayError {
    let mut failed = Vec::new();
    let mut switched_off = Vec::new();
    for (i, (spec, link)) in prep.boards.iter().zip(links).enumerate() {
        let port = link.name().to_string();
        let off = connect(spec.kind, spec.channels, spec.slave_address, link)
            .and_then(|mut b| b.all_off());
        match off {
            Ok(()) => switched_off.push(format!("board {i} ({port})")),
            Err(e) => failed.push(on_board(i, &port, e)),
        }
    }
    if failed.is_empty() {
        return cause;
    }
    RelayError::BoardsOffFailed {
        cause: Some(Box::new(cause)),
        failed,
        switched_off,
    }
}

/// What a finished (or quit) replay did.
#[derive(Debug, Clone, PartialEq)]
pub struct Summary {
    /// Plan steps whose dwell completed.
    pub steps_done: usize,
    /// Where to resume (`--from-step`).
    pub next_step: usize,
    /// The user quit in step mode.
    pub quit: bool,
}

/// Replays a prepared single-board schedule over `link` (a port opened by the caller, or a
/// dry run): `execute_on` with one link.
pub fn execute(
    prep: &Prepared,
    link: Link,
    stop: Arc<AtomicBool>,
    input: Option<Receiver<String>>,
    out: &mut dyn Write,
) -> Result<Summary, RelayError> {
    execute_on(prep, vec![link], stop, input, out)
}

/// Replays a prepared schedule over `links`, one per board in order (ports opened by the
/// caller, e.g. with `open_ports`, or dry runs).
pub fn execute_on(
    prep: &Prepared,
    links: Vec<Link>,
    stop: Arc<AtomicBool>,
    input: Option<Receiver<String>>,
    out: &mut dyn Write,
) -> Result<Summary, RelayError> {
    let mut r = Runner::start(prep, links, stop, input, out, LogKind::Replay)?;
    r.log_start(prep.drive.from_step)?;
    let result = r.drive(&prep.schedule);
    r.finish(result)
}

impl<'a> Runner<'a> {
    /// Connects a driver per board over `links` (one per board, in order), picks the boards
    /// `--verify` reads back, opens the log (`kind` says its columns) and prints the header.
    /// Nothing is sent to a board yet.
    pub(super) fn start(
        prep: &Prepared,
        links: Vec<Link>,
        stop: Arc<AtomicBool>,
        input: Option<Receiver<String>>,
        out: &'a mut dyn Write,
        kind: LogKind,
    ) -> Result<Runner<'a>, RelayError> {
        let n = prep.boards.len();
        let mut switches = prep.schedule.entries.iter().flat_map(|e| &e.switches);
        if n == 0 || links.len() != n || switches.any(|s| s.board >= n) {
            return Err(RelayError::Setting {
                setting: Setting::Port,
                expected: format!("one link per board ({n} boards), got {}", links.len()),
            });
        }
        let dry_run = links.iter().all(Link::is_dry_run);
        let listed = prep.listed();
        let start = Instant::now();
        let watch = Arc::new(Watch::new(stop.clone(), start));
        let mut boards = Vec::with_capacity(n);
        for (i, (spec, mut link)) in prep.boards.iter().zip(links).enumerate() {
            link.set_watch(watch.clone());
            let port = if link.is_dry_run() {
                configured_port(spec)
            } else {
                link.name().to_string()
            };
            let driver =
                connect(spec.kind, spec.channels, spec.slave_address, link).map_err(|e| {
                    if listed {
                        on_board(i, &port, e)
                    } else {
                        e
                    }
                })?;
            boards.push(Driven {
                driver,
                port,
                verify: false,
                failed: false,
            });
        }
        if prep.drive.verify {
            choose_verified(&mut boards, listed)?;
        }
        let log = match &prep.drive.log {
            Some(p) => Some(Log::open(p, listed, kind)?),
            None => None,
        };
        print_header(out, prep, &boards, dry_run).map_err(stdout_error)?;
        Ok(Runner {
            boards,
            listed,
            out,
            log,
            start,
            watch,
            virtual_t: Duration::ZERO,
            dry_run,
            stop,
            input,
            mode: prep.drive.mode,
            max_on_time: prep.settings.max_on_time,
            on_since: BTreeMap::new(),
            off_at: BTreeMap::new(),
            next_step: prep.drive.from_step,
            steps_done: 0,
        })
    }
}

/// `--verify`: a single board must be able to read back; of several, those that can are read
/// back (at least one must).
fn choose_verified(boards: &mut [Driven], listed: bool) -> Result<(), RelayError> {
    let mut refused = None;
    for (i, b) in boards.iter_mut().enumerate() {
        match b.driver.read_back() {
            Ok(()) => b.verify = true,
            Err(e) if !listed => return Err(e),
            Err(e) => {
                refused.get_or_insert_with(|| on_board(i, &b.port, e));
            }
        }
    }
    match refused {
        Some(e) if !boards.iter().any(|b| b.verify) => Err(e),
        _ => Ok(()),
    }
}

/// A failed write of the replay's report.
pub(super) fn stdout_error(cause: std::io::Error) -> RelayError {
    RelayError::Log {
        path: "<stdout>".into(),
        cause,
    }
}

fn order_name(order: SwitchOrder) -> &'static str {
    match order {
        SwitchOrder::MakeBeforeBreak => "make-before-break",
        SwitchOrder::BreakBeforeMake => "break-before-make",
    }
}

fn mode_name(mode: Mode) -> &'static str {
    match mode {
        Mode::Realtime => "realtime",
        Mode::Step => "step mode",
    }
}

/// A board's type, channels and serial settings, as the header prints them.
fn board_line(spec: &BoardSpec) -> String {
    format!(
        "{} board, {} channels, {} baud{}",
        spec.kind,
        spec.channels,
        spec.baud,
        if spec.kind == BoardKind::Modbus {
            format!(", slave {}", spec.slave_address)
        } else {
            String::new()
        },
    )
}

/// The replay's first lines: where it goes, the board(s) and their settings, then the column
/// heads (with several boards, a `board` column).
fn print_header(
    out: &mut dyn Write,
    prep: &Prepared,
    boards: &[Driven],
    dry_run: bool,
) -> std::io::Result<()> {
    let steps = format!(
        "{}, {}, steps {}..={}",
        order_name(prep.settings.order),
        mode_name(prep.drive.mode),
        prep.drive.from_step,
        prep.schedule.entries.last().map_or(0, |e| e.step),
    );
    if !prep.listed() {
        let (spec, port) = (&prep.boards[0], &boards[0].port);
        let to = if dry_run {
            "dry run (no port opened)".to_string()
        } else {
            format!("replaying on {port}")
        };
        writeln!(out, "{to}: {}, {steps}", board_line(spec))?;
        return writeln!(
            out,
            "{:>9} {:>5} {:<8} {:>5} {:>7}  bytes",
            "t_s", "step", "action", "coil", "channel"
        );
    }
    let n = boards.len();
    if dry_run {
        writeln!(out, "dry run (no port opened): {n} boards, {steps}")?;
    } else {
        writeln!(out, "replaying on {n} boards: {steps}")?;
    }
    for (i, (spec, b)) in prep.boards.iter().zip(boards).enumerate() {
        let verify = match (prep.drive.verify, b.verify) {
            (false, _) => "",
            (true, true) => ", read back",
            (true, false) => ", not read back (cannot report its relays)",
        };
        writeln!(
            out,
            "  board {i} ({}): {}{verify}",
            b.port,
            board_line(spec)
        )?;
    }
    writeln!(
        out,
        "{:>9} {:>5} {:<8} {:>5} {:>5} {:>7}  bytes",
        "t_s", "step", "action", "coil", "board", "channel"
    )
}

/// The longest line read from standard input in step mode, bytes: a longer one (standard
/// input redirected from a device or a binary file) ends the input, as its end does, so that
/// it is never gathered without bound.
const STDIN_LINE_MAX: u64 = 4096;

/// Spawns a thread that forwards standard input line by line (for step mode); it stops at the
/// end of the input, at a line that is not UTF-8 text and at one over [`STDIN_LINE_MAX`].
pub fn stdin_lines() -> Receiver<String> {
    use std::io::{BufRead, Read};
    let (tx, rx) = std::sync::mpsc::channel();
    std::thread::spawn(move || {
        let mut stdin = std::io::stdin().lock();
        loop {
            let mut buf = Vec::new();
            match (&mut stdin)
                .take(STDIN_LINE_MAX)
                .read_until(b'\n', &mut buf)
            {
                Ok(0) | Err(_) => break,
                Ok(_) => {}
            }
            let ended = buf.last() == Some(&b'\n');
            if !ended && buf.len() as u64 == STDIN_LINE_MAX {
                break;
            }
            let Ok(line) = String::from_utf8(buf) else {
                break;
            };
            let line = line.strip_suffix('\n').unwrap_or(&line);
            let line = line.strip_suffix('\r').unwrap_or(line);
            if tx.send(line.to_string()).is_err() {
                break;
            }
        }
    });
    rx
}

/// The replay log: `t_s,step,action,coil,channel,bytes` (with several boards
/// `t_s,step,action,coil,board,channel,bytes`), one row per frame, a `done` row when a step's
/// dwell completed and a `start` row per run; flushed after every step. A closed-loop replay's
/// log has the measurement's columns after those (`LOG_SENSOR_COLUMNS`), empty in the other
/// rows.
pub(super) struct Log {
    path: PathBuf,
    file: std::io::BufWriter<std::fs::File>,
    /// The board column is written.
    pub(super) listed: bool,
    /// How many columns a row has (shorter rows are padded with empty ones).
    columns: usize,
}

/// Which replay a log is of: its columns.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(super) enum LogKind {
    Replay,
    /// With the measurement's columns (`LOG_SENSOR_COLUMNS`).
    ClosedLoop,
}

/// The log's header.
pub const LOG_HEADER: &str = "t_s,step,action,coil,channel,bytes";
/// The log's header with several boards (`[[relay.boards]]`).
pub const LOG_HEADER_BOARDS: &str = "t_s,step,action,coil,board,channel,bytes";
/// The columns a closed-loop replay's log has after the others: the measured quaternion, its
/// angle from the goal (degrees) and what the sensor sent (a line, or a frame in hex).
pub const LOG_SENSOR_COLUMNS: &str = "qw,qx,qy,qz,goal_deg,raw";

/// The log's header for one board or several (`listed`), of a replay or a closed loop.
pub(super) fn log_header(listed: bool, kind: LogKind) -> String {
    let base = if listed {
        LOG_HEADER_BOARDS
    } else {
        LOG_HEADER
    };
    match kind {
        LogKind::Replay => base.to_string(),
        LogKind::ClosedLoop => format!("{base},{LOG_SENSOR_COLUMNS}"),
    }
}

/// What a `--log` path holds before the replay writes to it.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
struct LogFile {
    /// A log with rows already (appended to, its header not written again).
    existing: bool,
    /// Its last byte is a line end (else one is written before the first row).
    ends_with_line_end: bool,
}

/// What refuses a log whose first line is `line` as a log of another kind than this replay's
/// (its `header`, of `kind`), if it is one: whose log it is and what to do.
fn other_log_kind(line: &[u8], header: &str, kind: LogKind) -> Option<String> {
    let other = [false, true]
        .into_iter()
        .flat_map(|l| {
            [
                log_header(l, LogKind::Replay),
                log_header(l, LogKind::ClosedLoop),
            ]
        })
        .find(|h| line == h.as_bytes());
    other.map(|other| {
        let why = if kind == LogKind::Replay && other.contains(LOG_SENSOR_COLUMNS) {
            "a closed-loop replay's log"
        } else if kind == LogKind::ClosedLoop && !other.contains(LOG_SENSOR_COLUMNS) {
            "a replay's log without the sensor's columns"
        } else {
            "one board / several"
        };
        format!(
            "its columns are `{other}`, this replay writes `{header}` ({why}): give another log file"
        )
    })
}

/// The longest first line read to tell whether a file is a replay log.
const LOG_FIRST_LINE_MAX: u64 = 4096;

/// Checks that the log at `path` may take this replay's rows: a new or empty file, or a log
/// whose first line is exactly this replay's header (`log_header(listed, kind)`). Anything
/// else is refused: a log of another kind (its columns would not line up), and any other file
/// (a plan, a scenario, notes: appending would corrupt it).
fn inspect_log(path: &Path, listed: bool, kind: LogKind) -> Result<LogFile, RelayError> {
    use std::io::{Read, Seek, SeekFrom};
    let err = |e| RelayError::Log {
        path: path.to_path_buf(),
        cause: e,
    };
    let refuse = |message: String| {
        err(std::io::Error::new(
            std::io::ErrorKind::InvalidData,
            message,
        ))
    };
    let header = log_header(listed, kind);
    let meta = match std::fs::metadata(path) {
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => {
            return Ok(LogFile {
                existing: false,
                ends_with_line_end: true,
            })
        }
        Err(e) => return Err(err(e)),
        Ok(m) => m,
    };
    if meta.is_dir() {
        return Err(refuse(
            "expected a file for the replay log, got a folder: give another log file".into(),
        ));
    }
    if meta.len() == 0 {
        return Ok(LogFile {
            existing: false,
            ends_with_line_end: true,
        });
    }
    let mut f = std::fs::File::open(path).map_err(err)?;
    let mut first = Vec::new();
    std::io::BufReader::new((&mut f).take(LOG_FIRST_LINE_MAX))
        .read_until(b'\n', &mut first)
        .map_err(err)?;
    let line = first.strip_suffix(b"\n").unwrap_or(&first);
    if line == header.as_bytes() {
        let mut last = [0u8];
        f.seek(SeekFrom::End(-1))
            .and_then(|_| f.read_exact(&mut last))
            .map_err(err)?;
        return Ok(LogFile {
            existing: true,
            ends_with_line_end: last[0] == b'\n',
        });
    }
    if let Some(message) = other_log_kind(line, &header, kind) {
        return Err(refuse(message));
    }
    let text = crate::error::printable(&String::from_utf8_lossy(line));
    let shown = match text.char_indices().nth(80) {
        Some((k, _)) => format!("{}...", &text[..k]),
        None => text,
    };
    Err(refuse(format!(
        "expected an empty or new file, or a replay log whose first line is exactly `{header}`; \
         its first line is `{shown}`, so it is not a replay log and is not appended to: give \
         another --log file"
    )))
}

/// Checks the replay's `--log` (when given) before any port is opened: see `Log::open`.
/// `closed_loop`: the log of a closed-loop replay (with the sensor's columns).
pub fn check_log(prep: &Prepared, closed_loop: bool) -> Result<(), RelayError> {
    let kind = match closed_loop {
        true => LogKind::ClosedLoop,
        false => LogKind::Replay,
    };
    match &prep.drive.log {
        Some(p) => inspect_log(p, prep.listed(), kind).map(|_| ()),
        None => Ok(()),
    }
}

impl Log {
    /// Opens (appends to) the log, after `inspect_log`: a new or empty file gets the header;
    /// a log of this replay's header is appended to, on a line of its own; anything else (a
    /// log of another kind, any other file) is refused.
    fn open(path: &Path, listed: bool, kind: LogKind) -> Result<Log, RelayError> {
        let err = |e| RelayError::Log {
            path: path.to_path_buf(),
            cause: e,
        };
        let header = log_header(listed, kind);
        let found = inspect_log(path, listed, kind)?;
        let file = std::fs::OpenOptions::new()
            .create(true)
            .append(true)
            .open(path)
            .map_err(err)?;
        let mut log = Log {
            path: path.to_path_buf(),
            file: std::io::BufWriter::new(file),
            listed,
            columns: header.split(',').count(),
        };
        if !found.existing {
            writeln!(log.file, "{header}").map_err(err)?;
        } else if !found.ends_with_line_end {
            writeln!(log.file).map_err(err)?;
        }
        Ok(log)
    }

    /// One row: `cols`, then empty columns up to the header's count.
    pub(super) fn row(&mut self, cols: &[&str]) -> Result<(), RelayError> {
        let pad = self.columns.saturating_sub(cols.len());
        writeln!(self.file, "{}{}", cols.join(","), ",".repeat(pad)).map_err(|e| RelayError::Log {
            path: self.path.clone(),
            cause: e,
        })
    }

    /// A `start` or `done` row (or another marker): time, step, action, the other columns
    /// empty.
    pub(super) fn marker(&mut self, t: &str, step: &str, action: &str) -> Result<(), RelayError> {
        self.row(&[t, step, action])
    }

    pub(super) fn flush(&mut self) -> Result<(), RelayError> {
        self.file.flush().map_err(|e| RelayError::Log {
            path: self.path.clone(),
            cause: e,
        })
    }
}

/// One board of the replay: its driver, its port (as messages name it) and whether `--verify`
/// reads it back.
pub(super) struct Driven {
    driver: Box<dyn RelayBoard>,
    port: String,
    verify: bool,
    /// An exchange with it failed (or was cut): its all-off goes last.
    failed: bool,
}

/// A replay in progress: the boards' drivers, the output, the log, the clock and what is on.
pub(super) struct Runner<'a> {
    /// The boards, in order (every switch's board is one of them: checked by `execute_on`).
    pub(super) boards: Vec<Driven>,
    /// `[[relay.boards]]`: the board column is printed and errors name their board.
    pub(super) listed: bool,
    pub(super) out: &'a mut dyn Write,
    pub(super) log: Option<Log>,
    pub(super) start: Instant,
    /// The stop flag and the earliest coil deadline, watched by every link's waits.
    watch: Arc<Watch>,
    pub(super) virtual_t: Duration,
    pub(super) dry_run: bool,
    pub(super) stop: Arc<AtomicBool>,
    pub(super) input: Option<Receiver<String>>,
    pub(super) mode: Mode,
    pub(super) max_on_time: Duration,
    /// Relays on, with their coil, since when (the moment their frame went out) and since
    /// which step. Changed only through `switched_on`/`switched_off`/`all_off`, which keep
    /// the watch's deadline.
    on_since: BTreeMap<Slot, (CoilId, Duration, usize)>,
    /// The on-time each relay had when its board's all-off went out (the first all-off).
    off_at: BTreeMap<Slot, Duration>,
    pub(super) next_step: usize,
    pub(super) steps_done: usize,
}

/// How often waits look at the stop flag and the on-time limit.
pub(super) const POLL: Duration = Duration::from_millis(10);

/// Blank for `-` (the listing's "nothing"), for the log's columns.
fn blank(s: &str) -> &str {
    if s == "-" {
        ""
    } else {
        s
    }
}

impl Runner<'_> {
    pub(super) fn now(&self) -> Duration {
        if self.dry_run {
            self.virtual_t
        } else {
            self.start.elapsed()
        }
    }

    pub(super) fn say(&mut self, line: &str) -> Result<(), RelayError> {
        writeln!(self.out, "{line}").map_err(stdout_error)
    }

    /// `e` on board `board`: with several boards, wrapped to name the board and its port.
    fn on(&self, board: usize, e: RelayError) -> RelayError {
        if self.listed {
            on_board(board, &self.boards[board].port, e)
        } else {
            e
        }
    }

    /// Prints and logs the frames board `board` sent since the last call.
    pub(super) fn emit(
        &mut self,
        board: usize,
        step: Option<usize>,
        action: &str,
        coil: Option<CoilId>,
        channel: Option<Channel>,
    ) -> Result<(), RelayError> {
        let t = format!("{:.3}", self.now().as_secs_f64());
        let step = step.map_or("-".to_string(), |s| s.to_string());
        let coil = coil.map_or("-".to_string(), |c| c.to_string());
        let channel = channel.map_or("-".to_string(), |c| c.to_string());
        let bd = board.to_string();
        for frame in self.boards[board].driver.take_sent() {
            let text = if frame
                .iter()
                .all(|b| b.is_ascii_graphic() || *b == b' ' || *b == b'\r')
            {
                format!("  \"{}\"", frame.escape_ascii())
            } else {
                String::new()
            };
            let bytes = hex(&frame);
            let line = if self.listed {
                format!(
                    "{t:>9} {step:>5} {action:<8} {coil:>5} {bd:>5} {channel:>7}  {bytes}{text}"
                )
            } else {
                format!("{t:>9} {step:>5} {action:<8} {coil:>5} {channel:>7}  {bytes}{text}")
            };
            self.say(&line)?;
            if let Some(log) = self.log.as_mut() {
                let (s, c, ch) = (blank(&step), blank(&coil), blank(&channel));
                if log.listed {
                    log.row(&[&t, s, action, c, &bd, ch, &bytes])?;
                } else {
                    log.row(&[&t, s, action, c, ch, &bytes])?;
                }
            }
        }
        Ok(())
    }

    pub(super) fn log_start(&mut self, from: usize) -> Result<(), RelayError> {
        let t = format!("{:.3}", self.now().as_secs_f64());
        if let Some(log) = self.log.as_mut() {
            log.marker(&t, &from.to_string(), "start")?;
            log.flush()?;
        }
        Ok(())
    }

    pub(super) fn flush_log(&mut self) -> Result<(), RelayError> {
        match self.log.as_mut() {
            Some(l) => l.flush(),
            None => Ok(()),
        }
    }

    pub(super) fn check_stop(&self) -> Result<(), RelayError> {
        if self.stop.load(Ordering::SeqCst) {
            return Err(RelayError::Interrupted);
        }
        Ok(())
    }

    /// Records a relay on from `at` (kept if it was on already) and moves the deadline.
    fn switched_on(&mut self, slot: Slot, coil: CoilId, at: Duration, step: usize) {
        self.on_since.entry(slot).or_insert((coil, at, step));
        self.rearm();
    }

    /// Records a relay off and moves the deadline.
    fn switched_off(&mut self, slot: Slot) {
        self.on_since.remove(&slot);
        self.rearm();
    }

    /// The time (on the runner's clock) a relay that went on at `since` reaches its guard.
    fn guard_at(&self, since: Duration) -> Duration {
        since + self.max_on_time - on_time::guard_margin(self.max_on_time)
    }

    /// Gives the watch the earliest guard of the relays on (none in a dry run: its links
    /// never wait).
    fn rearm(&self) {
        let earliest = (self.on_since.values())
            .map(|&(_, since, _)| self.guard_at(since))
            .min();
        self.watch.set_deadline(earliest.filter(|_| !self.dry_run));
    }

    /// The runtime guard: `Err` ([`RelayError::OnTimeReached`], while `phase`) when a coil has
    /// reached its limit less the guard's margin.
    pub(super) fn check_on_time(&self, phase: impl FnOnce() -> String) -> Result<(), RelayError> {
        let now = self.now();
        let hit = (self.on_since.iter())
            .filter(|(_, &(_, since, _))| now >= self.guard_at(since))
            .min_by_key(|(_, &(_, since, _))| since);
        match hit {
            None => Ok(()),
            Some((&slot, &(coil, since, _))) => {
                Err(self.reached(slot, coil, now - since, phase(), false))
            }
        }
    }

    /// The guard's error for `coil` on `slot`, on for `on` while `phase` (a wait for a board
    /// that did not answer: `silent_board`).
    fn reached(
        &self,
        slot: Slot,
        coil: CoilId,
        on: Duration,
        phase: String,
        silent_board: bool,
    ) -> RelayError {
        RelayError::OnTimeReached {
            coil,
            board: self.listed.then_some(slot.board),
            channel: slot.channel,
            phase,
            on,
            off: None,
            max: self.max_on_time,
            silent_board,
        }
    }

    /// `e` from an exchange with board `board`: the board goes last in the all-off; a wait
    /// the watch cut while a coil is on becomes the guard's error naming the board (the coil on
    /// longest reached its guard), anything else names the board with several.
    fn board_failed(&mut self, board: usize, e: RelayError) -> RelayError {
        self.boards[board].failed = true;
        let (
            RelayError::WaitCut {
                op,
                waited,
                timeout,
                ..
            },
            Some((slot, coil, _, on)),
        ) = (&e, self.longest_on())
        else {
            return self.on(board, e);
        };
        let port = &self.boards[board].port;
        let which = match self.listed {
            true => format!("board {board} ({port})"),
            false => format!("the board ({port})"),
        };
        let to = if *op == "writing" { "to" } else { "from" };
        let phase = format!(
            "the replay was {op} {to} {which}, which had not answered after {} ms of its {} ms timeout \
             (the other boards were switched off first)",
            waited.as_millis(),
            timeout.as_millis()
        );
        self.reached(slot, coil, on, phase, true)
    }

    /// Every relay on at `now`: its coil, the step since which it is on, and for how long.
    pub(super) fn on_times(&self, now: Duration) -> OnTimes {
        self.on_since
            .iter()
            .map(|(&slot, &(coil, since, step))| (slot, (coil, step, now.saturating_sub(since))))
            .collect()
    }

    /// The coil on longest now (with its slot, the step since which it is on, and how long).
    pub(super) fn longest_on(&self) -> Option<(Slot, CoilId, usize, Duration)> {
        (self.on_times(self.now()).into_iter())
            .map(|(slot, (coil, step, on))| (slot, coil, step, on))
            .max_by_key(|&(_, _, _, on)| on)
    }

    /// Waits `d` (simulated in a dry run), watching the stop flag and the on-time limit.
    pub(super) fn wait(&mut self, d: Duration, step: usize) -> Result<(), RelayError> {
        if self.dry_run {
            self.virtual_t += d;
            return Ok(());
        }
        // elapsed against `d`, not a deadline: no Instant overflows, however long `d`
        let begun = Instant::now();
        loop {
            self.check_stop()?;
            self.check_on_time(|| format!("the replay dwelt in step {step}"))?;
            let waited = begun.elapsed();
            if waited >= d {
                return Ok(());
            }
            std::thread::sleep(POLL.min(d - waited));
        }
    }

    /// Step mode: waits for Enter (true) or `q` (false), watching the stop flag and the
    /// on-time limit.
    fn wait_enter(&mut self, prompt: &str) -> Result<bool, RelayError> {
        self.say(prompt)?;
        self.out.flush().map_err(stdout_error)?;
        if self.dry_run {
            return Ok(true);
        }
        loop {
            self.check_stop()?;
            self.check_on_time(|| "the replay waited for Enter".to_string())?;
            let Some(rx) = self.input.as_ref() else {
                return Err(RelayError::InputClosed);
            };
            match rx.recv_timeout(POLL) {
                Ok(line) => return Ok(!line.trim().eq_ignore_ascii_case("q")),
                Err(RecvTimeoutError::Timeout) => {}
                Err(RecvTimeoutError::Disconnected) => return Err(RelayError::InputClosed),
            }
        }
    }

    /// Sends an entry's switching in order, each on its board, recording what went out even
    /// when the board then failed to answer. A coil counts as on from the moment its frame
    /// goes out.
    pub(super) fn switch(&mut self, e: &Entry) -> Result<(), RelayError> {
        for sw in &e.switches {
            self.check_stop()?;
            self.check_on_time(|| format!("the replay switched step {}", e.step))?;
            if sw.on {
                let t = self.now();
                self.switched_on(sw.slot(), sw.coil, t, e.step);
            }
            let r = self.boards[sw.board].driver.set(sw.channel, sw.on);
            if !sw.on {
                self.switched_off(sw.slot());
            }
            let action = match (e.hold, sw.on) {
                (true, _) => "hold",
                (false, true) => "on",
                (false, false) => "off",
            };
            self.emit(
                sw.board,
                Some(e.step),
                action,
                Some(sw.coil),
                Some(sw.channel),
            )?;
            r.map_err(|err| self.board_failed(sw.board, err))?;
        }
        Ok(())
    }

    /// Reads the relays back (the boards `--verify` reads) and compares them with what the
    /// entry leaves on each.
    pub(super) fn verify_entry(&mut self, e: &Entry) -> Result<(), RelayError> {
        for i in 0..self.boards.len() {
            if !self.boards[i].verify {
                continue;
            }
            let states = self.boards[i].driver.read_states();
            self.emit(i, Some(e.step), "read", None, None)?;
            let Some(states) = states.map_err(|err| self.board_failed(i, err))? else {
                continue;
            };
            let got: Vec<Channel> = states
                .iter()
                .enumerate()
                .filter(|(_, on)| **on)
                .map(|(k, _)| Channel(k as u16 + 1))
                .collect();
            let expected: Vec<Channel> = e
                .on_after
                .keys()
                .filter(|s| s.board == i)
                .map(|s| s.channel)
                .collect();
            if got != expected {
                let step = e.step;
                return Err(self.on(
                    i,
                    RelayError::Mismatch {
                        step,
                        expected,
                        got,
                    },
                ));
            }
        }
        Ok(())
    }

    /// Switches every board all off, each tried whatever the others did (the boards that
    /// failed before go last: one that does not answer holds up no other), with no wait cut
    /// short, and records what went out (even of an all-off that failed half way) and each
    /// relay's on-time when its board's all-off went out. Returns the boards that failed, and
    /// the first failure to print or log.
    pub(super) fn all_off(&mut self) -> (Vec<(usize, RelayError)>, Result<(), RelayError>) {
        let mut failed = Vec::new();
        let mut shown = Ok(());
        let mut order: Vec<usize> = (0..self.boards.len()).collect();
        order.sort_by_key(|&i| self.boards[i].failed);
        self.watch.set_closing(true);
        for i in order {
            let r = self.boards[i].driver.all_off();
            let now = self.now();
            let s = self.emit(i, None, "all-off", None, None);
            if shown.is_ok() {
                shown = s;
            }
            match r {
                Err(e) => {
                    self.boards[i].failed = true;
                    failed.push((i, e));
                }
                Ok(()) => {
                    let off_at = &mut self.off_at;
                    self.on_since.retain(|slot, &mut (_, since, _)| {
                        if slot.board != i {
                            return true;
                        }
                        off_at.entry(*slot).or_insert(now.saturating_sub(since));
                        false
                    });
                }
            }
        }
        self.on_since.clear();
        self.rearm();
        self.watch.set_closing(false);
        failed.sort_by_key(|&(i, _)| i);
        (failed, shown)
    }

    /// The guard's error `e` (if it is one) with the on-time its coil had when its board's
    /// all-off went out.
    fn with_off_time(&self, mut e: RelayError) -> RelayError {
        if let RelayError::OnTimeReached {
            board,
            channel,
            off: off @ None,
            ..
        } = &mut e
        {
            let slot = Slot {
                board: board.unwrap_or(0),
                channel: *channel,
            };
            *off = self.off_at.get(&slot).copied();
        }
        e
    }

    /// The error of a replay that ended (with `cause`, or finished) with an all-off that
    /// failed on the `failed` boards.
    pub(super) fn off_failed(
        &self,
        cause: Option<RelayError>,
        mut failed: Vec<(usize, RelayError)>,
    ) -> RelayError {
        if !self.listed && failed.len() == 1 {
            let off = Box::new(failed.remove(0).1);
            return match cause {
                None => RelayError::EndOffFailed(off),
                Some(c) => RelayError::OffFailed {
                    cause: Box::new(c),
                    off,
                },
            };
        }
        let switched_off = (0..self.boards.len())
            .filter(|i| failed.iter().all(|(j, _)| j != i))
            .map(|i| format!("board {i} ({})", self.boards[i].port))
            .collect();
        RelayError::BoardsOffFailed {
            cause: cause.map(Box::new),
            failed: failed.into_iter().map(|(i, e)| self.on(i, e)).collect(),
            switched_off,
        }
    }

    /// Ends a replay whatever happened: every channel of every board off (tried even after an
    /// error), the all-off recorded, and the outcome of the replay and of the all-off reported
    /// together.
    fn finish(&mut self, result: Result<bool, RelayError>) -> Result<Summary, RelayError> {
        let next = self.next_step;
        let closed = self.close(result).map_err(|e| match e {
            RelayError::OffFailed { .. } | RelayError::BoardsOffFailed { cause: Some(_), .. } => {
                RelayError::OffFailedResume {
                    error: Box::new(e),
                    resume: next,
                }
            }
            e => e,
        })?;
        match closed {
            Ok(quit) => {
                let msg = if quit {
                    format!(
                        "quit before step {next}; all coils off; resume with --from-step {next}"
                    )
                } else {
                    format!("done: {} step(s) replayed; all coils off", self.steps_done)
                };
                writeln!(self.out, "{msg}").map_err(stdout_error)?;
                Ok(Summary {
                    steps_done: self.steps_done,
                    next_step: next,
                    quit,
                })
            }
            Err(e) => Err(RelayError::Stopped {
                cause: Box::new(e),
                resume: next,
            }),
        }
    }

    /// Says and waits an entry's dwell.
    pub(super) fn dwell(&mut self, e: &Entry) -> Result<(), RelayError> {
        let t = format!("{:.3}", self.now().as_secs_f64());
        let ms = e.dwell.as_millis();
        let why = match e.unsettled {
            true => " (the step never settled in the plan: its settle time is t_max, not a settle)",
            false => "",
        };
        self.say(&format!("{t:>9} {:>5} dwell {ms} ms{why}", e.step))?;
        self.wait(e.dwell, e.step)
    }

    /// Logs a marker row (`done`, ...) for `step` now, and flushes the log.
    pub(super) fn mark(&mut self, step: usize, action: &str) -> Result<(), RelayError> {
        let t = format!("{:.3}", self.now().as_secs_f64());
        if let Some(log) = self.log.as_mut() {
            log.marker(&t, &step.to_string(), action)?;
            log.flush()?;
        }
        Ok(())
    }

    /// Switches every board all off (tried whatever happened) and records it, then: `Err`
    /// when that failed on a board (the error says so, with `result`'s error as its cause) or
    /// could not be printed or logged after a `result` that succeeded; else `Ok(result)`.
    pub(super) fn close<T>(
        &mut self,
        result: Result<T, RelayError>,
    ) -> Result<Result<T, RelayError>, RelayError> {
        let (failed, shown) = self.all_off();
        let result = result.map_err(|e| self.with_off_time(e));
        let flushed = self.flush_log();
        if !failed.is_empty() {
            return Err(self.off_failed(result.err(), failed));
        }
        if result.is_ok() {
            shown?;
            flushed?;
        }
        Ok(result)
    }

    /// The all-off before the first step (the boards' state is unknown), stopping at a board
    /// that fails.
    pub(super) fn start_off(&mut self) -> Result<(), RelayError> {
        self.check_stop()?;
        let (mut failed, shown) = self.all_off();
        shown?;
        if !failed.is_empty() {
            let (i, e) = failed.remove(0);
            return Err(self.on(i, e));
        }
        Ok(())
    }

    /// The replay proper; returns whether the user quit. The caller switches all off after.
    fn drive(&mut self, s: &Schedule) -> Result<bool, RelayError> {
        self.start_off()?;
        for e in &s.entries {
            self.next_step = if e.hold { e.step + 1 } else { e.step };
            if self.mode == Mode::Step {
                let what = if e.hold {
                    "re-energise step"
                } else {
                    "switch step"
                };
                let prompt = format!("-- Enter: {what} {}; q: quit", e.step);
                if !self.wait_enter(&prompt)? {
                    return Ok(true);
                }
            }
            self.switch(e)?;
            self.verify_entry(e)?;
            if self.mode == Mode::Realtime {
                self.dwell(e)?;
            }
            self.mark(e.step, "done")?;
            if !e.hold {
                self.steps_done += 1;
            }
            self.next_step = e.step + 1;
        }
        if self.mode == Mode::Step {
            // Enter or q: either way everything goes off now.
            self.wait_enter("-- Enter: switch all off")?;
        }
        Ok(false)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::geometry::Pair;
    use nalgebra::UnitQuaternion;

    fn row(step: usize, active: &[(usize, usize)], settle: f64) -> PlanRow {
        PlanRow {
            step,
            pivot: None,
            new: Vec::new(),
            active: active.iter().map(|&(c, m)| Pair::new(c, m)).collect(),
            q: UnitQuaternion::identity(),
            step_angle_deg: 0.0,
            step_axis_error_deg: 0.0,
            cum_angle_deg: 0.0,
            cum_axis_error_deg: 0.0,
            settle_time_s: settle,
            settled: true,
        }
    }

    #[test]
    fn dwell_is_settle_times_factor_at_least_the_floor() {
        let s = RelaySettings::default();
        assert_eq!(
            dwell(&row(0, &[], 0.1), &s, None),
            Duration::from_millis(200)
        );
        assert_eq!(
            dwell(&row(0, &[], 1.0), &s, None),
            Duration::from_millis(1500)
        );
        let fixed = Some(Duration::from_millis(7));
        assert_eq!(
            dwell(&row(0, &[], 1.0), &s, fixed),
            Duration::from_millis(7)
        );
    }

    #[test]
    fn resume_re_energises_the_step_before() {
        let rows = [
            row(0, &[(0, 1), (1, 2)], 0.1),
            row(1, &[(0, 1), (2, 3)], 0.1),
            row(2, &[(2, 3), (3, 4)], 0.1),
        ];
        let s = RelaySettings::default();
        let sc = schedule(&rows, &s, BoardKind::Lcus, 8, 16, None, 2, Mode::Realtime).unwrap();
        assert_eq!(sc.entries.len(), 2);
        let hold = &sc.entries[0];
        assert!(hold.hold && hold.step == 1);
        let on: Vec<u16> = hold.switches.iter().map(|w| w.channel.0).collect();
        assert_eq!(on, [1, 3]);
        let step = &sc.entries[1];
        assert_eq!(
            step.switches,
            [
                Switch {
                    coil: CoilId(3),
                    board: 0,
                    channel: Channel(4),
                    on: true
                },
                Switch {
                    coil: CoilId(0),
                    board: 0,
                    channel: Channel(1),
                    on: false
                },
            ]
        );
        assert_eq!(step.peak, 3);
        let e = schedule(&rows, &s, BoardKind::Lcus, 8, 16, None, 3, Mode::Realtime).unwrap_err();
        assert!(e.to_string().contains("`from_step`"), "{e}");
    }
}
