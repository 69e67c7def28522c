//! `spherestep run` (plan a motion in one scenario's physics and play it on a plant, open or
//! closed loop) and `spherestep simulate PLAN --plant P --closed-loop` (the same from a plan
//! file): the per-step CSV and the summary.

use crate::error::{Error, Result};
use crate::io::loopfile::write_loop;
use crate::io::output::emit_csv;
use crate::io::planfile::read_plan;
use crate::io::scenario::Scenario;
use crate::planning::closed_loop::{run_closed_loop, LoopRun, LoopSettings};
pub use crate::planning::options::{default_max_steps, LoopOptions, MAX_SENSOR_NOISE_DEG};
use crate::planning::options::{LoopNames, LoopPlan, RowsFrom};
use crate::planning::plan::{PlanRow, PlanSettings};
use crate::planning::planner::plan;
use crate::text::printable;
use std::io::Write;
use std::path::Path;

/// Where a run's CSV and summary go: the CSV to `file` (atomically), else alone to `out`; the
/// summary (text, or JSON) to `out`, or to `note` when the CSV took `out`.
pub struct Report<'a> {
    /// The CSV's file (`None`: the CSV goes to `out`).
    pub file: Option<&'a Path>,
    /// Whether the summary is JSON (else text).
    pub json: bool,
    /// Standard output, or what stands for it.
    pub out: &'a mut dyn Write,
    /// Where the summary goes when the CSV took `out`.
    pub note: &'a mut dyn Write,
}

pub use crate::planning::options::RunSummary;

/// What the command line calls the loop's options.
pub const LOOP_OPTION_NAMES: LoopNames = LoopNames {
    noise_deg: "--sensor-noise-deg",
    max_steps: "--max-steps",
    motion: "--axis/--angle",
};

/// Checks the loop's options as the command line gives them ([`LoopOptions::check`]).
pub fn check_loop_options(o: &LoopOptions) -> Result<()> {
    Ok(o.check(&LOOP_OPTION_NAMES)?)
}

/// The loop's settings from the command line's options, checked ([`LoopOptions::settings`]).
pub fn loop_settings(o: &LoopOptions, planned_steps: usize) -> Result<LoopSettings> {
    Ok(o.settings(planned_steps, &LOOP_OPTION_NAMES)?)
}

/// `spherestep run`: plans in `sc` (the model) with `settings`, plays the plan on `plant` as
/// `o` says, and reports.
pub fn run_command(
    sc: &Scenario,
    plant: &Scenario,
    settings: &PlanSettings,
    o: &LoopOptions,
    report: Report,
) -> Result<RunSummary> {
    sc.check_same_packings(plant, "--plant")?;
    check_loop_options(o)?;
    let p = plan(&sc.motor(), settings);
    let lp = LoopPlan::planned(settings, p, &LOOP_OPTION_NAMES)?;
    play(sc, plant, &lp, o, report)
}

/// `spherestep simulate PLAN SCENARIO --plant PLANT --closed-loop`: the plan file's own
/// target (the rotation from its row 0 to its last row, the goal its last orientation), the
/// plan's model and limits from `settings` (the scenario's, with any command-line overrides).
pub fn simulate_closed_loop(
    sc: &Scenario,
    plant: &Scenario,
    settings: &PlanSettings,
    plan_path: &Path,
    o: &LoopOptions,
    report: Report,
) -> Result<RunSummary> {
    sc.check_same_packings(plant, "--plant")?;
    check_loop_options(o)?;
    let lp = plan_file_loop(sc, settings, read_plan(plan_path)?, plan_path)?;
    play(sc, plant, &lp, o, report)
}

/// The plan `rows` read from `plan_path` as the closed loop plays them in `sc`: their pairs
/// checked against the scenario, `settings` aimed at their own target ([`LoopPlan::of_rows`]).
pub fn plan_file_loop(
    sc: &Scenario,
    settings: &PlanSettings,
    rows: Vec<PlanRow>,
    plan_path: &Path,
) -> Result<LoopPlan> {
    super::check_plan_pairs(sc, &rows, plan_path)?;
    Ok(LoopPlan::of_rows(
        settings,
        rows,
        RowsFrom::File(plan_path),
    )?)
}

/// Plays `p` on the plant and reports.
fn play(
    sc: &Scenario,
    plant: &Scenario,
    lp: &LoopPlan,
    o: &LoopOptions,
    report: Report,
) -> Result<RunSummary> {
    let planned_steps = lp.planned_steps();
    let cl = loop_settings(o, planned_steps)?;
    let (s, p) = (&lp.settings, &lp.plan);
    let run: LoopRun = run_closed_loop(&sc.motor(), &plant.motor(), s, p, lp.goal, &cl);
    let mut csv = Vec::new();
    write_loop(&run.rows, &mut csv)?;
    let Report {
        file,
        json,
        out,
        note,
    } = report;
    let out = emit_csv(&csv, file, json, out, note)?;
    let summary = RunSummary::of(o, planned_steps, run.summary);
    let w = |e| Error::io("<stdout>", e);
    if json {
        let text =
            serde_json::to_string(&summary).map_err(|e| Error::json("the run summary", e))?;
        writeln!(out, "{text}").map_err(w)?;
    } else {
        let r = &summary.run;
        writeln!(
            out,
            "{} loop on {}: {} steps ({} planned), {} replans{}: {:.2} deg from the goal, \
             turned {:.2} deg, worst axis error {:.2} deg, path deviation {:.2} deg (measured), \
             {}{}",
            summary.mode,
            printable(&plant.name),
            r.steps,
            planned_steps,
            r.replans,
            match (&r.fitted, r.fitted_after_step) {
                (Some(name), Some(k)) => format!(", steered from step {k} with the fitted {name}"),
                _ => String::new(),
            },
            r.final_error_deg,
            r.final_angle_deg,
            r.max_axis_error_deg,
            r.max_path_deviation_deg,
            if r.reached { "reached" } else { "NOT reached" },
            r.message
                .as_deref()
                .map(|m| format!(": {m}"))
                .unwrap_or_default()
        )
        .map_err(w)?;
    }
    Ok(summary)
}
