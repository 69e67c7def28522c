//! `spherestep plan --waypoints`: one motion through a file of waypoints (the plan CSV with
//! the waypoint columns and a summary), and the check `simulate` makes of such a plan: where
//! the simulated ball ends against each waypoint.

use crate::error::{Error, Result};
use crate::io::output::emit_csv;
use crate::io::planfile::{waypoint_ends, write_waypoint_plan, Serves};
use crate::io::scenario::Scenario;
use crate::io::waypoints::read_waypoints;
use crate::planning::plan::PlanSettings;
use crate::planning::simulate::SimRow;
use crate::planning::waypoints::{plan_waypoints_with, WaypointPlan};
use crate::text::printable;
use serde::Serialize;
use std::io::Write;
use std::path::Path;

/// What `plan --waypoints` was asked: the waypoints file and the tolerance (degrees) every
/// waypoint must be reached within.
#[derive(Debug, Clone, Copy)]
pub struct WaypointJob<'a> {
    /// The waypoints file (CSV).
    pub file: &'a Path,
    /// How near each waypoint must be reached, degrees.
    pub tolerance_deg: f64,
}

/// Checks a waypoint tolerance given on the command line (`--tolerance-deg`): finite, > 0 and
/// at most 90 degrees.
///
/// # Errors
/// Any other value, naming the flag.
pub fn check_tolerance(deg: f64) -> Result<f64> {
    match deg.is_finite() && deg > 0.0 && deg <= 90.0 {
        true => Ok(deg),
        false => Err(Error::Arg {
            arg: "--tolerance-deg".into(),
            expected: format!(
                "a tolerance in (0, 90] degrees, got {}",
                crate::text::shown(deg)
            ),
        }),
    }
}

/// `spherestep plan --waypoints`: reads the waypoints (turns count from the settings' start),
/// plans the motion through them, writes the CSV (atomically) to `out_file` when asked and the
/// summary to `out`; without `out_file` (and without `json`) the CSV alone goes to `out` and
/// the summary to `note`.
///
/// # Errors
/// The waypoints file cannot be read or is malformed (the error names the file, line and
/// column), or the output cannot be written.
pub fn plan_waypoints_command(
    sc: &Scenario,
    settings: &PlanSettings,
    job: WaypointJob,
    out_file: Option<&Path>,
    json: bool,
    out: &mut dyn Write,
    note: &mut dyn Write,
) -> Result<WaypointPlan> {
    let waypoints = read_waypoints(job.file, &settings.start)?;
    // a progress bar on standard error (drawn only when it is a terminal): waypoints served
    let bar = crate::commands::styled(
        indicatif::ProgressBar::new(waypoints.len() as u64),
        "{bar:40} {pos}/{len} waypoints, {elapsed}",
    );
    let p = plan_waypoints_with(
        &sc.motor(),
        settings,
        &waypoints,
        job.tolerance_deg,
        &mut |k| bar.set_position(k as u64),
    );
    bar.finish_and_clear();
    let mut csv = Vec::new();
    write_waypoint_plan(&p, &mut csv)?;
    let out = emit_csv(&csv, out_file, json, out, note)?;
    let s = p.summary(settings, job.tolerance_deg);
    let w = |e| Error::io("<stdout>", e);
    if json {
        let text =
            serde_json::to_string(&s).map_err(|e| Error::json("the waypoint plan summary", e))?;
        return writeln!(out, "{text}").map_err(w).map(|()| p);
    }
    let mut text = format!(
        "{}: {} waypoints in {} steps ({} model, {} {}, {}): worst waypoint {:.2} deg from its \
         orientation (tolerance {:.2}), worst axis error {:.2} deg, path deviation {:.2} deg, {}",
        printable(&sc.name),
        waypoints.len(),
        s.steps,
        s.model,
        settings.pairs,
        settings.model.unit(),
        s.scheme,
        s.worst_waypoint_error_deg,
        job.tolerance_deg,
        s.max_axis_error_deg,
        s.max_path_deviation_deg,
        if s.reached { "reached" } else { "NOT reached" }
    );
    if let Some(m) = &p.message {
        text.push_str(&format!(": {m}"));
    }
    writeln!(out, "{text}").map_err(w)?;
    for r in &s.waypoints {
        writeln!(
            out,
            "  waypoint {}: step {}, {:.2} deg from it, path deviation {:.2} deg",
            r.waypoint, r.step, r.error_deg, r.max_path_deviation_deg
        )
        .map_err(w)?;
    }
    Ok(p)
}

/// Where a simulated replay of a waypoint plan leaves the ball against one waypoint.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct WaypointCheck {
    /// The waypoint, 1, 2, ...
    pub waypoint: usize,
    /// The last step serving it.
    pub step: usize,
    /// The angle from the simulated orientation after that step to the waypoint, degrees.
    pub error_deg: f64,
}

/// The JSON summary of `simulate` for a plan through waypoints: the simulation's figures and
/// where the simulated ball is at each waypoint.
#[derive(Debug, Clone, Serialize)]
pub struct SimulatedWaypoints<'a> {
    /// The simulation's figures, as `simulate` reports them.
    #[serde(flatten)]
    pub simulation: &'a crate::planning::simulate::SimSummary,
    /// Where the simulated ball is at each waypoint.
    pub waypoints: &'a [WaypointCheck],
}

/// Each waypoint of a plan (`serves`, row by row, from the plan file) against the simulated
/// rows: the simulated orientation after the last step serving it.
pub fn check_waypoints(serves: &[Serves], sim: &[SimRow]) -> Vec<WaypointCheck> {
    waypoint_ends(serves)
        .into_iter()
        .filter_map(|k| {
            let (w, q) = &serves[k];
            sim.get(k).map(|row| WaypointCheck {
                waypoint: *w,
                step: row.step,
                error_deg: row.q.angle_to(q).to_degrees(),
            })
        })
        .collect()
}
