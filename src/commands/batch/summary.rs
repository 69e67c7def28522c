//! summary.csv: one row per scenario of a batch, built from the result files (so that a run
//! merged from shard parts gives the same summary as one run).

use super::{BatchReport, SUMMARY_HEADER};
use crate::error::{Error, Result};
use crate::io::planfile::parse_plan;
use crate::io::scenario::{Scenario, Sweep};
use crate::io::table::{csv_bytes, Table};
use crate::model::geometry::UnitVec;
use crate::planning::plan::{final_orientation_error_deg, max_path_deviation_deg, PlanRow};
use crate::planning::planner::{max_axis_error_deg, total_settle_time};
use std::path::{Path, PathBuf};

pub(super) fn axis_text(a: &UnitVec) -> String {
    format!("{:.4};{:.4};{:.4}", a.x, a.y, a.z)
}

/// summary.csv, built from the output files (so that a merged run gives the same summary).
pub(super) fn summary_csv(inputs: &[PathBuf], out: &Path, report: &BatchReport) -> Result<String> {
    let failed: Vec<String> = report.failed.iter().map(|f| f.0.clone()).collect();
    let mut records = Vec::new();
    for file in inputs {
        if failed.contains(&file.display().to_string()) {
            continue;
        }
        let Ok(sc) = Scenario::load(file) else {
            continue;
        };
        let csv = out.join(format!("{}.csv", sc.name));
        let Ok(text) = crate::io::input::read_text(&csv) else {
            continue;
        };
        records.push(match &sc.sweep {
            None => plan_summary(&sc, &parse_plan(&text, &csv)?),
            Some(sw) => sweep_summary(&sc, sw, &Table::parse(&text, &csv)?)?,
        });
    }
    let what = out.join("summary.csv").display().to_string();
    let bytes = csv_bytes(&what, &SUMMARY_HEADER, records)?;
    String::from_utf8(bytes).map_err(|e| Error::io(what, std::io::Error::other(e)))
}

/// The summary row of a plain scenario's plan.
fn plan_summary(sc: &Scenario, rows: &[PlanRow]) -> Vec<String> {
    let s = &sc.plan;
    let fin = rows.last().map(|r| r.cum_angle_deg).unwrap_or(0.0);
    // as `plan` judges it: the angle turned, and the end within the tolerance of the target
    // orientation
    let turned = fin >= (s.angle.0 - s.angle_tolerance.0).to_degrees();
    let reached = turned && final_orientation_error_deg(s, rows) <= s.tolerance.0.to_degrees();
    vec![
        sc.name.clone(),
        "plan".into(),
        "1".into(),
        axis_text(&s.axis),
        s.angle.0.to_degrees().to_string(),
        s.scheme.name().into(),
        s.model.name().into(),
        s.pairs.to_string(),
        rows.len().saturating_sub(1).to_string(),
        fin.to_string(),
        max_axis_error_deg(rows).to_string(),
        max_path_deviation_deg(s, rows).to_string(),
        reached.to_string(),
        total_settle_time(rows).to_string(),
    ]
}

/// The summary row of a sweep: its cases' steps and settle times summed, the smallest final
/// angle, the worst axis error, the worst path deviation and how many reached their target.
fn sweep_summary(sc: &Scenario, sw: &Sweep, t: &Table) -> Result<Vec<String>> {
    let col = |name: &str| t.require(name, "");
    let [steps_c, final_c, worst_c, deviation_c, reached_c, settle_c] = [
        col("steps")?,
        col("final_angle_deg")?,
        col("max_axis_error_deg")?,
        col("max_path_deviation_deg")?,
        col("reached")?,
        col("total_settle_time_s")?,
    ];
    let (mut n, mut reached, mut steps) = (0usize, 0usize, 0usize);
    let (mut worst, mut settle, mut min_final) = (0.0f64, 0.0f64, f64::INFINITY);
    let mut deviation = 0.0f64;
    for r in t.rows() {
        let num = |k: usize| r.get(k).parse::<f64>().unwrap_or(0.0);
        n += 1;
        steps += num(steps_c) as usize;
        min_final = min_final.min(num(final_c));
        worst = worst.max(num(worst_c));
        deviation = deviation.max(num(deviation_c));
        reached += usize::from(r.get(reached_c) == "true");
        settle += num(settle_c);
    }
    let join = |v: Vec<String>| v.join(";");
    Ok(vec![
        sc.name.clone(),
        "sweep".into(),
        n.to_string(),
        match sw.motions.is_empty() {
            true => format!("{} axes", sw.axes.len()),
            false => format!("{} random motions", sw.motions.len()),
        },
        match sw.motions.is_empty() {
            true => join(
                sw.angles
                    .iter()
                    .map(|a| a.0.to_degrees().to_string())
                    .collect(),
            ),
            false => {
                let deg = sw.angles.iter().map(|a| a.0.to_degrees());
                let lo = deg.clone().fold(f64::INFINITY, f64::min);
                format!("{lo}-{}", deg.fold(0.0, f64::max))
            }
        },
        join(sw.schemes.iter().map(|s| s.name().to_string()).collect()),
        join(sw.models.iter().map(|m| m.0.name().to_string()).collect()),
        join(sw.models.iter().map(|m| m.1.to_string()).collect()),
        steps.to_string(),
        if n == 0 {
            "0".into()
        } else {
            min_final.to_string()
        },
        worst.to_string(),
        deviation.to_string(),
        format!("{reached}/{n}"),
        settle.to_string(),
    ])
}
