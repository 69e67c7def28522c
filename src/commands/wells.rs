//! `spherestep wells`: a scenario's well as a bench would measure it, the torque on one magnet
//! as it passes one energised coil against the angle between them, written as a CSV in the
//! `table` format (`angle_deg,torque_nm`, from 0 to the cut-off) that a measurement can be
//! compared with and a `shape = "table"` scenario reads back, with its picture and a summary.

use crate::error::{printable, shown, Error, Result};
use crate::figures::{write_figure, WellPlot};
use crate::io::output::{check_not_input, emit_csv};
use crate::io::scenario::Scenario;
use crate::io::table::csv_bytes;
use crate::physics::torque::Well;
use serde::Serialize;
use std::io::Write;
use std::path::{Path, PathBuf};

/// The default angle step of the curve, degrees: read back as a table (linear interpolation),
/// the prototype's gaussian well is then within 1e-6 N m of itself (0.02 deg is 3.5e-4 rad,
/// and g'' h^2 / 8 with |g''| <= 50 N m / rad^2).
pub const DEFAULT_STEP_DEG: f64 = 0.02;

/// The finest angle step of a curve, degrees: a cut-off of at most 180 degrees then gives at
/// most 180,001 rows (a few MB of CSV), 20 times finer than the default.
pub const MIN_STEP_DEG: f64 = 0.001;
/// The coarsest angle step of a curve, degrees.
pub const MAX_STEP_DEG: f64 = 10.0;

/// The torque curve of a well: (angle, deg; torque, N m) from 0 to the cut-off, both included,
/// the step in [`MIN_STEP_DEG`, `MAX_STEP_DEG`].
pub fn well_curve(well: &Well, step_deg: f64) -> Result<Vec<(f64, f64)>> {
    if !(step_deg.is_finite() && (MIN_STEP_DEG..=MAX_STEP_DEG).contains(&step_deg)) {
        return Err(Error::Arg {
            arg: "--step-deg".into(),
            expected: format!(
                "an angle step in [{MIN_STEP_DEG}, {MAX_STEP_DEG}] degrees, got {}",
                shown(step_deg)
            ),
        });
    }
    // the cut-off in the degrees it was given in (radians and back lose the last bit)
    let end = (well.max_attraction().0.to_degrees() * 1e9).round() / 1e9;
    let n = (end / step_deg).ceil().max(1.0) as usize;
    Ok((0..=n)
        .map(|i| {
            let deg = end * i as f64 / n as f64;
            (deg, well.passing_torque(deg.to_radians()))
        })
        .collect())
}

/// What `wells` reports of a curve.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct WellSummary {
    pub rows: usize,
    /// The strongest pull and where it is.
    pub peak_torque_nm: f64,
    pub peak_angle_deg: f64,
    /// The pull just inside the cut-off (what is lost at once beyond it).
    pub cutoff_deg: f64,
    pub cutoff_torque_nm: f64,
    /// dg/dd at 0: how hard one aligned magnet is held, N m / rad.
    pub stiffness_nm_per_rad: f64,
    /// Half the peak pull, reached first and last at these angles (the well's width).
    pub half_peak_from_deg: f64,
    pub half_peak_to_deg: f64,
}

/// The summary of a curve of `well`.
pub fn summarise(well: &Well, curve: &[(f64, f64)]) -> WellSummary {
    let peak = curve.iter().copied().fold(
        (0.0, f64::NEG_INFINITY),
        |a, p| if p.1 > a.1 { p } else { a },
    );
    let half: Vec<f64> = curve
        .iter()
        .filter(|p| p.1 >= 0.5 * peak.1)
        .map(|p| p.0)
        .collect();
    let last = curve.last().copied().unwrap_or((0.0, 0.0));
    WellSummary {
        rows: curve.len(),
        peak_torque_nm: peak.1,
        peak_angle_deg: peak.0,
        cutoff_deg: last.0,
        cutoff_torque_nm: last.1,
        stiffness_nm_per_rad: well.stiffness(),
        half_peak_from_deg: half.first().copied().unwrap_or(0.0),
        half_peak_to_deg: half.last().copied().unwrap_or(0.0),
    }
}

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
            check_not_input(p, &sc.files)?;
        }
    }
    let well = &sc.torques.well;
    let curve = well_curve(well, step_deg)?;
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
