//! What a lab runs once after wiring a relay board (or several): every coil a channel drives
//! switched on alone for a moment and off again, each switch read back where the board can
//! report its relays, and a table of what passed. It plays through the replay's own runner
//! (`relay::replay::prepare_check` and `execute_on`), so the limits are a replay's: the
//! scenario's `relay.max_coils_on` and `relay.max_on_time_s` checked before any byte is sent,
//! every wait cut at a coil's guard, each board's `timeout_ms`, every board all off first, at
//! the end, on an error and on Ctrl-C/SIGTERM/SIGHUP.
//!
//! ```text
//! cargo run --release --example hardware_check -- SCENARIO.toml [--port DEV]... [--map FILE]
//!     [--board KIND] [--baud N] [--on-ms MS] [--coils 0,1,...] [--no-verify]
//! ```
//!
//! `SCENARIO.toml` gives the stator's coils and the `[relay]` section (or `--map FILE`, a map
//! file as `replay --map` reads it); `--port` names the board's serial device (once per board
//! of `[[relay.boards]]`, in order, or their `port` keys); `--on-ms` is how long each coil is
//! on (default 200); `--coils` checks only those coils.
//! `tests/rig/hardware_check.rs` runs it against pseudo-terminal boards, and
//! `tests/rig/hardware.rs` (feature `hardware-tests`) against a real one (TESTING.md).

use spherestep::io::scenario::Scenario;
use spherestep::relay::replay::{execute_on, open_ports, prepare_check, Drive, Mode, Prepared};
use spherestep::relay::{connect, Link, RelayError, RelaySettings, Setting, Wording};
use spherestep::{CoilId, Error};
use std::io::Write;
use std::path::PathBuf;
use std::process::ExitCode;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;

/// How long each coil is on when `--on-ms` is not given, ms.
pub const DEFAULT_ON_MS: u64 = 200;

/// The check's arguments.
#[derive(Debug, Clone)]
pub struct Args {
    pub scenario: PathBuf,
    pub map: Option<PathBuf>,
    pub drive: Drive,
    pub coils: Option<Vec<CoilId>>,
}

/// This program's wording of the replay settings its errors name: its flags.
#[derive(Debug)]
pub struct CheckFlags;

impl Wording for CheckFlags {
    fn name(&self, s: Setting) -> String {
        match s {
            Setting::Board => "--board",
            Setting::Baud => "--baud",
            Setting::Port => "--port",
            Setting::Dwell => "--on-ms",
            other => other.name(),
        }
        .to_string()
    }
    fn subject(&self, s: Setting) -> String {
        format!("argument {}", self.name(s))
    }
}

fn arg_error(arg: &str, expected: impl Into<String>) -> Error {
    Error::Arg {
        arg: arg.to_string(),
        expected: expected.into(),
    }
}

/// Parses the arguments after the program's name.
pub fn parse(args: &[String]) -> Result<Args, Error> {
    let mut scenario = None;
    let mut map = None;
    let mut coils = None;
    let mut drive = Drive {
        board: None,
        baud: None,
        ports: Vec::new(),
        mode: Mode::Realtime,
        dwell_ms: Some(DEFAULT_ON_MS),
        from_step: 0,
        log: None,
        verify: true,
    };
    let mut it = args.iter();
    while let Some(a) = it.next() {
        let mut value = |what: &str| {
            it.next()
                .cloned()
                .ok_or_else(|| arg_error(a, format!("{what} after it")))
        };
        match a.as_str() {
            "--port" => drive.ports.push(value("a serial device")?),
            "--map" => map = Some(PathBuf::from(value("a map file")?)),
            "--board" => {
                let v = value("a board type")?;
                drive.board = Some(v.parse().map_err(|m: String| {
                    arg_error(a, m.trim_start_matches("expected ").to_string())
                })?);
            }
            "--baud" => {
                let v = value("a baud rate")?;
                let b = v
                    .parse()
                    .map_err(|_| arg_error(a, format!("a baud rate, got {v}")))?;
                drive.baud = Some(b);
            }
            "--on-ms" => {
                let v = value("milliseconds")?;
                let ms = v
                    .parse()
                    .map_err(|_| arg_error(a, format!("milliseconds, got {v}")))?;
                drive.dwell_ms = Some(ms);
            }
            "--coils" => coils = Some(parse_coils(a, &value("coil numbers")?)?),
            "--no-verify" => drive.verify = false,
            s if s.starts_with("--") => return Err(arg_error(s, "no such option")),
            s if scenario.is_none() => scenario = Some(PathBuf::from(s)),
            s => return Err(arg_error(s, "one scenario file")),
        }
    }
    let scenario = scenario.ok_or_else(|| arg_error("SCENARIO", "a scenario file"))?;
    Ok(Args {
        scenario,
        map,
        drive,
        coils,
    })
}

/// `0,1,5`: coil numbers from 0, at least one.
fn parse_coils(arg: &str, text: &str) -> Result<Vec<CoilId>, Error> {
    let bad = || {
        arg_error(
            arg,
            format!("coil numbers from 0 separated by commas, got {text}"),
        )
    };
    text.split(',')
        .map(|c| c.trim().parse().map(CoilId).map_err(|_| bad()))
        .collect()
}

/// Reads the scenario (or the map file) and works out the checked schedule; opens nothing.
/// With `verify`, only the boards that can report their relays are read back: verify stays on
/// when one of them can.
pub fn prepare(args: &Args) -> Result<Prepared, Error> {
    let sc = Scenario::load(&args.scenario)?;
    let settings = match &args.map {
        Some(p) => RelaySettings::from_map_toml(&spherestep::io::input::text(p)?, p)?,
        None => sc.relay.clone(),
    };
    let coils = args.coils.as_deref();
    let mut prep = prepare_check(coils, settings, sc.stator.len(), args.drive.clone())?;
    // the runner refuses to verify a single board that cannot report its relays
    prep.drive.verify = args.drive.verify && readable(&prep).iter().any(|&r| r);
    Ok(prep.worded(&CheckFlags))
}

/// Which of the boards can report their relays.
fn readable(prep: &Prepared) -> Vec<bool> {
    (prep.boards.iter())
        .map(|b| {
            connect(b.kind, b.channels, b.slave_address, Link::dry_run())
                .is_ok_and(|d| d.read_back().is_ok())
        })
        .collect()
}

/// Runs the check on the boards' ports (opened here) and prints the runner's listing, then the
/// table; every coil is off at the end, whatever happened.
pub fn check(args: &[String], stop: Arc<AtomicBool>, out: &mut dyn Write) -> Result<(), Error> {
    let prep = prepare(&parse(args)?)?;
    let links = open_ports(&prep)?;
    let result = execute_on(&prep, links, stop, None, out);
    let resume = match &result {
        Ok(s) => s.next_step,
        Err(RelayError::Stopped { resume, .. } | RelayError::OffFailedResume { resume, .. }) => {
            *resume
        }
        Err(_) => 0,
    };
    table(&prep, resume, out).map_err(|e| Error::io("<stdout>", e))?;
    result.map(|_| ()).map_err(Error::from)
}

/// The table: per coil, its board and channel, and how its on and its off went (`read back`:
/// the board reported it; `sent`: the board cannot report its relays; `STOPPED`: the check
/// stopped there, see the error; `-`: not reached). `resume` is the first step not done.
fn table(prep: &Prepared, resume: usize, out: &mut dyn Write) -> std::io::Result<()> {
    let verified = readable(prep);
    writeln!(
        out,
        "{:>5} {:>5} {:>7}  {:<9}  off",
        "coil", "board", "channel", "on"
    )?;
    for pair in prep.schedule.entries.chunks(2) {
        let on = &pair[0];
        let Some(sw) = on.switches.first() else {
            continue;
        };
        let how = |step: usize| match step {
            s if s < resume && prep.drive.verify && verified[sw.board] => "read back",
            s if s < resume => "sent",
            s if s == resume => "STOPPED",
            _ => "-",
        };
        let off = pair.get(1).map_or("-", |e| how(e.step));
        let line = format!(
            "{:>5} {:>5} {:>7}  {:<9}  {off}",
            sw.coil.to_string(),
            sw.board,
            sw.channel.to_string(),
            how(on.step),
        );
        writeln!(out, "{}", line.trim_end())?;
    }
    Ok(())
}

fn main() -> ExitCode {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let stop = Arc::new(AtomicBool::new(false));
    let flag = stop.clone();
    if let Err(e) = ctrlc::set_handler(move || flag.store(true, Ordering::SeqCst)) {
        eprintln!("error: installing the Ctrl-C/SIGTERM handler: {e}");
        return ExitCode::FAILURE;
    }
    match check(&args, stop, &mut std::io::stdout()) {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("error: {}", e.worded(&CheckFlags));
            ExitCode::FAILURE
        }
    }
}
