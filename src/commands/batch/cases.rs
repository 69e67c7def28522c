//! The cases of a batch job: one plan for a plain scenario, one per combination of a sweep's
//! models, schemes, angles and axes; computing them in parallel, and a sweep case's CSV row.

use super::progress::{append_progress, read_progress, start_progress};
use super::{BatchOptions, Job};
use crate::error::{Error, Result};
use crate::io::output::write_atomic;
use crate::io::planfile::write_plan;
use crate::io::scenario::Scenario;
use crate::physics::torque::MagnetTorques;
use crate::planning::commutation::{pivot_floor, StepModel};
use crate::planning::plan::PlanRow;
use crate::planning::planner::{max_axis_error_deg, plan, total_settle_time, PlanSettings};
use rayon::prelude::*;
use std::collections::BTreeMap;
use std::path::Path;
use std::time::Instant;

/// One planning case of a scenario.
#[derive(Debug, Clone)]
pub(super) struct Case {
    pub(super) index: usize,
    pub(super) settings: PlanSettings,
}

/// The cases of a scenario, in their fixed order (models, schemes, angles, axes).
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

pub(super) fn sweep_record(c: &Case, o: &Outcome, torques: &MagnetTorques) -> Vec<String> {
    let s = &c.settings;
    vec![
        c.index.to_string(),
        s.scheme.name().to_string(),
        s.model.name().to_string(),
        s.pairs.to_string(),
        s.axis.x.to_string(),
        s.axis.y.to_string(),
        s.axis.z.to_string(),
        s.angle.0.to_degrees().to_string(),
        o.rows.len().saturating_sub(1).to_string(),
        o.rows
            .last()
            .map(|r| r.cum_angle_deg)
            .unwrap_or(0.0)
            .to_string(),
        max_axis_error_deg(&o.rows).to_string(),
        o.reached.to_string(),
        total_settle_time(&o.rows).to_string(),
        pivot_floor(torques, &s.axis).0.to_degrees().to_string(),
    ]
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

/// Computes a job's cases (those of a sweep found in its progress file with `--resume` are
/// taken from there), saving each sweep case's row as it ends.
pub(super) fn run_cases(
    job: &Job,
    opts: &BatchOptions,
    bar: &indicatif::ProgressBar,
) -> Vec<Outcome> {
    let keep_plans = job.scenario.sweep.as_ref().is_some_and(|sw| sw.keep_plans);
    // A sweep's pictures of one axis draw every case's plan: those need them all computed.
    let saves = job
        .scenario
        .sweep
        .as_ref()
        .is_some_and(|sw| !(opts.plots && sw.axes.len() == 1));
    let done = if saves && opts.resume {
        read_progress(&job.csv, &job.hash)
    } else {
        BTreeMap::new()
    };
    let progress = if saves {
        start_progress(job, &done)
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
                    reached: record.get(11).is_some_and(|r| r == "true"),
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
                append_progress(f, &o.record);
            }
            bar.inc(1);
            o
        })
        .collect()
}
