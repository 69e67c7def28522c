//! A well as a bench would measure it: the torque on one magnet as it passes one energised
//! coil against the angle between them, from 0 to the cut-off, and what a summary says of it
//! (the peak pull, the width, the stiffness). What `spherestep wells` and
//! [`crate::Motor::wells`] compute.

use crate::physics::torque::Well;
use crate::text::shown;
use serde::Serialize;

/// The default angle step of the curve, degrees: read back as a table (linear interpolation),
/// the prototype's gaussian well is then within 1e-6 N m of itself (0.02 deg is 3.5e-4 rad,
/// and g'' h^2 / 8 with |g''| <= 50 N m / rad^2).
pub const DEFAULT_STEP_DEG: f64 = 0.02;

/// The finest angle step of a curve, degrees: a cut-off of at most 180 degrees then gives at
/// most 180,001 rows (a few MB of CSV), 20 times finer than the default.
pub const MIN_STEP_DEG: f64 = 0.001;
/// The coarsest angle step of a curve, degrees.
pub const MAX_STEP_DEG: f64 = 10.0;

/// A curve's angle step that is not allowed: the crate's `Error` gathers it as its `Input`
/// about `step_deg` (`Input::WellStep`), with the same message.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("`step_deg`: expected {expected}")]
pub struct StepError {
    /// What the step may be.
    pub expected: String,
}

/// The torque curve of a well: (angle, deg; torque, N m) from 0 to the cut-off, both included,
/// the step in [`MIN_STEP_DEG`, `MAX_STEP_DEG`].
pub fn well_curve(well: &Well, step_deg: f64) -> Result<Vec<(f64, f64)>, StepError> {
    if !(step_deg.is_finite() && (MIN_STEP_DEG..=MAX_STEP_DEG).contains(&step_deg)) {
        return Err(StepError {
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
    /// The curve's rows (angles sampled).
    pub rows: usize,
    /// The strongest pull and where it is.
    pub peak_torque_nm: f64,
    /// The angle of the strongest pull, degrees.
    pub peak_angle_deg: f64,
    /// The pull just inside the cut-off (what is lost at once beyond it).
    pub cutoff_deg: f64,
    /// The pull at [`WellSummary::cutoff_deg`], N m.
    pub cutoff_torque_nm: f64,
    /// dg/dd at 0: how hard one aligned magnet is held, N m / rad.
    pub stiffness_nm_per_rad: f64,
    /// Half the peak pull, reached first and last at these angles (the well's width).
    pub half_peak_from_deg: f64,
    /// The last angle of half the peak pull, degrees.
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
