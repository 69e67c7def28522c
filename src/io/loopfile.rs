//! The results of a closed-loop (or open-loop, measured) run on a plant: one CSV row per step
//! with what was on, the planned, measured and true orientations, the true cumulative rotation
//! and the distance to the goal, and whether the rest was replanned.

use crate::error::Result;
use crate::io::table::{write_csv, Table};
use crate::model::geometry::{pairs_text, xyzw};
use crate::planning::closed_loop::LoopRow;
use std::io::Write;
use std::path::Path;

/// The header of a closed-loop results file.
pub const HEADER: [&str; 20] = [
    "step",
    "active",
    "replanned",
    "planned_qx",
    "planned_qy",
    "planned_qz",
    "planned_qw",
    "measured_qx",
    "measured_qy",
    "measured_qz",
    "measured_qw",
    "true_qx",
    "true_qy",
    "true_qz",
    "true_qw",
    "cum_angle_deg",
    "cum_axis_error_deg",
    "error_to_goal_deg",
    "settled",
    "settle_time_s",
];

/// Writes the rows (columns [`HEADER`]).
pub fn write_loop(rows: &[LoopRow], out: &mut dyn Write) -> Result<()> {
    let record = |r: &LoopRow| {
        let mut v = vec![
            r.step.to_string(),
            pairs_text(&r.active),
            r.replanned.to_string(),
        ];
        for q in [&r.planned, &r.measured, &r.truth] {
            v.extend(xyzw(q).iter().map(|c| c.to_string()));
        }
        v.extend([
            r.cum_angle_deg.to_string(),
            r.cum_axis_error_deg.to_string(),
            r.error_to_goal_deg.to_string(),
            r.settled.to_string(),
            r.settle_time_s.to_string(),
        ]);
        v
    };
    write_csv(
        out,
        "<closed-loop output>",
        &HEADER,
        rows.iter().map(record),
    )
}

/// What a run file's pictures need, read back: per row the step, the true distance to the goal
/// and cumulative angle (degrees) and whether it was replanned after.
pub fn parse_loop(text: &str, path: &Path) -> Result<Vec<(usize, f64, f64, bool)>> {
    let t = Table::parse(text, path)?;
    t.require_rows("step")?;
    let hint = " (a file written by `spherestep run` or `simulate --closed-loop`)";
    let cols = [
        t.require("step", hint)?,
        t.require("error_to_goal_deg", hint)?,
        t.require("cum_angle_deg", hint)?,
        t.require("replanned", hint)?,
    ];
    t.rows()
        .map(|r| {
            let replanned = match r.get(cols[3]) {
                "true" => true,
                "false" => false,
                other => {
                    return Err(r.error(format!(
                        "column `replanned`: expected true or false, got '{other}'"
                    )))
                }
            };
            Ok((
                r.step(cols[0])?,
                r.finite(cols[1], "error_to_goal_deg")?,
                r.finite(cols[2], "cum_angle_deg")?,
                replanned,
            ))
        })
        .collect()
}
