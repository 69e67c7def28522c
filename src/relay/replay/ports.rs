//! The replay's boards resolved from the settings and the command line, and their serial
//! ports opened (the boards already open switched off when one fails to open).

use super::schedule::{coil_check, schedule_on, Mode, Schedule};
use crate::model::geometry::CoilId;
use crate::planning::plan::PlanRow;
use crate::relay::{
    connect, BoardKind, BoardSpec, Fields, Link, RelayError, RelaySettings, Setting, Wording,
};
use std::path::PathBuf;
use std::time::Duration;

/// Everything resolved from the options before a port is opened.
#[derive(Debug, Clone)]
pub struct Prepared {
    /// The `[relay]` settings, checked.
    pub settings: RelaySettings,
    /// The boards, in order (one with the single-board form), ports resolved with `--port`.
    pub boards: Vec<BoardSpec>,
    /// The plan's steps as relay switching, checked against the limits.
    pub schedule: Schedule,
    /// The command line's choices (mode, dwell, first step, log, verify).
    pub drive: Drive,
    /// How the replay's own lines and refusals name its settings (where to resume, which log
    /// to give): by their fields ([`Fields`]) unless the front end words them
    /// ([`Prepared::worded`]; the command line: as its flags).
    pub wording: &'static dyn Wording,
}

impl Prepared {
    /// The same replay, its settings named by `w`.
    pub fn worded(self, w: &'static dyn Wording) -> Prepared {
        Prepared { wording: w, ..self }
    }

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
    /// Realtime (the dwells) or step mode (Enter between steps).
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
    let boards = boards_of(&settings, &drive)?;
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
        wording: &Fields,
    })
}

/// Resolves the boards of `settings` as [`prepare`] does and works out the checked schedule of
/// a wiring check ([`coil_check`]: each of `coils`, or every coil a channel drives, on alone
/// for `drive.dwell_ms`, then off for as long), to play with the runner of a replay
/// ([`execute_on`](super::execute_on)) under its limits. `drive.mode` must be realtime and
/// `drive.from_step` 0 (step mode and a resume are a plan's).
pub fn prepare_check(
    coils: Option<&[CoilId]>,
    settings: RelaySettings,
    stator_coils: usize,
    drive: Drive,
) -> Result<Prepared, RelayError> {
    let refuse = |setting, expected: &str| RelayError::Setting {
        setting,
        expected: expected.into(),
    };
    if drive.mode != Mode::Realtime {
        return Err(refuse(
            Setting::Mode,
            "realtime (a wiring check waits for no Enter)",
        ));
    }
    if drive.from_step != 0 {
        return Err(refuse(
            Setting::FromStep,
            "0 (a wiring check has no step to resume from)",
        ));
    }
    let on = match drive.dwell_ms {
        Some(ms) if ms > 0 => Duration::from_millis(ms),
        _ => {
            return Err(refuse(
                Setting::Dwell,
                "how long each coil of a wiring check stays on, over 0 ms",
            ))
        }
    };
    let boards = boards_of(&settings, &drive)?;
    let schedule = coil_check(coils, &settings, &boards, stator_coils, on)?;
    Ok(Prepared {
        settings,
        boards,
        schedule,
        drive,
        wording: &Fields,
    })
}

/// The boards of `settings` under the overrides of `drive`: the single board, or the listed ones.
fn boards_of(settings: &RelaySettings, drive: &Drive) -> Result<Vec<BoardSpec>, RelayError> {
    if settings.boards.is_empty() {
        Ok(vec![single_board(settings, drive)?])
    } else {
        listed_boards(settings, drive)
    }
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
pub(super) fn configured_port(spec: &BoardSpec) -> String {
    spec.port.clone().unwrap_or_else(|| "no port".into())
}

/// An error on board `index` (on `port`), for the multi-board form.
pub(super) fn on_board(index: usize, port: &str, error: RelayError) -> RelayError {
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
