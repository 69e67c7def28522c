//! The runner of a replay: it switches the boards step by step, prints and logs every frame,
//! keeps every coil deadline and ends with every board all off.

use super::log::{Log, LogKind};
use super::ports::{configured_port, on_board, Prepared};
use super::schedule::{Entry, Mode, OnTimes, Schedule};
use crate::model::geometry::CoilId;
use crate::planning::on_time;
use crate::relay::watch::Watch;
use crate::relay::{
    connect, hex, BoardKind, BoardSpec, Channel, Link, RelayBoard, RelayError, Setting, Slot,
    SwitchOrder,
};
use std::collections::BTreeMap;
use std::io::Write;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::mpsc::{Receiver, RecvTimeoutError};
use std::sync::Arc;
use std::time::{Duration, Instant};

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
    pub(crate) fn start(
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
            Some(p) => Some(Log::open(p, listed, kind, prep.wording)?),
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
            wording: prep.wording,
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
pub(crate) fn stdout_error(cause: std::io::Error) -> RelayError {
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

/// One board of the replay: its driver, its port (as messages name it) and whether `--verify`
/// reads it back.
struct Driven {
    driver: Box<dyn RelayBoard>,
    port: String,
    verify: bool,
    /// An exchange with it failed (or was cut): its all-off goes last.
    failed: bool,
}

/// A replay in progress: the boards' drivers, the output, the log, the clock and what is on.
pub(crate) struct Runner<'a> {
    /// The boards, in order (every switch's board is one of them: checked by `execute_on`).
    boards: Vec<Driven>,
    /// `[[relay.boards]]`: the board column is printed and errors name their board.
    listed: bool,
    out: &'a mut dyn Write,
    log: Option<Log>,
    start: Instant,
    /// The stop flag and the earliest coil deadline, watched by every link's waits.
    watch: Arc<Watch>,
    virtual_t: Duration,
    dry_run: bool,
    stop: Arc<AtomicBool>,
    input: Option<Receiver<String>>,
    mode: Mode,
    max_on_time: Duration,
    /// Relays on, with their coil, since when (the moment their frame went out) and since
    /// which step. Changed only through `switched_on`/`switched_off`/`all_off`, which keep
    /// the watch's deadline.
    on_since: BTreeMap<Slot, (CoilId, Duration, usize)>,
    /// The on-time each relay had when its board's all-off went out (the first all-off).
    off_at: BTreeMap<Slot, Duration>,
    next_step: usize,
    steps_done: usize,
    /// How its own lines name the replay's settings ([`Prepared::wording`]).
    wording: &'static dyn crate::relay::Wording,
}

/// How often waits look at the stop flag and the on-time limit.
pub(crate) const POLL: Duration = Duration::from_millis(10);

/// Blank for `-` (the listing's "nothing"), for the log's columns.
fn blank(s: &str) -> &str {
    if s == "-" {
        ""
    } else {
        s
    }
}

impl Runner<'_> {
    pub(crate) fn now(&self) -> Duration {
        if self.dry_run {
            self.virtual_t
        } else {
            self.start.elapsed()
        }
    }

    pub(crate) fn say(&mut self, line: &str) -> Result<(), RelayError> {
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
    fn emit(
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

    pub(crate) fn log_start(&mut self, from: usize) -> Result<(), RelayError> {
        let t = format!("{:.3}", self.now().as_secs_f64());
        if let Some(log) = self.log.as_mut() {
            log.marker(&t, &from.to_string(), "start")?;
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

    pub(crate) fn check_stop(&self) -> Result<(), RelayError> {
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
    pub(crate) fn check_on_time(&self, phase: impl FnOnce() -> String) -> Result<(), RelayError> {
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
    pub(crate) fn on_times(&self, now: Duration) -> OnTimes {
        self.on_since
            .iter()
            .map(|(&slot, &(coil, since, step))| (slot, (coil, step, now.saturating_sub(since))))
            .collect()
    }

    /// The coil on longest now (with its slot, the step since which it is on, and how long).
    fn longest_on(&self) -> Option<(Slot, CoilId, usize, Duration)> {
        (self.on_times(self.now()).into_iter())
            .map(|(slot, (coil, step, on))| (slot, coil, step, on))
            .max_by_key(|&(_, _, _, on)| on)
    }

    /// Waits `d` (simulated in a dry run), watching the stop flag and the on-time limit.
    fn wait(&mut self, d: Duration, step: usize) -> Result<(), RelayError> {
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
    fn switch(&mut self, e: &Entry) -> Result<(), RelayError> {
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
    fn verify_entry(&mut self, e: &Entry) -> Result<(), RelayError> {
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
    pub(crate) fn all_off(&mut self) -> (Vec<(usize, RelayError)>, Result<(), RelayError>) {
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
    pub(crate) fn with_off_time(&self, mut e: RelayError) -> RelayError {
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

    /// The error of a replay whose all-off failed on the `failed` boards (`EndOffFailed`, or
    /// `BoardsOffFailed` without a cause: [`RelayError::after`] adds the replay's error).
    fn off_failed(&self, mut failed: Vec<(usize, RelayError)>) -> RelayError {
        if !self.listed && failed.len() == 1 {
            return RelayError::EndOffFailed(Box::new(failed.remove(0).1));
        }
        let switched_off = (0..self.boards.len())
            .filter(|i| failed.iter().all(|(j, _)| j != i))
            .map(|i| format!("board {i} ({})", self.boards[i].port))
            .collect();
        RelayError::BoardsOffFailed {
            cause: None,
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
                        "quit before step {next}; all coils off; resume with {} {next}",
                        self.wording.name(Setting::FromStep)
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
    fn dwell(&mut self, e: &Entry) -> Result<(), RelayError> {
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
    pub(crate) fn mark(&mut self, step: usize, action: &str) -> Result<(), RelayError> {
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
    pub(crate) fn close<T>(
        &mut self,
        result: Result<T, RelayError>,
    ) -> Result<Result<T, RelayError>, RelayError> {
        let (off, written) = self.close_off();
        let result = result.map_err(|e| self.with_off_time(e));
        if let Some(off) = off {
            return Err(off.after(result.err()));
        }
        if result.is_ok() {
            written?;
        }
        Ok(result)
    }

    /// Switches every board all off (tried whatever happened), records it and flushes the
    /// log: the all-off's failure, if any (`EndOffFailed` or `BoardsOffFailed` without a
    /// cause: see [`RelayError::after`]), and whether the all-off was printed and logged.
    pub(crate) fn close_off(&mut self) -> (Option<RelayError>, Result<(), RelayError>) {
        let (failed, shown) = self.all_off();
        let flushed = self.flush_log();
        let off = (!failed.is_empty()).then(|| self.off_failed(failed));
        (off, shown.and(flushed))
    }

    /// The all-off before the first step (the boards' state is unknown), stopping at a board
    /// that fails.
    pub(crate) fn start_off(&mut self) -> Result<(), RelayError> {
        self.check_stop()?;
        let (mut failed, shown) = self.all_off();
        shown?;
        if !failed.is_empty() {
            let (i, e) = failed.remove(0);
            return Err(self.on(i, e));
        }
        Ok(())
    }

    /// Plays one entry: switches it, reads the relays back (`verify`), dwells (realtime), runs
    /// `then` (where the rig's closed loop reads the sensor and decides, under its watch) and
    /// marks the step done. The one step sequence of the open-loop replay and of the closed
    /// loop.
    pub(crate) fn play<T, E: From<RelayError>>(
        &mut self,
        e: &Entry,
        then: impl FnOnce(&mut Self) -> Result<T, E>,
    ) -> Result<T, E> {
        self.next_step = if e.hold { e.step + 1 } else { e.step };
        self.switch(e)?;
        self.verify_entry(e)?;
        if self.mode == Mode::Realtime {
            self.dwell(e)?;
        }
        let done = then(self)?;
        self.mark(e.step, "done")?;
        if !e.hold {
            self.steps_done += 1;
        }
        self.next_step = e.step + 1;
        Ok(done)
    }

    /// Logs a closed loop's measurement (or tare) row at `t` for `step` and flushes the log
    /// (see `Log::measurement`); nothing without a log.
    pub(crate) fn log_measurement(
        &mut self,
        t: &str,
        step: usize,
        action: &str,
        q: [f64; 4],
        goal_deg: Option<f64>,
        raw: &str,
    ) -> Result<(), RelayError> {
        let Some(log) = self.log.as_mut() else {
            return Ok(());
        };
        log.measurement(t, &step.to_string(), action, q, goal_deg, raw)?;
        log.flush()
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
            self.play(e, |_| Ok::<(), RelayError>(()))?;
        }
        if self.mode == Mode::Step {
            // Enter or q: either way everything goes off now.
            self.wait_enter("-- Enter: switch all off")?;
        }
        Ok(false)
    }
}
