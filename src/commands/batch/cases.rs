//! The cases of a batch job: one plan for a plain scenario, one per combination of a sweep's
//! models, schemes, angles and axes (or random motions); computing them in parallel, and a
//! sweep case's CSV row.

use super::progress::{append_progress, start_progress};
use super::{BatchOptions, Job, SWEEP_HEADER};
use crate::error::{Error, Result};
use crate::io::output::write_atomic;
use crate::io::planfile::write_plan;
use crate::io::scenario::Scenario;
use crate::physics::torque::MagnetTorques;
use crate::planning::commutation::{pivot_floor, StepModel};
use crate::planning::plan::{final_orientation_error_deg, max_path_deviation_deg, PlanRow};
use crate::planning::planner::{max_axis_error_deg, plan, total_settle_time, PlanSettings};
use crate::text::printable;
use rayon::prelude::*;
use std::path::Path;
use std::time::Instant;

/// One planning case of a scenario.
#[derive(Debug, Clone)]
pub(super) struct Case {
    pub(super) index: usize,
    pub(super) settings: PlanSettings,
}

/// The cases of a scenario, in their fixed order (models, schemes, angles, axes; or models,
/// schemes, motions).
pub(super) fn cases(sc: &Scenario) -> Vec<Case> {
    let Some(sw) = &sc.sweep else {
        return vec![Case {
            index: 0,
            settings: sc.plan.clone(),
        }];
    };
    let mut out = Vec::new();
    for &(model, pairs) in &sw.models {
        for &scheme in &sw.schemes {
            for m in &sw.motions {
                out.push(Case {
                    index: out.len(),
                    settings: PlanSettings {
                        axis: m.axis,
                        angle: m.angle,
                        start: m.start,
                        scheme,
                        model,
                        pairs,
                        ..sc.plan.clone()
                    },
                });
            }
            if !sw.motions.is_empty() {
                continue;
            }
            for &angle in &sw.angles {
                for axis in &sw.axes {
                    out.push(Case {
                        index: out.len(),
                        settings: PlanSettings {
                            axis: *axis,
                            angle,
                            scheme,
                            model,
                            pairs,
                            ..sc.plan.clone()
                        },
                    });
                }
            }
        }
    }
    out
}

pub(super) fn case_label(c: &Case) -> String {
    let s = &c.settings;
    match s.model {
        StepModel::Pivot => s.scheme.name().to_string(),
        StepModel::Dynamic => format!("{} (dynamic, {} pairs)", s.scheme.name(), s.pairs),
        StepModel::Coils => format!("{} (coil sets, {} coils)", s.scheme.name(), s.pairs),
    }
}

/// The result of one case.
pub(super) struct Outcome {
    /// The plan (empty for a sweep case taken from the progress file).
    pub(super) rows: Vec<PlanRow>,
    pub(super) reached: bool,
    pub(super) seconds: f64,
    /// The case's row of a sweep CSV.
    pub(super) record: Vec<String>,
    /// Writing the case's kept plan failed.
    pub(super) error: Option<Error>,
}

/// The columns of a case's sweep row that its settings fix: case, scheme, model,
/// pairs_per_step, the axis and the angle.
fn case_columns(c: &Case) -> [String; 8] {
    let s = &c.settings;
    [
        c.index.to_string(),
        s.scheme.name().to_string(),
        s.model.name().to_string(),
        s.pairs.to_string(),
        s.axis.x.to_string(),
        s.axis.y.to_string(),
        s.axis.z.to_string(),
        s.angle.0.to_degrees().to_string(),
    ]
}

pub(super) fn sweep_record(c: &Case, o: &Outcome, torques: &MagnetTorques) -> Vec<String> {
    let s = &c.settings;
    let mut record = case_columns(c).to_vec();
    record.extend([
        o.rows.len().saturating_sub(1).to_string(),
        o.rows
            .last()
            .map(|r| r.cum_angle_deg)
            .unwrap_or(0.0)
            .to_string(),
        max_axis_error_deg(&o.rows).to_string(),
        max_path_deviation_deg(s, &o.rows).to_string(),
        o.reached.to_string(),
        total_settle_time(&o.rows).to_string(),
        pivot_floor(torques, &s.axis).0.to_degrees().to_string(),
    ]);
    record.extend(start_columns(c));
    record.push(final_orientation_error_deg(s, &o.rows).to_string());
    record
}

/// Where a sweep row's start columns begin (after pivot_floor_deg).
const START_COLUMN: usize = 15;

/// A sweep row's `steps` column.
const STEPS_COLUMN: usize = 8;

/// A sweep row's `reached` column.
const REACHED_COLUMN: usize = 12;

/// A sweep row's columns that hold a number (not a whole one): final_angle_deg,
/// max_axis_error_deg, max_path_deviation_deg, total_settle_time_s, pivot_floor_deg and
/// final_orientation_error_deg.
const NUMBER_COLUMNS: [usize; 6] = [9, 10, 11, 13, 14, START_COLUMN + 4];

/// The columns of a case's sweep row that its start fixes: start_qx, start_qy, start_qz,
/// start_qw.
fn start_columns(c: &Case) -> [String; 4] {
    let q = &c.settings.start;
    [q.i, q.j, q.k, q.w].map(|x| x.to_string())
}

/// What is wrong with `record` as case `c`'s row of a sweep CSV (as [`sweep_record`] writes
/// it), if anything: the columns its settings fix must be those, the others numbers (`steps`
/// a whole one) and `reached` true or false.
pub(super) fn sweep_row_problem(c: &Case, record: &[String]) -> Option<String> {
    let got = |k: usize| format!("got \"{}\"", printable(&record[k]));
    if record.len() != SWEEP_HEADER.len() {
        return Some(format!(
            "expected {} columns, got {}",
            SWEEP_HEADER.len(),
            record.len()
        ));
    }
    let fixed: Vec<(usize, String)> = case_columns(c)
        .into_iter()
        .enumerate()
        .chain((START_COLUMN..).zip(start_columns(c)))
        .collect();
    for &(k, ref want) in &fixed {
        if record[k] != *want {
            return Some(format!(
                "column `{}`: expected {want} (case {}), {}",
                SWEEP_HEADER[k],
                c.index,
                got(k)
            ));
        }
    }
    if record[STEPS_COLUMN].parse::<usize>().is_err() {
        return Some(format!(
            "column `steps`: expected a whole number, {}",
            got(STEPS_COLUMN)
        ));
    }
    if let Some(k) = NUMBER_COLUMNS
        .into_iter()
        .find(|&k| record[k].parse::<f64>().is_err())
    {
        return Some(format!(
            "column `{}`: expected a number, {}",
            SWEEP_HEADER[k],
            got(k)
        ));
    }
    if !matches!(record[REACHED_COLUMN].as_str(), "true" | "false") {
        return Some(format!(
            "column `reached`: expected true or false, {}",
            got(REACHED_COLUMN)
        ));
    }
    None
}

/// Writes a kept plan of a sweep case (`[sweep] keep_plans`).
pub(super) fn write_kept_plan(job: &Job, c: &Case, rows: &[PlanRow], out: &Path) -> Result<()> {
    let mut buf = Vec::new();
    write_plan(rows, &mut buf)?;
    let p = out.join(&job.name).join(format!(
        "case-{}-{}-{}{}.csv",
        c.index,
        c.settings.scheme.name(),
        c.settings.model.name(),
        c.settings.pairs
    ));
    write_atomic(&p, &buf)
}

/// Whether a job saves its sweep's cases as they end (and `--resume` takes them back): a
/// sweep's pictures of one axis draw every case's plan, so those need them all computed.
pub(super) fn saves_progress(job: &Job, opts: &BatchOptions) -> bool {
    job.scenario
        .sweep
        .as_ref()
        .is_some_and(|sw| !(opts.plots && sw.axes.len() == 1))
}

/// Computes a job's cases (those of a sweep saved in its progress file, `job.saved`, are
/// taken from there), saving each sweep case's row as it ends.
pub(super) fn run_cases(
    job: &Job,
    opts: &BatchOptions,
    bar: &indicatif::ProgressBar,
) -> Vec<Outcome> {
    let keep_plans = job.scenario.sweep.as_ref().is_some_and(|sw| sw.keep_plans);
    let done = &job.saved;
    let progress = if saves_progress(job, opts) {
        start_progress(job, done)
    } else {
        None
    };
    job.cases
        .par_iter()
        .map(|case| {
            if let Some(record) = done.get(&case.index) {
                bar.inc(1);
                return Outcome {
                    rows: Vec::new(),
                    reached: record.get(REACHED_COLUMN).is_some_and(|r| r == "true"),
                    seconds: 0.0,
                    record: record.clone(),
                    error: None,
                };
            }
            let t = Instant::now();
            let p = plan(&job.scenario.motor(), &case.settings);
            let mut o = Outcome {
                rows: p.rows,
                reached: p.reached,
                seconds: t.elapsed().as_secs_f64(),
                record: Vec::new(),
                error: None,
            };
            o.record = sweep_record(case, &o, &job.scenario.torques);
            if keep_plans {
                o.error = write_kept_plan(job, case, &o.rows, &opts.out).err();
            }
            if let (Some(f), None) = (&progress, &o.error) {
                append_progress(f, &job.hash, &o.record);
            }
            bar.inc(1);
            o
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_column_indices_name_their_columns() {
        assert_eq!(SWEEP_HEADER[STEPS_COLUMN], "steps");
        assert_eq!(SWEEP_HEADER[REACHED_COLUMN], "reached");
        assert_eq!(SWEEP_HEADER[START_COLUMN], "start_qx");
        let numbers = NUMBER_COLUMNS.map(|k| SWEEP_HEADER[k]);
        assert_eq!(
            numbers,
            [
                "final_angle_deg",
                "max_axis_error_deg",
                "max_path_deviation_deg",
                "total_settle_time_s",
                "pivot_floor_deg",
                "final_orientation_error_deg"
            ]
        );
    }
}
