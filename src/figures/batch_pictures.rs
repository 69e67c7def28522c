//! The pictures of a result: for a plan, the paper's Figure 5 (its initial commutation state),
//! Figure 6 (a 3-D view of its final state), its Figure 7/8 curve and its interactive page;
//! for a set of plans of one motion, one Figure 7/8 with a line per scheme; for a sweep, the
//! maps of the worst axis error. Built from scenarios and result files, drawn by the figures'
//! own modules.

use crate::error::Result;
use crate::figures::axis_error::{plan_series, AxisErrorPlot, ErrorSeries, ReferenceLine};
use crate::figures::commutation_plot::CommutationPlot;
use crate::figures::figure::write_figure;
use crate::figures::plot_csv::plot_csv_with_coils;
use crate::figures::view;
use crate::figures::view_3d::View3d;
use crate::io::scenario::Scenario;
use crate::model::geometry::{rotation_axis, UnitVec};
use crate::planning::commutation::{filter_candidates, ERROR_BOUND_START};
use crate::planning::plan::PlanRow;
use std::path::{Path, PathBuf};

/// The paper's bound for a scenario's motion, drawn as a reference line.
fn reference(sc: &Scenario) -> Option<ReferenceLine> {
    sc.report.reference_deg.map(|v| ReferenceLine {
        label: sc
            .report
            .reference_label
            .clone()
            .unwrap_or_else(|| format!("paper: {v} deg")),
        value_deg: v,
    })
}

/// Figure 7/8 of a scenario's motion: the given series against the paper's bound and the
/// target angle.
fn axis_error_plot(sc: &Scenario, series: Vec<ErrorSeries>) -> AxisErrorPlot {
    AxisErrorPlot {
        title: format!("{}: cumulative axis error vs rotation angle", sc.name),
        series,
        reference: reference(sc),
        target_deg: Some(sc.plan.angle.0.to_degrees()),
    }
}

fn arr(v: &nalgebra::Vector3<f64>) -> [f64; 3] {
    [v.x, v.y, v.z]
}

/// Figure 5: the plan's initial commutation state on X-Y: coils, the magnets of the bottom
/// hemisphere, the candidate pairs for the first step, the chosen (held) pairs boxed.
pub fn commutation_plot(
    sc: &Scenario,
    axis: &UnitVec,
    row0: &PlanRow,
    title: &str,
) -> CommutationPlot {
    let r = row0.q.to_rotation_matrix();
    let magnets = sc
        .torques
        .rotor
        .iter()
        .enumerate()
        .map(|(j, m)| (j, r * m))
        .filter(|(_, p)| p.z < 0.0)
        .map(|(j, p)| (j, [p.x, p.y]))
        .collect();
    let (cands, _) = filter_candidates(&sc.torques, &row0.q, axis, &row0.active, ERROR_BOUND_START);
    CommutationPlot {
        title: title.to_string(),
        coils: sc.torques.stator.iter().map(|s| [s.x, s.y]).collect(),
        magnets,
        candidates: cands.iter().map(|c| c.pair).collect(),
        chosen: row0.active.clone(),
    }
}

/// Figure 6: the ball at a plan row, with its active pairs, the desired axis and the actual
/// axis of the cumulative rotation so far.
pub fn view_3d(
    sc: &Scenario,
    axis: &UnitVec,
    row0: &PlanRow,
    row: &PlanRow,
    title: &str,
) -> View3d {
    let r = row.q.to_rotation_matrix();
    let cum = row.q * row0.q.inverse();
    View3d {
        title: title.to_string(),
        coils: sc.torques.stator.iter().map(arr).collect(),
        magnets: sc
            .torques
            .rotor
            .iter()
            .enumerate()
            .map(|(j, m)| (j, arr(&(r * m))))
            .collect(),
        active: row.active.clone(),
        desired_axis: arr(&axis.into_inner()),
        actual_axis: rotation_axis(&cum).map(|a| arr(&a.into_inner())),
    }
}

/// The pictures of one plan, `STEM-fig5`, `STEM-fig6`, `STEM-error` (SVG and PNG) and the page
/// `STEM.html`, in `dir`. Returns the files written.
pub fn plan_pictures(
    sc: &Scenario,
    axis: &UnitVec,
    label: &str,
    rows: &[PlanRow],
    dir: &Path,
    stem: &str,
) -> Result<Vec<PathBuf>> {
    let mut out = Vec::new();
    let (Some(first), Some(last)) = (rows.first(), rows.last()) else {
        return Ok(out);
    };
    let base = |s: &str| dir.join(format!("{stem}-{s}"));
    out.extend(write_figure(
        &commutation_plot(
            sc,
            axis,
            first,
            &format!("{}: initial commutation state", sc.name),
        ),
        &base("fig5"),
    )?);
    out.extend(write_figure(
        &view_3d(
            sc,
            axis,
            first,
            last,
            &format!("{}: final state, {} steps", sc.name, rows.len() - 1),
        ),
        &base("fig6"),
    )?);
    out.extend(write_figure(
        &axis_error_plot(sc, vec![plan_series(label, rows)]),
        &base("error"),
    )?);
    let page = dir.join(format!("{stem}.html"));
    let data = view::view_data(
        rows,
        &page,
        sc,
        &view::ViewOptions {
            axis: Some(*axis),
            sim: None,
            title: Some(format!("spherestep plan: {}", sc.name)),
        },
    )?;
    crate::io::output::write_atomic(&page, view::render_html(&data)?.as_bytes())?;
    out.push(page);
    Ok(out)
}

/// One Figure 7/8 for several plans of the same motion (a line each), `STEM-schemes`.
pub fn schemes_picture(
    sc: &Scenario,
    plans: &[(String, Vec<PlanRow>)],
    dir: &Path,
    stem: &str,
) -> Result<Vec<PathBuf>> {
    write_figure(
        &axis_error_plot(
            sc,
            plans.iter().map(|(n, rows)| plan_series(n, rows)).collect(),
        ),
        &dir.join(format!("{stem}-schemes")),
    )
}

/// The maps of a sweep CSV of scenario `sc`, one per scheme, with its coil directions.
pub fn sweep_pictures(sc: &Scenario, csv: &Path, dir: &Path) -> Result<Vec<PathBuf>> {
    let coils: Vec<[f64; 3]> = sc.torques.stator.iter().map(arr).collect();
    plot_csv_with_coils(csv, Some(dir), Some(&sc.name), &coils)
}
