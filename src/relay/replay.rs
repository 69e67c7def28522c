//! Hardware replay of a plan (`spherestep replay`): turns each step's active set into relay
//! switching on a board, in order (new coils on before released ones off, by default), waits
//! the dwell (realtime) or for Enter (step mode), and always ends with every channel off: at
//! the end, on an error, on Ctrl-C/SIGTERM (a flag the caller sets), and when the port fails
//! (tried, and reported). The limits (coils on at once, one coil's continuous on-time) are
//! checked on the whole schedule before any byte is sent. `--dry-run` runs the same code on a
//! link that only records, with a simulated clock. `--log` writes what was sent when.

use super::{
    connect, hex, BoardKind, Channel, Link, RelayBoard, RelayError, RelaySettings, SwitchOrder,
};
use crate::model::geometry::CoilId;
use crate::planning::plan::PlanRow;
use std::collections::{BTreeMap, BTreeSet};
use std::io::Write;
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

/// One relay switched.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Switch {
    pub coil: CoilId,
    pub channel: Channel,
    pub on: bool,
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
    /// What is on after the entry, by channel.
    pub on_after: BTreeMap<Channel, CoilId>,
    /// The most coils on at any moment of the entry.
    pub peak: usize,
    /// Time to wait after switching (realtime).
    pub dwell: Duration,
}

/// The whole replay, worked out and checked before anything is sent.
#[derive(Debug, Clone, PartialEq)]
pub struct Schedule {
    pub board: BoardKind,
    pub channels: u16,
    pub entries: Vec<Entry>,
}

/// The dwell of a plan row: the override, or settle time x factor, at least the floor.
pub fn dwell(
    row: &PlanRow,
    settings: &RelaySettings,
    dwell_override: Option<Duration>,
) -> Duration {
    match dwell_override {
        Some(d) => d,
        None => {
            let t = row.settle_time_s * settings.dwell_factor;
            let d = if t.is_finite() && t > 0.0 {
                Duration::from_secs_f64(t.min(1e6))
            } else {
                Duration::ZERO
            };
            d.max(settings.dwell_floor)
        }
    }
}

/// Works out the schedule of a plan and checks it: every coil on the stator and driven by a
/// channel of the board, never more than `max_coils_on` coils on, and (realtime) no coil on
/// longer than `max_on_time` in a row.
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
    if from_step >= rows.len() {
        return Err(RelayError::Arg {
            arg: "--from-step".into(),
            expected: format!(
                "a step of the plan, 0..={}, got {from_step}",
                rows.len().saturating_sub(1)
            ),
        });
    }
    let first = from_step.saturating_sub(1);
    let mut entries = Vec::new();
    let mut prev: BTreeMap<Channel, CoilId> = BTreeMap::new();
    for (k, row) in rows.iter().enumerate().skip(first) {
        let mut target = BTreeMap::new();
        for p in &row.active {
            let ch = channel_of(p.coil, row.step, settings, board, channels, stator_coils)?;
            target.insert(ch, p.coil);
        }
        let (switches, peak) = transition(&prev, &target, settings.order);
        if peak > settings.max_coils_on {
            return Err(too_many_on(row.step, peak, &prev, &target, settings));
        }
        entries.push(Entry {
            step: row.step,
            hold: k < from_step,
            switches,
            on_after: target.clone(),
            peak,
            dwell: dwell(row, settings, dwell_override),
        });
        prev = target;
    }
    if mode == Mode::Realtime {
        check_on_time(&entries, settings.max_on_time)?;
    }
    Ok(Schedule {
        board,
        channels,
        entries,
    })
}

/// The switching from what is on (`prev`, by channel) to `target`, in the order it is sent,
/// and the most coils on at any moment of it.
fn transition(
    prev: &BTreeMap<Channel, CoilId>,
    target: &BTreeMap<Channel, CoilId>,
    order: SwitchOrder,
) -> (Vec<Switch>, usize) {
    let switches = |from: &BTreeMap<Channel, CoilId>, to: &BTreeMap<Channel, CoilId>, on| {
        from.iter()
            .filter(|(ch, _)| !to.contains_key(ch))
            .map(|(&channel, &coil)| Switch { coil, channel, on })
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
    prev: &BTreeMap<Channel, CoilId>,
    target: &BTreeMap<Channel, CoilId>,
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

fn channel_of(
    coil: CoilId,
    step: usize,
    settings: &RelaySettings,
    board: BoardKind,
    channels: u16,
    stator_coils: usize,
) -> Result<Channel, RelayError> {
    let unmapped = |reason: String| RelayError::Unmapped { step, coil, reason };
    if coil.0 >= stator_coils {
        return Err(unmapped(format!(
            "is not on the stator (the scenario has {stator_coils} coils)"
        )));
    }
    let ch = settings.map.channel(coil).ok_or_else(|| {
        unmapped("no relay channel drives (add it to [relay.map] or the --map file)".into())
    })?;
    if ch.0 > channels {
        let hint = if board == BoardKind::Lcus {
            format!(
                " (LCUS boards have at most {} channels: drive 16 coils from a 16-channel numato or modbus board, or map the coils this plan uses onto channels 1..={channels})",
                super::lcus::MAX_CHANNELS
            )
        } else {
            " (set relay.channels, or map the coil to a lower channel)".into()
        };
        return Err(unmapped(format!(
            "is mapped to channel {ch}, but the {board} board has {channels} channels{hint}"
        )));
    }
    Ok(ch)
}

/// Simulates the schedule: a coil's continuous on-time is the sum of the dwells while it stays
/// on.
fn check_on_time(entries: &[Entry], max: Duration) -> Result<(), RelayError> {
    let mut on: BTreeMap<Channel, (CoilId, usize, Duration)> = BTreeMap::new();
    for e in entries {
        on.retain(|ch, _| e.on_after.contains_key(ch));
        for (&ch, &coil) in &e.on_after {
            let slot = on.entry(ch).or_insert((coil, e.step, Duration::ZERO));
            slot.2 += e.dwell;
            if slot.2 > max {
                return Err(RelayError::OnTooLong {
                    coil,
                    channel: ch,
                    when: format!(
                        "would stay on from step {} through step {} for",
                        slot.1, e.step
                    ),
                    on: slot.2,
                    max,
                    advice: "; the dwells are the plan's settle times x relay.dwell_factor: \
                             give a shorter --dwell-ms, or raise relay.max_on_time_s if the \
                             coils can take the heat",
                });
            }
        }
    }
    Ok(())
}

/// Everything resolved from the options before a port is opened.
#[derive(Debug, Clone)]
pub struct Prepared {
    pub settings: RelaySettings,
    pub board: BoardKind,
    pub channels: u16,
    pub baud: u32,
    pub schedule: Schedule,
    pub drive: Drive,
}

/// How to replay: the choices of the command line that the relay layer needs.
#[derive(Debug, Clone)]
pub struct Drive {
    /// Overrides `relay.board`.
    pub board: Option<BoardKind>,
    /// Overrides `relay.baud`.
    pub baud: Option<u32>,
    pub mode: Mode,
    /// A fixed dwell for every step instead of settle time x factor (at least the floor).
    pub dwell_ms: Option<u64>,
    /// First step to replay; the step before is re-energised first to hold the ball.
    pub from_step: usize,
    /// CSV log of what was sent when (appended to when it exists).
    pub log: Option<PathBuf>,
    /// Read the relays back after each step and stop on a mismatch.
    pub verify: bool,
}

/// Resolves the board, channels and baud rate of `settings` under the overrides of `drive`
/// and works out the checked schedule of `rows` on a stator of `stator_coils` coils.
pub fn prepare(
    rows: &[PlanRow],
    settings: RelaySettings,
    stator_coils: usize,
    drive: Drive,
) -> Result<Prepared, RelayError> {
    let board = drive
        .board
        .or(settings.board)
        .ok_or_else(|| RelayError::Arg {
            arg: "--board".into(),
            expected: "lcus, kmtronic, numato or modbus (or `board` in the [relay] section)".into(),
        })?;
    let channels = settings.channels.unwrap_or(board.default_channels());
    // The same check `connect` makes, before anything else.
    connect(board, channels, settings.slave_address, Link::dry_run())?;
    if let Some(b) = drive.baud.filter(|b| !(1..=4_000_000).contains(b)) {
        return Err(RelayError::Arg {
            arg: "--baud".into(),
            expected: format!("a baud rate from 1 to 4000000, got {b}"),
        });
    }
    let baud = drive.baud.or(settings.baud).unwrap_or(board.default_baud());
    let schedule = schedule(
        rows,
        &settings,
        board,
        channels,
        stator_coils,
        drive.dwell_ms.map(Duration::from_millis),
        drive.from_step,
        drive.mode,
    )?;
    Ok(Prepared {
        settings,
        board,
        channels,
        baud,
        schedule,
        drive,
    })
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

/// Replays a prepared schedule over `link` (a port opened by the caller, or a dry run).
pub fn execute(
    prep: &Prepared,
    link: Link,
    stop: Arc<AtomicBool>,
    input: Option<Receiver<String>>,
    out: &mut dyn Write,
) -> Result<Summary, RelayError> {
    let dry_run = link.is_dry_run();
    let port = link.name().to_string();
    let mut board = connect(prep.board, prep.channels, prep.settings.slave_address, link)?;
    if prep.drive.verify {
        board.read_back()?;
    }
    let log = match &prep.drive.log {
        Some(p) => Some(Log::open(p)?),
        None => None,
    };
    let s = &prep.schedule;
    print_header(out, prep, &port, dry_run).map_err(stdout_error)?;
    let mut r = Runner {
        board: board.as_mut(),
        out,
        log,
        start: Instant::now(),
        virtual_t: Duration::ZERO,
        dry_run,
        stop,
        input,
        mode: prep.drive.mode,
        verify: prep.drive.verify,
        max_on_time: prep.settings.max_on_time,
        on_since: BTreeMap::new(),
        next_step: prep.drive.from_step,
        steps_done: 0,
    };
    r.log_start(prep.drive.from_step)?;
    let result = r.drive(s);
    r.finish(result)
}

/// A failed write of the replay's report.
fn stdout_error(source: std::io::Error) -> RelayError {
    RelayError::Log {
        path: "<stdout>".into(),
        source,
    }
}

/// The replay's first lines: where it goes, the board and its settings, then the column heads.
fn print_header(
    out: &mut dyn Write,
    prep: &Prepared,
    port: &str,
    dry_run: bool,
) -> std::io::Result<()> {
    let s = &prep.schedule;
    writeln!(
        out,
        "{}: {} board, {} channels, {} baud{}, {}, {}, steps {}..={}",
        if dry_run {
            "dry run (no port opened)".to_string()
        } else {
            format!("replaying on {port}")
        },
        prep.board,
        prep.channels,
        prep.baud,
        if prep.board == BoardKind::Modbus {
            format!(", slave {}", prep.settings.slave_address)
        } else {
            String::new()
        },
        match prep.settings.order {
            SwitchOrder::MakeBeforeBreak => "make-before-break",
            SwitchOrder::BreakBeforeMake => "break-before-make",
        },
        match prep.drive.mode {
            Mode::Realtime => "realtime",
            Mode::Step => "step mode",
        },
        prep.drive.from_step,
        s.entries.last().map_or(0, |e| e.step),
    )?;
    writeln!(
        out,
        "{:>9} {:>5} {:<8} {:>5} {:>7}  bytes",
        "t_s", "step", "action", "coil", "channel"
    )?;
    Ok(())
}

/// Spawns a thread that forwards standard input line by line (for step mode).
pub fn stdin_lines() -> Receiver<String> {
    let (tx, rx) = std::sync::mpsc::channel();
    std::thread::spawn(move || {
        for line in std::io::stdin().lines() {
            match line {
                Ok(l) => {
                    if tx.send(l).is_err() {
                        break;
                    }
                }
                Err(_) => break,
            }
        }
    });
    rx
}

/// The replay log: `t_s,step,action,coil,channel,bytes`, one row per frame, a `done` row when
/// a step's dwell completed and a `start` row per run; flushed after every step.
struct Log {
    path: PathBuf,
    file: std::io::BufWriter<std::fs::File>,
}

/// The log's header.
pub const LOG_HEADER: &str = "t_s,step,action,coil,channel,bytes";

impl Log {
    fn open(path: &Path) -> Result<Log, RelayError> {
        let err = |e| RelayError::Log {
            path: path.to_path_buf(),
            source: e,
        };
        let existing = std::fs::metadata(path)
            .map(|m| m.len() > 0)
            .unwrap_or(false);
        let file = std::fs::OpenOptions::new()
            .create(true)
            .append(true)
            .open(path)
            .map_err(err)?;
        let mut log = Log {
            path: path.to_path_buf(),
            file: std::io::BufWriter::new(file),
        };
        if !existing {
            writeln!(log.file, "{LOG_HEADER}").map_err(err)?;
        }
        Ok(log)
    }

    fn row(&mut self, cols: [&str; 6]) -> Result<(), RelayError> {
        writeln!(self.file, "{}", cols.join(",")).map_err(|e| RelayError::Log {
            path: self.path.clone(),
            source: e,
        })
    }

    fn flush(&mut self) -> Result<(), RelayError> {
        self.file.flush().map_err(|e| RelayError::Log {
            path: self.path.clone(),
            source: e,
        })
    }
}

struct Runner<'a> {
    board: &'a mut dyn RelayBoard,
    out: &'a mut dyn Write,
    log: Option<Log>,
    start: Instant,
    virtual_t: Duration,
    dry_run: bool,
    stop: Arc<AtomicBool>,
    input: Option<Receiver<String>>,
    mode: Mode,
    verify: bool,
    max_on_time: Duration,
    /// Channels on, with their coil, since when and since which step.
    on_since: BTreeMap<Channel, (CoilId, Duration, usize)>,
    next_step: usize,
    steps_done: usize,
}

/// How often waits look at the stop flag and the on-time limit.
const POLL: Duration = Duration::from_millis(10);

impl Runner<'_> {
    fn now(&self) -> Duration {
        if self.dry_run {
            self.virtual_t
        } else {
            self.start.elapsed()
        }
    }

    fn say(&mut self, line: &str) -> Result<(), RelayError> {
        writeln!(self.out, "{line}").map_err(stdout_error)
    }

    /// Prints and logs the frames the board sent since the last call.
    fn emit(
        &mut self,
        step: Option<usize>,
        action: &str,
        coil: Option<CoilId>,
        channel: Option<Channel>,
    ) -> Result<(), RelayError> {
        let t = format!("{:.3}", self.now().as_secs_f64());
        let step = step.map_or("-".to_string(), |s| s.to_string());
        let coil = coil.map_or("-".to_string(), |c| c.to_string());
        let channel = channel.map_or("-".to_string(), |c| c.to_string());
        for frame in self.board.take_sent() {
            let text = if frame
                .iter()
                .all(|b| b.is_ascii_graphic() || *b == b' ' || *b == b'\r')
            {
                format!("  \"{}\"", frame.escape_ascii())
            } else {
                String::new()
            };
            let bytes = hex(&frame);
            self.say(&format!(
                "{t:>9} {step:>5} {action:<8} {coil:>5} {channel:>7}  {bytes}{text}"
            ))?;
            if let Some(log) = self.log.as_mut() {
                let blank = |s: &str| {
                    if s == "-" {
                        String::new()
                    } else {
                        s.to_string()
                    }
                };
                log.row([
                    &t,
                    &blank(&step),
                    action,
                    &blank(&coil),
                    &blank(&channel),
                    &bytes,
                ])?;
            }
        }
        Ok(())
    }

    fn log_start(&mut self, from: usize) -> Result<(), RelayError> {
        let t = format!("{:.3}", self.now().as_secs_f64());
        if let Some(log) = self.log.as_mut() {
            log.row([&t, &from.to_string(), "start", "", "", ""])?;
            log.flush()?;
        }
        Ok(())
    }

    fn flush_log(&mut self) -> Result<(), RelayError> {
        match self.log.as_mut() {
            Some(l) => l.flush(),
            None => Ok(()),
        }
    }

    fn check_stop(&self) -> Result<(), RelayError> {
        if self.stop.load(Ordering::SeqCst) {
            return Err(RelayError::Interrupted);
        }
        Ok(())
    }

    /// Fails when a coil has been on longer than allowed (the runtime guard).
    fn check_on_time(&self) -> Result<(), RelayError> {
        let now = self.now();
        for (&channel, &(coil, since, step)) in &self.on_since {
            let on = now.saturating_sub(since);
            if on > self.max_on_time {
                return Err(RelayError::OnTooLong {
                    coil,
                    channel,
                    when: format!("has been on since step {step} for"),
                    on,
                    max: self.max_on_time,
                    advice: "",
                });
            }
        }
        Ok(())
    }

    /// Waits `d` (simulated in a dry run), watching the stop flag and the on-time limit.
    fn wait(&mut self, d: Duration) -> Result<(), RelayError> {
        if self.dry_run {
            self.virtual_t += d;
            return Ok(());
        }
        let end = Instant::now() + d;
        loop {
            self.check_stop()?;
            self.check_on_time()?;
            let now = Instant::now();
            if now >= end {
                return Ok(());
            }
            std::thread::sleep(POLL.min(end - now));
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
            self.check_on_time()?;
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

    /// The replay proper; returns whether the user quit. The caller switches all off after.
    /// Sends an entry's switching in order, recording what went out even when the board then
    /// failed to answer.
    fn switch(&mut self, e: &Entry) -> Result<(), RelayError> {
        for sw in &e.switches {
            self.check_stop()?;
            let r = self.board.set(sw.channel, sw.on);
            if sw.on {
                let t = self.now();
                self.on_since.insert(sw.channel, (sw.coil, t, e.step));
            } else {
                self.on_since.remove(&sw.channel);
            }
            let action = match (e.hold, sw.on) {
                (true, _) => "hold",
                (false, true) => "on",
                (false, false) => "off",
            };
            self.emit(Some(e.step), action, Some(sw.coil), Some(sw.channel))?;
            r?;
        }
        Ok(())
    }

    /// Reads the relays back (boards that can) and compares them with what the entry leaves on.
    fn verify_entry(&mut self, e: &Entry) -> Result<(), RelayError> {
        let states = self.board.read_states();
        self.emit(Some(e.step), "read", None, None)?;
        let Some(states) = states? else {
            return Ok(());
        };
        let got: Vec<Channel> = states
            .iter()
            .enumerate()
            .filter(|(_, on)| **on)
            .map(|(i, _)| Channel(i as u16 + 1))
            .collect();
        let expected: Vec<Channel> = e.on_after.keys().copied().collect();
        if got != expected {
            return Err(RelayError::Mismatch {
                step: e.step,
                expected,
                got,
            });
        }
        Ok(())
    }

    /// Ends a replay whatever happened: every channel off (tried even after an error), the
    /// all-off recorded, and the outcome of the replay and of the all-off reported together.
    fn finish(&mut self, result: Result<bool, RelayError>) -> Result<Summary, RelayError> {
        let off = self.board.all_off();
        self.on_since.clear();
        // Record whatever went out of the all-off, even when it failed half way.
        let shown = self.emit(None, "all-off", None, None);
        let flushed = self.flush_log();
        let next = self.next_step;
        match (result, off) {
            (Ok(quit), Ok(())) => {
                shown?;
                flushed?;
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
            (Ok(_), Err(off)) => Err(RelayError::EndOffFailed(Box::new(off))),
            (Err(e), Ok(())) => Err(RelayError::Stopped {
                cause: Box::new(e),
                resume: next,
            }),
            (Err(e), Err(off)) => Err(RelayError::OffFailed {
                cause: Box::new(e),
                off: Box::new(off),
            }),
        }
    }

    fn drive(&mut self, s: &Schedule) -> Result<bool, RelayError> {
        self.check_stop()?;
        let r = self.board.all_off();
        self.emit(None, "all-off", None, None)?;
        r?;
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
            if self.verify {
                self.verify_entry(e)?;
            }
            if self.mode == Mode::Realtime {
                let t = format!("{:.3}", self.now().as_secs_f64());
                self.say(&format!(
                    "{t:>9} {:>5} dwell {} ms",
                    e.step,
                    e.dwell.as_millis()
                ))?;
                self.wait(e.dwell)?;
            }
            let t = format!("{:.3}", self.now().as_secs_f64());
            if let Some(log) = self.log.as_mut() {
                log.row([&t, &e.step.to_string(), "done", "", "", ""])?;
                log.flush()?;
            }
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
                    channel: Channel(4),
                    on: true
                },
                Switch {
                    coil: CoilId(0),
                    channel: Channel(1),
                    on: false
                },
            ]
        );
        assert_eq!(step.peak, 3);
        let e = schedule(&rows, &s, BoardKind::Lcus, 8, 16, None, 3, Mode::Realtime).unwrap_err();
        assert!(e.to_string().contains("--from-step"), "{e}");
    }
}
