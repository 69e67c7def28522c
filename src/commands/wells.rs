//! `spherestep wells`: a scenario's well as a bench would measure it, the torque on one magnet
//! as it passes one energised coil against the angle between them, written as a CSV in the
//! `table` format (`angle_deg,torque_nm`, from 0 to the cut-off) that a measurement can be
//! compared with and a `shape = "table"` scenario reads back, with its picture and a summary.

use crate::commands::args::{as_flag, check_out};
use crate::error::{Error, Input, Result};
use crate::figures::{write_figure, WellPlot};
use crate::io::output::emit_csv;
use crate::io::scenario::Scenario;
use crate::io::table::csv_bytes;
use crate::physics::torque::Well;
pub use crate::physics::well_curve::{
    summarise, well_curve, WellSummary, DEFAULT_STEP_DEG, MAX_STEP_DEG, MIN_STEP_DEG,
};
use crate::text::printable;
use std::io::Write;
use std::path::{Path, PathBuf};

/// The curve as CSV bytes, in the `table` format (numbers in their shortest exact form).
pub fn curve_csv(curve: &[(f64, f64)]) -> Result<Vec<u8>> {
    csv_bytes(
        "the well curve",
        &["angle_deg", "torque_nm"],
        curve
            .iter()
            .map(|(a, g)| vec![a.to_string(), g.to_string()]),
    )
}

/// The curve and, for the picture, a little of what lies beyond the cut-off (up to 15% of it
/// further, at most 180 degrees): the drop there.
fn with_beyond(well: &Well, curve: &[(f64, f64)]) -> Vec<(f64, f64)> {
    let mut points = curve.to_vec();
    let (Some(&(end, _)), Some(&(step, _))) = (curve.last(), curve.get(1)) else {
        return points;
    };
    let stop = (end * 1.15).min(180.0);
    let mut k = 1.0;
    while end + k * step <= stop {
        let deg = end + k * step;
        points.push((deg, well.passing_torque(deg.to_radians())));
        k += 1.0;
    }
    points
}

/// Where the picture of a curve written to `csv` goes: the same path without `.csv`.
pub fn picture_stem(csv: &Path) -> PathBuf {
    match csv.extension() {
        Some(e) if e.eq_ignore_ascii_case("csv") => csv.with_extension(""),
        _ => csv.to_path_buf(),
    }
}

/// `spherestep wells`: the scenario's curve to `out_file` (atomically; with its picture,
/// `STEM.svg` and `STEM.png`) or alone to `out`, and the summary (text, or JSON) to `out`, or
/// to `note` when the CSV took `out`.
pub fn wells_command(
    sc: &Scenario,
    step_deg: f64,
    out_file: Option<&Path>,
    json: bool,
    out: &mut dyn Write,
    note: &mut dyn Write,
) -> Result<WellSummary> {
    if let Some(path) = out_file {
        // the CSV and its pictures must not replace what the scenario was read from (its
        // table, say)
        let stem = picture_stem(path).into_os_string();
        let pictures = ["svg", "png"].map(|e| {
            let mut p = stem.clone();
            p.push(format!(".{e}"));
            PathBuf::from(p)
        });
        for p in std::iter::once(path).chain(pictures.iter().map(PathBuf::as_path)) {
            check_out(p, &sc.files)?;
        }
    }
    let well = &sc.torques.well;
    let curve =
        well_curve(well, step_deg).map_err(|e| as_flag(e.into(), Input::WellStep, "--step-deg"))?;
    let csv = curve_csv(&curve)?;
    let out = emit_csv(&csv, out_file, json, out, note)?;
    let mut pictures = Vec::new();
    if let Some(path) = out_file {
        let fig = WellPlot {
            title: format!(
                "{}: torque on one magnet passing one coil",
                printable(&sc.name)
            ),
            points: with_beyond(well, &curve),
            cutoff_deg: curve.last().map(|p| p.0),
        };
        pictures = write_figure(&fig, &picture_stem(path))?;
    }
    let s = summarise(well, &curve);
    let w = |e| Error::io("<stdout>", e);
    if json {
        let text = serde_json::to_string(&s).map_err(|e| Error::json("the well summary", e))?;
        writeln!(out, "{text}").map_err(w)?;
    } else {
        writeln!(
            out,
            "{}: peak pull {:.4} N m at {:.2} deg, half of it from {:.2} to {:.2} deg, \
             {:.4} N m at the {:.2} deg cut-off, stiffness {:.4} N m/rad ({} rows)",
            printable(&sc.name),
            s.peak_torque_nm,
            s.peak_angle_deg,
            s.half_peak_from_deg,
            s.half_peak_to_deg,
            s.cutoff_torque_nm,
            s.cutoff_deg,
            s.stiffness_nm_per_rad,
            s.rows
        )
        .map_err(w)?;
        for p in pictures {
            writeln!(out, "wrote {}", p.display()).map_err(w)?;
        }
    }
    Ok(s)
}
