//! `spherestep replay`: reads the plan, the scenario and the relay map, and hands the relay layer
//! what it needs to drive the board, or the boards (`crate::relay::replay`); also reads a replay
//! log to say where to resume.

use crate::error::{Error, Result};
use crate::io::planfile::read_plan;
use crate::io::scenario::Scenario;
use crate::planning::plan::PlanRow;
use crate::relay::replay::{check_log, execute_on, open_ports, Drive, Mode, Prepared, Summary};
use crate::relay::{BoardKind, Link, RelayError, RelaySettings, Setting, Wording};
use std::io::Write;
use std::path::{Path, PathBuf};
use std::sync::atomic::AtomicBool;
use std::sync::mpsc::Receiver;
use std::sync::Arc;

/// The command line's wording of a replay's settings: each as the flag that sets it.
#[derive(Debug, Clone, Copy)]
pub struct Flags;

impl Flags {
    /// The flag of a setting.
    pub fn flag(s: Setting) -> &'static str {
        match s {
            Setting::Board => "--board",
            Setting::Baud => "--baud",
            Setting::Port => "--port",
            Setting::Mode => "--mode",
            Setting::Dwell => "--dwell-ms",
            Setting::FromStep => "--from-step",
            Setting::Log => "--log",
            Setting::Verify => "--verify",
            Setting::DryRun => "--dry-run",
            Setting::Sensor => "--sensor",
            Setting::SensorTimeout => "--sensor-timeout-ms",
            Setting::MaxSteps => "--max-steps",
        }
    }
}

impl Wording for Flags {
    fn name(&self, s: Setting) -> String {
        Flags::flag(s).to_string()
    }
    fn subject(&self, s: Setting) -> String {
        format!("argument {}", Flags::flag(s))
    }
}

/// An error as the command line shows it: a replay's settings worded as their flags
/// ([`Error::worded`] with [`Flags`]); its causes are the error's.
#[derive(Debug)]
pub struct Flagged(pub Error);

impl std::fmt::Display for Flagged {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(&self.0.worded(&Flags))
    }
}

impl std::error::Error for Flagged {
    fn source(&self) -> Option<&(dyn std::error::Error + 'static)> {
        std::error::Error::source(&self.0)
    }
}

impl From<Error> for Flagged {
    fn from(e: Error) -> Self {
        Flagged(e)
    }
}

/// The replay's inputs, as the command line gives them.
#[derive(Debug, Clone)]
pub struct ReplayOptions {
    /// The plan CSV.
    pub plan: PathBuf,
    /// The scenario (coil count, `[relay]` section); the built-in prototype when `None`.
    pub scenario: Option<PathBuf>,
    /// A TOML map file with the `[relay]` keys at the top; replaces the scenario's section.
    pub map: Option<PathBuf>,
    /// Serial device (`--port`; not needed with `dry_run`): one for a single board; with
    /// `[[relay.boards]]`, none (their `port` keys) or one per board in list order.
    pub ports: Vec<String>,
    /// Overrides `relay.board` (single board only).
    pub board: Option<BoardKind>,
    /// Overrides `relay.baud` (single board only).
    pub baud: Option<u32>,
    /// Realtime (the dwells) or step mode (Enter between steps).
    pub mode: Mode,
    /// A fixed dwell for every step instead of settle time x factor (used as given: the floor is for the derived dwells).
    pub dwell_ms: Option<u64>,
    /// First step to replay; the step before is re-energised first to hold the ball.
    pub from_step: usize,
    /// A dry run: nothing is opened or sent, the clock is simulated.
    pub dry_run: bool,
    /// CSV log of what was sent when (appended to when it exists).
    pub log: Option<PathBuf>,
    /// Read the relays back after each step and stop on a mismatch.
    pub verify: bool,
}

impl ReplayOptions {
    /// Options for `plan` with everything else at its default (realtime, no port).
    pub fn new(plan: impl Into<PathBuf>) -> ReplayOptions {
        ReplayOptions {
            plan: plan.into(),
            scenario: None,
            map: None,
            ports: Vec::new(),
            board: None,
            baud: None,
            mode: Mode::Realtime,
            dwell_ms: None,
            from_step: 0,
            dry_run: false,
            log: None,
            verify: false,
        }
    }

    /// The choices the relay layer needs.
    pub fn drive(&self) -> Drive {
        Drive {
            board: self.board,
            baud: self.baud,
            ports: self.ports.clone(),
            mode: self.mode,
            dwell_ms: self.dwell_ms,
            from_step: self.from_step,
            log: self.log.clone(),
            verify: self.verify,
        }
    }
}

/// What a replay reads: the plan's rows, the scenario and the relay settings (the map file's,
/// or the scenario's section).
pub fn inputs(opts: &ReplayOptions) -> Result<(Vec<PlanRow>, Scenario, RelaySettings)> {
    let rows = read_plan(&opts.plan)?;
    let scenario = match &opts.scenario {
        Some(p) => Scenario::load(p)?,
        None => Scenario::prototype(),
    };
    let settings = match &opts.map {
        Some(p) => {
            let text = crate::io::input::text(p)?;
            RelaySettings::from_map_toml(&text, p)?
        }
        None => scenario.relay.clone(),
    };
    Ok((rows, scenario, settings))
}

/// Reads the plan, scenario and map, resolves the settings, checks the schedule and that the
/// `--log` is a replay log that may be appended to (or a new or empty file).
pub fn prepare(opts: &ReplayOptions) -> Result<Prepared> {
    let (rows, scenario, settings) = inputs(opts)?;
    let prep = crate::relay::replay::prepare(&rows, settings, scenario.stator.len(), opts.drive())?
        .worded(&Flags);
    check_log(&prep, false)?;
    Ok(prep)
}

/// `spherestep replay`: prepares, opens the ports (unless dry run) and replays.
pub fn run(
    opts: &ReplayOptions,
    stop: Arc<AtomicBool>,
    input: Option<Receiver<String>>,
    out: &mut dyn Write,
) -> Result<Summary> {
    let prep = prepare(opts)?;
    let links = if opts.dry_run {
        prep.boards.iter().map(|_| Link::dry_run()).collect()
    } else {
        open_ports(&prep)?
    };
    Ok(execute_on(&prep, links, stop, input, out)?)
}

/// Reads a replay log and returns the step to resume from: the one after the last step whose
/// dwell completed (0 when none did).
pub fn resume_step(log: &Path) -> Result<usize> {
    let text = crate::io::input::read_text(log).map_err(|e| RelayError::Log {
        path: log.to_path_buf(),
        cause: e,
    })?;
    let mut next = 0;
    for line in text.lines().skip(1) {
        let cols: Vec<&str> = line.split(',').collect();
        if cols.get(2) == Some(&"done") {
            if let Some(Ok(step)) = cols.get(1).map(|s| s.parse::<usize>()) {
                next = step + 1;
            }
        }
    }
    Ok(next)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn resume_step_reads_the_last_done_row() {
        let dir = std::env::temp_dir().join(format!("spherestep-log-{}", std::process::id()));
        std::fs::write(
            &dir,
            "t_s,step,action,coil,channel,bytes\n0.000,0,start,,,\n0.2,0,done,,,\n0.2,1,on,2,3,A0 03 01 A4\n",
        )
        .unwrap();
        assert_eq!(resume_step(&dir).unwrap(), 1);
        let _ = std::fs::remove_file(&dir);
    }
}
