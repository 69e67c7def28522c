//! Relay boards that switch the stator coils. The entry points are [`replay::prepare`] (a
//! plan's checked [`Schedule`](replay::Schedule) on the boards of a [`RelaySettings`]),
//! [`replay::open_ports`] and [`replay::execute_on`] (the replay played on the boards' links,
//! every coil off at the end), and the [`RelayBoard`] trait with its four drivers
//! ([`lcus`], [`kmtronic`], [`numato`], [`modbus`]); the errors are [`RelayError`].
//!
//! One driver per board type behind one trait (`RelayBoard`, in the spirit of the crelay project),
//! the serial link they talk over, the coil-to-channel map and replay settings (`[relay]` in a
//! scenario, or a `--map` file; one board, or several as `[[relay.boards]]`), and the hardware
//! replay of a plan (`replay`), which drives one driver per board, open loop (the closed loop
//! through an orientation sensor is the rig's, `crate::rig`, above this layer). Channels are
//! numbered from 1, as printed on the boards; each driver converts to its own wire numbering.
//! Boards are numbered from 0, in list order. Private files: the link (`link.rs`, re-exported as
//! [`Link`]), a `[[relay.boards]]` entry (`boards.rs`, [`BoardConfig`]) and the runner's watch of
//! every coil deadline (`watch.rs`).

mod boards;
pub mod config;
mod fields;
pub mod kmtronic;
pub mod lcus;
mod link;
pub mod modbus;
pub mod numato;
pub mod replay;
mod watch;

pub use boards::BoardConfig;
pub use config::{CoilMap, RelayConfig, RelaySettings, SwitchOrder};
pub use fields::ConfigError;
pub use link::Link;

use crate::model::geometry::CoilId;
use std::fmt;
use std::path::PathBuf;
use std::str::FromStr;
use std::time::Duration;

/// A relay channel as printed on the board: 1-based.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub struct Channel(pub u16);

impl fmt::Display for Channel {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}", self.0)
    }
}

/// A relay channel on one of a replay's boards: the board (0-based, in `[[relay.boards]]`
/// order; always 0 with a single board) and its channel (1-based). Ordered board first.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub struct Slot {
    /// The board, 0-based in `[[relay.boards]]` order (0 with a single board).
    pub board: usize,
    /// The channel on that board, 1-based as printed on it.
    pub channel: Channel,
}

impl fmt::Display for Slot {
    /// As written in `[relay.map]`: `board:channel`.
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}:{}", self.board, self.channel)
    }
}

/// One board of a replay, resolved: its type, channel count, serial settings and port.
#[derive(Debug, Clone, PartialEq)]
pub struct BoardSpec {
    /// The board's type (its protocol).
    pub kind: BoardKind,
    /// How many relay channels it drives (at most [`BoardKind::max_channels`]).
    pub channels: u16,
    /// The serial baud rate, bits per second.
    pub baud: u32,
    /// Modbus slave address (other boards ignore it).
    pub slave_address: u8,
    /// How long to wait for a reply.
    pub timeout: Duration,
    /// The serial device (`port` of a `[[relay.boards]]` entry, or `--port`); `None` when not
    /// given (a dry run needs none).
    pub port: Option<String>,
}

/// The supported board types.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, serde::Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum BoardKind {
    /// CH340 "LCUS-1/2/4/8" USB relay boards: 4-byte frames `A0 ch op sum`, no read-back.
    Lcus,
    /// KMTronic USB relay boards: 3-byte frames `FF ch op`, status read on 1/2/4/8-relay boards.
    Kmtronic,
    /// Numato Lab USB relay modules: ASCII commands (`relay on 0\r`), read-back.
    Numato,
    /// Modbus RTU relay boards: coils written with function 05/0F, read with 01, CRC16.
    Modbus,
}

impl BoardKind {
    /// Every supported board type, in the order error messages list them.
    pub const ALL: [BoardKind; 4] = [
        BoardKind::Lcus,
        BoardKind::Kmtronic,
        BoardKind::Numato,
        BoardKind::Modbus,
    ];

    /// The type's name as a scenario or `--board` writes it (`lcus`, `kmtronic`, `numato`,
    /// `modbus`).
    pub fn name(self) -> &'static str {
        match self {
            BoardKind::Lcus => "lcus",
            BoardKind::Kmtronic => "kmtronic",
            BoardKind::Numato => "numato",
            BoardKind::Modbus => "modbus",
        }
    }

    /// The most channels one board of this type can drive.
    pub fn max_channels(self) -> u16 {
        match self {
            BoardKind::Lcus => lcus::MAX_CHANNELS,
            BoardKind::Kmtronic => kmtronic::MAX_CHANNELS,
            BoardKind::Numato => numato::MAX_CHANNELS,
            BoardKind::Modbus => modbus::MAX_CHANNELS,
        }
    }

    /// The channel count assumed when the settings give none.
    pub fn default_channels(self) -> u16 {
        match self {
            BoardKind::Lcus | BoardKind::Kmtronic => 8,
            BoardKind::Numato | BoardKind::Modbus => 16,
        }
    }

    /// The vendors' default baud rate.
    pub fn default_baud(self) -> u32 {
        match self {
            BoardKind::Numato => 19200,
            _ => 9600,
        }
    }
}

impl fmt::Display for BoardKind {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

impl FromStr for BoardKind {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        BoardKind::ALL
            .into_iter()
            .find(|k| k.name().eq_ignore_ascii_case(s.trim()))
            .ok_or_else(|| format!("expected lcus, kmtronic, numato or modbus, got '{s}'"))
    }
}

/// Errors of the relay drivers and of a replay.
#[derive(Debug, thiserror::Error)]
pub enum RelayError {
    /// The serial port could not be opened.
    #[error("cannot open serial port {port}: {message} (is the board plugged in, and are you in the `dialout` group?)")]
    Open {
        /// The serial device.
        port: String,
        /// The operating system's reason.
        message: String,
    },
    /// Reading or writing the port failed.
    #[error("serial port {port}: {op} failed: {source}")]
    Port {
        /// The serial device.
        port: String,
        /// What was being done, in words ("writing", "reading", "waiting for a reply").
        op: &'static str,
        /// The operating system's error.
        #[source]
        source: std::io::Error,
    },
    /// The other end of the port went away (unplugged board, closed pseudo-terminal).
    #[error("serial port {port}: the board end closed the connection while {op}")]
    Closed {
        /// The serial device.
        port: String,
        /// What was being done, in words ("writing", "waiting for a reply").
        op: &'static str,
    },
    /// The board did not answer in time.
    #[error("{board} board on {port}: no complete reply within {} ms (got {got} bytes: {})", timeout.as_millis(), hex(partial))]
    NoReply {
        /// The board's type.
        board: BoardKind,
        /// Its serial device.
        port: String,
        /// How long its reply was awaited.
        timeout: Duration,
        /// How many bytes of the reply arrived.
        got: usize,
        /// The bytes that arrived.
        partial: Vec<u8>,
    },
    /// A wait for a board (its reply, or a blocked write) ended before the board's timeout
    /// because a coil reached its guard (the runner's watch, `relay/watch.rs`); the runner turns
    /// it into [`RelayError::OnTimeReached`] naming the board.
    #[error("serial port {port}: {op} given up after {} ms (of its {} ms timeout) to keep every coil within its on-time limit", waited.as_millis(), timeout.as_millis())]
    WaitCut {
        /// The serial device.
        port: String,
        /// What was being waited for, in words ("writing", "waiting for a reply").
        op: &'static str,
        /// How long it was waited before it was cut.
        waited: Duration,
        /// The board's full timeout, which the wait did not reach.
        timeout: Duration,
    },
    /// The board answered something the protocol does not allow.
    #[error("{board} board: unexpected reply {}: expected {expected}", hex(got))]
    BadReply {
        /// The board's type.
        board: BoardKind,
        /// What the protocol allows at this point, in words.
        expected: String,
        /// The bytes received.
        got: Vec<u8>,
    },
    /// A Modbus slave answered with an exception.
    #[error("modbus slave {slave}: exception {code:#04x} ({}) to function {function:#04x}", modbus::exception_name(*code))]
    ModbusException {
        /// The slave's address.
        slave: u8,
        /// The function code of the request.
        function: u8,
        /// The exception code.
        code: u8,
    },
    /// A channel outside the board.
    #[error("{board} board: channel {channel} is outside its channels 1..={count}")]
    ChannelOutOfRange {
        /// The board's type.
        board: BoardKind,
        /// The channel asked for (1-based).
        channel: Channel,
        /// The board's channel count.
        count: u16,
    },
    /// More channels configured than one board of this type has.
    #[error("{board} boards have at most {max} channels, the settings ask for {count}{hint}")]
    TooManyChannels {
        /// The board's type.
        board: BoardKind,
        /// The channel count asked for.
        count: u16,
        /// The most this board type has ([`BoardKind::max_channels`]).
        max: u16,
        /// A hint on what to change, or empty.
        hint: &'static str,
    },
    /// Verifying the relays on a board (or channel count) that cannot report them.
    #[error("{}", self.worded(&Fields))]
    NoReadBack {
        /// The board's type.
        board: BoardKind,
        /// Why it cannot report its relays.
        reason: String,
    },
    /// The read-back after a step differs from what was switched.
    #[error(
        "verify after step {step}: expected channels on [{}], the board reports [{}]",
        list(expected),
        list(got)
    )]
    Mismatch {
        /// The plan step whose relays were verified, as the plan numbers it.
        step: usize,
        /// The channels that should be on, in order.
        expected: Vec<Channel>,
        /// The channels the board reports on, in order.
        got: Vec<Channel>,
    },
    /// The plan uses a coil that no relay channel drives.
    #[error("plan step {step} uses coil {coil}, which {reason}")]
    Unmapped {
        /// The plan step that uses the coil, as the plan numbers it.
        step: usize,
        /// The coil no channel drives.
        coil: CoilId,
        /// Why, in words: not on the stator, not in the map, or mapped past its board.
        reason: String,
    },
    /// Too many coils would be on at once (supply limit).
    #[error("step {step} would have {count} coils on at once ({coils}), over the limit of {max} (relay.max_coils_on; the supply is 24 V, 100 W)")]
    TooManyOn {
        /// The plan step, as the plan numbers it.
        step: usize,
        /// How many coils would be on.
        count: usize,
        /// The limit (`relay.max_coils_on`).
        max: usize,
        /// The coils that would be on, as a list for the message.
        coils: String,
    },
    /// One coil would stay on longer than allowed (heat).
    #[error("{}", self.worded(&Fields))]
    OnTooLong {
        /// The coil that would stay on too long.
        coil: CoilId,
        /// The board, with `[[relay.boards]]` (`None` with a single board).
        board: Option<usize>,
        /// Its channel (1-based).
        channel: Channel,
        /// When it would be on, in words (which steps).
        when: String,
        /// How long it would stay on continuously.
        on: Duration,
        /// Its limit (`relay.max_on_time`).
        max: Duration,
        /// What to do about it.
        advice: OnTimeAdvice,
    },
    /// A coil reached its guard (its on-time limit less [`on_time::guard_margin`]) while the
    /// replay dwelt, waited for a board or the sensor, or decided (fitting, replanning):
    /// every coil was switched off (the other boards first when one did not answer), and the
    /// computation abandoned.
    ///
    /// [`on_time::guard_margin`]: crate::planning::on_time::guard_margin
    #[error("{}", self.worded(&Fields))]
    OnTimeReached {
        /// The coil that reached its guard.
        coil: CoilId,
        /// Its board, with `[[relay.boards]]` (`None` with a single board).
        board: Option<usize>,
        /// Its channel (1-based).
        channel: Channel,
        /// What the replay was doing: "dwelling in step 3", "waiting for the sensor",
        /// "deciding (fitting the wells, replanning)", "waiting for board 1 (...) to answer".
        phase: String,
        /// Its on-time when the guard fired.
        on: Duration,
        /// Its on-time when its board's all-off went out (`None`: that all-off failed).
        off: Option<Duration>,
        /// Its limit (`relay.max_on_time`).
        max: Duration,
        /// The wait was for a board that did not answer (not for a dwell, Enter, the sensor or
        /// a decision that a shorter setting could shorten).
        silent_board: bool,
    },
    /// Ctrl-C, SIGTERM or SIGHUP.
    #[error("interrupted by a signal")]
    Interrupted,
    /// Standard input closed while waiting for Enter in step mode.
    #[error("standard input closed while waiting for Enter")]
    InputClosed,
    /// Reading, checking or writing the replay log failed.
    /// (The cause is part of the message and not a `source`, so that printing the error chain
    /// does not say it twice.)
    #[error("log {path}: {cause}")]
    Log {
        /// The log file.
        path: PathBuf,
        /// What failed.
        cause: std::io::Error,
    },
    /// A replay setting's value that cannot be used (for example a first step past the plan's
    /// end); `expected` says what can.
    #[error("{}", self.worded(&Fields))]
    Setting {
        /// The setting.
        setting: Setting,
        /// What values it can take.
        expected: String,
    },
    /// The replay stopped on an error; every coil was switched off afterwards; `resume` is the
    /// step to resume from.
    #[error("{}", self.worded(&Fields))]
    Stopped {
        /// The error the replay stopped on.
        cause: Box<RelayError>,
        /// The step to resume from (`from_step`).
        resume: usize,
    },
    /// The replay finished but the final all-off failed.
    #[error("{}", self.worded(&Fields))]
    EndOffFailed(Box<RelayError>),
    /// The replay stopped and switching everything off failed too.
    #[error("{}", self.worded(&Fields))]
    OffFailed {
        /// The error the replay stopped on.
        cause: Box<RelayError>,
        /// The all-off's failure.
        off: Box<RelayError>,
    },
    /// An open-loop replay stopped and switching all off failed too (`error`: `OffFailed` or
    /// `BoardsOffFailed`): where to resume once the board is back.
    #[error("{}", self.worded(&Fields))]
    OffFailedResume {
        /// The failure (`OffFailed` or `BoardsOffFailed`).
        error: Box<RelayError>,
        /// The step to resume from (`from_step`).
        resume: usize,
    },
    /// Something failed on one board of several (`[[relay.boards]]`): which board, on which
    /// port (the configured one in a dry run), and what.
    #[error("{}", self.worded(&Fields))]
    OnBoard {
        /// The board, 0-based in `[[relay.boards]]` order.
        index: usize,
        /// Its serial device (the configured one in a dry run).
        port: String,
        /// What failed on it.
        error: Box<RelayError>,
    },
    /// With several boards: the replay finished (`cause` `None`) or stopped on `cause`, and
    /// switching all off failed on the `failed` boards (each an `OnBoard`); the boards in
    /// `switched_off` (their labels) were switched off.
    #[error("{}", self.worded(&Fields))]
    BoardsOffFailed {
        /// The error the replay stopped on (`None`: it finished).
        cause: Option<Box<RelayError>>,
        /// The all-off's failures, one `OnBoard` per board.
        failed: Vec<RelayError>,
        /// The labels of the boards that were switched off.
        switched_off: Vec<String>,
    },
}

/// A setting of a replay that an error is about. The library's messages name it by its field
/// (`from_step`); the command line words it as its flag (see [`Wording`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
#[non_exhaustive]
pub enum Setting {
    /// The board type of the single-board form ([`replay::Drive::board`]).
    Board,
    /// The baud rate of the single-board form.
    Baud,
    /// The serial devices of the boards.
    Port,
    /// Realtime or step mode.
    Mode,
    /// A fixed dwell for every step.
    Dwell,
    /// The first step replayed.
    FromStep,
    /// The replay log.
    Log,
    /// Reading the relays back after each step.
    Verify,
    /// A replay over no port (nothing is sent).
    DryRun,
    /// The closed loop's orientation sensor.
    Sensor,
    /// How long the sensor is awaited.
    SensorTimeout,
    /// The most steps of a closed loop.
    MaxSteps,
}

impl Setting {
    /// The setting's name in the library: the field that holds it.
    pub fn name(self) -> &'static str {
        match self {
            Setting::Board => "board",
            Setting::Baud => "baud",
            Setting::Port => "ports",
            Setting::Mode => "mode",
            Setting::Dwell => "dwell_ms",
            Setting::FromStep => "from_step",
            Setting::Log => "log",
            Setting::Verify => "verify",
            Setting::DryRun => "dry_run",
            Setting::Sensor => "sensor",
            Setting::SensorTimeout => "sensor_timeout_ms",
            Setting::MaxSteps => "max_steps",
        }
    }
}

/// How a message names the settings it is about: [`Fields`] (the library's `Display`: the
/// fields' names), or the command line's flags.
pub trait Wording: std::fmt::Debug + Sync {
    /// A setting inside a phrase ("resume with `from_step` 3").
    fn name(&self, s: Setting) -> String;
    /// The head of a message about a setting's value ("replay setting `from_step`").
    fn subject(&self, s: Setting) -> String;
}

/// The library's wording: settings by their fields' names.
#[derive(Debug, Clone, Copy)]
pub struct Fields;

impl Wording for Fields {
    fn name(&self, s: Setting) -> String {
        format!("`{}`", s.name())
    }
    fn subject(&self, s: Setting) -> String {
        format!("replay setting `{}`", s.name())
    }
}

/// What an on-time error advises.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum OnTimeAdvice {
    /// Nothing to add.
    None,
    /// The dwells come from the plan: a fixed shorter dwell, or a higher limit.
    Dwell,
}

impl RelayError {
    /// The message, its settings named by `w` (`Display` is `worded(&Fields)`); the errors
    /// inside are worded the same way.
    pub fn worded(&self, w: &dyn Wording) -> String {
        match self {
            RelayError::Setting { setting, expected } => {
                format!("{}: expected {expected}", w.subject(*setting))
            }
            RelayError::NoReadBack { board, reason } => format!(
                "{board} board: {reason}; replay without {}",
                w.name(Setting::Verify)
            ),
            RelayError::OnTooLong { .. } | RelayError::OnTimeReached { .. } => self.on_time(w),
            RelayError::Stopped { .. }
            | RelayError::EndOffFailed(_)
            | RelayError::OffFailed { .. }
            | RelayError::OffFailedResume { .. } => self.stopped(w),
            RelayError::OnBoard { index, port, error } => {
                format!("board {index} ({port}): {}", error.worded(w))
            }
            RelayError::BoardsOffFailed {
                cause,
                failed,
                switched_off,
            } => boards_off_failed(cause.as_ref().map(|c| c.worded(w)), failed, switched_off, w),
            e => e.to_string(),
        }
    }

    /// The messages of a replay that stopped (and of the all-off that failed), worded by `w`.
    fn stopped(&self, w: &dyn Wording) -> String {
        match self {
            RelayError::Stopped { cause, resume } => format!(
                "{}; all coils switched off; resume with {} {resume}",
                cause.worded(w),
                w.name(Setting::FromStep)
            ),
            RelayError::EndOffFailed(e) => format!(
                "the replay finished, but switching all coils off FAILED: {}; the coils may \
                 still be on: cut the coil supply",
                e.worded(w)
            ),
            RelayError::OffFailed { cause, off } => off_failed(&cause.worded(w), off, w),
            RelayError::OffFailedResume { error, resume } => format!(
                "{}; once every board answers again, resume with {} {resume}",
                error.worded(w),
                w.name(Setting::FromStep)
            ),
            e => e.to_string(),
        }
    }

    /// The messages of the on-time errors, worded by `w`.
    fn on_time(&self, w: &dyn Wording) -> String {
        match self {
            RelayError::OnTooLong {
                coil,
                board,
                channel,
                when,
                on,
                max,
                advice,
            } => {
                let advice = match advice {
                    OnTimeAdvice::None => String::new(),
                    OnTimeAdvice::Dwell => format!(
                        "; the dwells are the plan's settle times x relay.dwell_factor: give a \
                         shorter {}, or raise relay.max_on_time_s if the coils can take the heat",
                        w.name(Setting::Dwell)
                    ),
                };
                format!(
                    "coil {coil} ({}) {when} {:.3} s, over {}{advice}",
                    where_on(*board, *channel),
                    on.as_secs_f64(),
                    crate::planning::on_time::budget_text(*max)
                )
            }
            RelayError::OnTimeReached {
                coil,
                board,
                channel,
                phase,
                on,
                off,
                max,
                silent_board,
            } => {
                let advice = match silent_board {
                    true => "check that board's power and cable".to_string(),
                    false => format!(
                        "a shorter {} or {}, or a higher relay.max_on_time_s, leaves more time",
                        w.name(Setting::Dwell),
                        w.name(Setting::SensorTimeout)
                    ),
                };
                let off = match off {
                    Some(off) if off <= max => format!(
                        "every coil was switched off, this one after {:.3} s, within the limit",
                        off.as_secs_f64()
                    ),
                    Some(off) => format!(
                        "every coil was switched off, this one only after {:.3} s, PAST the limit",
                        off.as_secs_f64()
                    ),
                    None => "every coil was switched off but on its own board, which failed \
                             (below)"
                        .to_string(),
                };
                format!(
                    "coil {coil} ({}) had been on {:.3} s, within the guard's {} ms of its limit \
                     of {:.3} s (relay.max_on_time_s), while {phase}: {off} ({advice})",
                    where_on(*board, *channel),
                    on.as_secs_f64(),
                    crate::planning::on_time::guard_margin(*max).as_millis(),
                    max.as_secs_f64(),
                )
            }
            e => e.to_string(),
        }
    }

    /// The error that started it all (through `Stopped` and `OffFailed`).
    pub fn root(&self) -> &RelayError {
        match self {
            RelayError::Stopped { cause, .. } | RelayError::OffFailed { cause, .. } => cause.root(),
            RelayError::OnBoard { error, .. } | RelayError::OffFailedResume { error, .. } => {
                error.root()
            }
            RelayError::BoardsOffFailed {
                cause: Some(cause), ..
            } => cause.root(),
            e => e,
        }
    }
}

impl RelayError {
    /// An all-off that failed at the end of a replay (`EndOffFailed`, or `BoardsOffFailed`
    /// without a cause) after the replay stopped on `cause`: `OffFailed`, or `BoardsOffFailed`
    /// with that cause; the all-off's failure as it is without one.
    pub fn after(self, cause: Option<RelayError>) -> RelayError {
        match (self, cause) {
            (RelayError::EndOffFailed(off), Some(c)) => RelayError::OffFailed {
                cause: Box::new(c),
                off,
            },
            (
                RelayError::BoardsOffFailed {
                    cause: None,
                    failed,
                    switched_off,
                },
                Some(c),
            ) => RelayError::BoardsOffFailed {
                cause: Some(Box::new(c)),
                failed,
                switched_off,
            },
            (e, _) => e,
        }
    }

    /// The message of this all-off failure (as [`RelayError::after`] takes it) after a replay
    /// that stopped on an error of a layer above, already worded: `cause`.
    pub fn after_text(&self, cause: &str, w: &dyn Wording) -> String {
        match self {
            RelayError::EndOffFailed(off) => off_failed(cause, off, w),
            RelayError::BoardsOffFailed {
                cause: None,
                failed,
                switched_off,
            } => boards_off_failed(Some(cause.to_string()), failed, switched_off, w),
            e => format!("{cause}; then {}", e.worded(w)),
        }
    }
}

/// The message of a replay that stopped on `cause` (worded) and whose all-off then failed on
/// its one board with `off`.
fn off_failed(cause: &str, off: &RelayError, w: &dyn Wording) -> String {
    format!(
        "{cause}; then switching all coils off FAILED: {}; the coils may still be on: cut the \
         coil supply",
        off.worded(w)
    )
}

/// Where a coil is switched, in messages: `channel 3`, or `board 1, channel 3`.
fn where_on(board: Option<usize>, channel: Channel) -> String {
    match board {
        None => format!("channel {channel}"),
        Some(b) => format!("board {b}, channel {channel}"),
    }
}

/// The message of `RelayError::BoardsOffFailed`: which boards failed and why, that their coils
/// may still be on, and which boards were switched off.
fn boards_off_failed(
    cause: Option<String>,
    failed: &[RelayError],
    switched_off: &[String],
    w: &dyn Wording,
) -> String {
    let head = match cause {
        Some(c) => format!("{c}; then switching all coils off FAILED on "),
        None => "the replay finished, but switching all coils off FAILED on ".to_string(),
    };
    let why: Vec<String> = failed.iter().map(|e| e.worded(w)).collect();
    let which: Vec<String> = failed
        .iter()
        .map(|e| match e {
            RelayError::OnBoard { index, .. } => index.to_string(),
            _ => "?".to_string(),
        })
        .collect();
    let boards = match which.as_slice() {
        [one] => format!("board {one}"),
        [most @ .., last] => format!("boards {} and {last}", most.join(", ")),
        [] => "the boards".to_string(),
    };
    let others = if switched_off.is_empty() {
        String::new()
    } else {
        format!(" (switched off: {})", switched_off.join(", "))
    };
    format!(
        "{head}{}; the coils on {boards} may still be on: cut the coil supply{others}",
        why.join("; and on ")
    )
}

pub use crate::serial::hex;

fn list(chs: &[Channel]) -> String {
    chs.iter()
        .map(|c| c.to_string())
        .collect::<Vec<_>>()
        .join(", ")
}

/// One relay board: the interface every driver implements.
pub trait RelayBoard: Send {
    /// Which protocol this is.
    fn kind(&self) -> BoardKind;
    /// Switches one channel on or off.
    fn set(&mut self, channel: Channel, on: bool) -> Result<(), RelayError>;
    /// Switches every channel off.
    fn all_off(&mut self) -> Result<(), RelayError>;
    /// Whether `read_states` can work with this board and channel count; `Err` says why not.
    fn read_back(&self) -> Result<(), RelayError> {
        Err(RelayError::NoReadBack {
            board: self.kind(),
            reason: "this board type cannot report its relay states".into(),
        })
    }
    /// The state of channels 1..=count (index 0 is channel 1); `None` in a dry run.
    fn read_states(&mut self) -> Result<Option<Vec<bool>>, RelayError> {
        self.read_back()?;
        Ok(None)
    }
    /// The frames written since the last call, in order (for the log and the dry-run listing).
    fn take_sent(&mut self) -> Vec<Vec<u8>>;
}

/// Checks a channel against a board's count.
pub(crate) fn check_channel(
    board: BoardKind,
    channel: Channel,
    count: u16,
) -> Result<(), RelayError> {
    if channel.0 == 0 || channel.0 > count {
        return Err(RelayError::ChannelOutOfRange {
            board,
            channel,
            count,
        });
    }
    Ok(())
}

/// Opens the driver for `kind` with `channels` channels over `link`; refuses a channel count the
/// board type cannot have.
pub fn connect(
    kind: BoardKind,
    channels: u16,
    slave_address: u8,
    link: Link,
) -> Result<Box<dyn RelayBoard>, RelayError> {
    let max = kind.max_channels();
    if channels == 0 || channels > max {
        return Err(RelayError::TooManyChannels {
            board: kind,
            count: channels,
            max,
            hint: if kind == BoardKind::Lcus {
                " (LCUS-1/2/4/8: for 16 coils use a 16-channel numato or modbus board, or map the coils the plan uses onto channels 1..=8)"
            } else {
                ""
            },
        });
    }
    Ok(match kind {
        BoardKind::Lcus => Box::new(lcus::Lcus::new(link, channels)),
        BoardKind::Kmtronic => Box::new(kmtronic::Kmtronic::new(link, channels)),
        BoardKind::Numato => Box::new(numato::Numato::new(link, channels)),
        BoardKind::Modbus => Box::new(modbus::Modbus::new(link, channels, slave_address)),
    })
}

#[cfg(test)]
mod wording_tests {
    use super::*;

    /// A front end's wording: settings as `<name>`.
    #[derive(Debug)]
    struct Angled;

    impl Wording for Angled {
        fn name(&self, s: Setting) -> String {
            format!("<{}>", s.name())
        }
        fn subject(&self, s: Setting) -> String {
            format!("option <{}>", s.name())
        }
    }

    #[test]
    fn where_to_resume_is_named_by_the_wording_not_by_a_flag() {
        let e = RelayError::OffFailedResume {
            error: Box::new(RelayError::Setting {
                setting: Setting::Dwell,
                expected: "a dwell".into(),
            }),
            resume: 3,
        };
        assert_eq!(
            e.to_string(),
            "replay setting `dwell_ms`: expected a dwell; once every board answers again, \
             resume with `from_step` 3"
        );
        assert_eq!(
            e.worded(&Angled),
            "option <dwell_ms>: expected a dwell; once every board answers again, resume with \
             <from_step> 3"
        );
    }
}
