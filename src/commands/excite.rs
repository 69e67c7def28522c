//! `spherestep plan --excite N`: an excitation run (random coil sets, [`excitation`]) written
//! as a plan file, to be replayed with a sensor and its log fitted (`fit --log`), and its
//! summary.

use crate::error::{Error, Result};
use crate::io::output::emit_csv;
use crate::io::planfile::write_plan;
use crate::io::scenario::Scenario;
use crate::planning::design::objectives::median;
use crate::planning::excitation::{excitation, Excitation, EXCITE_COILS, MAX_EXCITE_STEPS};
use crate::planning::plan::PlanSettings;
use crate::text::printable;
use serde::Serialize;
use std::io::Write;
use std::path::Path;

/// What `plan --excite` was asked: the steps after the first set and the seed of the draws.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct ExciteJob {
    /// The steps after the first set.
    pub steps: usize,
    /// The seed the sets are drawn from.
    pub seed: u64,
}

/// Checks the steps asked of an excitation run (`--excite`): 1 to [`MAX_EXCITE_STEPS`].
///
/// # Errors
/// Any other count, naming the flag.
pub fn check_steps(steps: usize) -> Result<usize> {
    match (1..=MAX_EXCITE_STEPS).contains(&steps) {
        true => Ok(steps),
        false => Err(Error::Arg {
            arg: "--excite".into(),
            expected: format!("1 to {MAX_EXCITE_STEPS} steps, got {steps}"),
        }),
    }
}

/// The summary of an excitation run (`plan --excite --json`).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct ExciteSummary {
    /// The steps after the first set.
    pub steps: usize,
    /// The seed the sets were drawn from.
    pub seed: u64,
    /// The sets drawn (and settled) to choose them.
    pub draws: usize,
    /// The median of the steps' rotation angles (the whole rotation of each step), degrees.
    pub median_step_deg: f64,
    /// The largest step's rotation angle, degrees.
    pub max_step_deg: f64,
    /// The longest predicted settle time of a step, s.
    pub max_settle_time_s: f64,
}

impl ExciteSummary {
    /// The summary of `e`, drawn for `job`.
    pub fn of(e: &Excitation, job: ExciteJob) -> ExciteSummary {
        let turns: Vec<f64> = (e.rows.windows(2))
            .map(|w| w[0].q.angle_to(&w[1].q).to_degrees())
            .collect();
        ExciteSummary {
            steps: job.steps,
            seed: job.seed,
            draws: e.draws,
            median_step_deg: median(&turns),
            max_step_deg: turns.iter().copied().fold(0.0, f64::max),
            max_settle_time_s: (e.rows.iter().map(|r| r.settle_time_s)).fold(0.0, f64::max),
        }
    }
}

/// `spherestep plan --excite`: draws the run from the settings' start, writes its plan CSV
/// (atomically) to `out_file` when asked and the summary to `out`; without `out_file` (and
/// without `json`) the CSV alone goes to `out` and the summary to `note`.
///
/// # Errors
/// No run within the supply and the on-time limit ([`Error::Excite`]), or the output cannot be
/// written.
pub fn excite_command(
    sc: &Scenario,
    settings: &PlanSettings,
    job: ExciteJob,
    out_file: Option<&Path>,
    json: bool,
    out: &mut dyn Write,
    note: &mut dyn Write,
) -> Result<Excitation> {
    let e = excitation(&sc.motor(), settings, job.steps, job.seed)?;
    let mut csv = Vec::new();
    write_plan(&e.rows, &mut csv)?;
    let out = emit_csv(&csv, out_file, json, out, note)?;
    let s = ExciteSummary::of(&e, job);
    let w = |e| Error::io("<stdout>", e);
    let text = match json {
        true => serde_json::to_string(&s).map_err(|e| Error::json("the excitation summary", e))?,
        false => format!(
            "{}: an excitation run of {} steps, random sets of {}-{} coils (seed {}, {} drawn): \
             steps of {:.2} deg (median), {:.2} at most; settles within {:.2} s. Replay it with \
             a sensor and --log, then fit the log (`spherestep fit SCENARIO --log LOG`)",
            printable(&sc.name),
            s.steps,
            EXCITE_COILS.0,
            EXCITE_COILS.1.min(settings.limits.max_coils_on),
            s.seed,
            s.draws,
            s.median_step_deg,
            s.max_step_deg,
            s.max_settle_time_s,
        ),
    };
    writeln!(out, "{text}").map_err(w)?;
    Ok(e)
}
