//! Fitting a physical scenario (`shape = "dipole"`) to a bench's torque curve: the core's gain
//! `core_gain` (a gain on the coil's field, so on every torque) and the gap `gap_m` (which moves
//! the peak and the reach), everything else as the scenario gives it (the magnet's shape and
//! size, the winding, its turns and current). Levenberg-Marquardt and the standard errors are
//! [`crate::planning::fit`]'s, on the logarithms of the two (so that both stay positive); each
//! trial gap builds the well as a scenario file builds it (a real parts' well tabulated once)
//! and evaluates [`Well::passing_torque`] at the curve's angles, as `spherestep wells` writes
//! the curve. The torque is linear in the gain (it multiplies the winding's ampere-turns), so
//! the well is built once per gap at a gain of 1 and scaled. The gain must stay at least 1 (the
//! scenario format's bound): where the curve asks for less, the gain is held at 1, the gap
//! fitted alone and the gain asked for reported.

use crate::model::geometry::Radians;
use crate::physics::magnetics::DipoleWell;
use crate::physics::real_parts::{MagnetShape, RealParts};
use crate::physics::torque::{Well, WellShape};
use crate::planning::fit::{curve_radians, levenberg_marquardt, Estimate, FitError, Solved};
use std::collections::BTreeMap;
use std::sync::Mutex;

/// The central-difference step of the Jacobian in the logarithms of the parameters: wide
/// enough that the well's table (whose cells follow the gap) is smooth across it (its
/// interpolation error, 1e-8 of the peak, moves the slope by 1e-4 at most).
pub const LOG_STEP: f64 = 1e-4;

/// The two physical parameters a curve fits.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct PartsValues {
    /// The core's gain on the coil's field (`magnets.core_gain`, at least 1).
    pub core_gain: f64,
    /// From the magnets' centres to the coil's loop, or its winding's face (`magnets.gap_m`), m.
    pub gap_m: f64,
}

/// A physical scenario's parts fitted to a torque curve.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct PartsFit {
    /// The scenario's own values, where the fit starts.
    pub start: PartsValues,
    /// The fitted values.
    pub fitted: PartsValues,
    /// `core_gain` and `gap_m` with their standard errors (the gain's `None` when it is held
    /// at its bound).
    pub estimates: Vec<Estimate>,
    /// The RMS residual with the fitted parts, N m.
    pub rms_nm: f64,
    /// The RMS residual with the scenario's parts, N m.
    pub start_rms_nm: f64,
    /// The curve's points fitted.
    pub points: usize,
    /// The gain the curve asks for when it is below 1 (the gain is then held at 1).
    pub core_gain_wanted: Option<f64>,
    /// The fitted well's strongest pull, N m, and where it is, degrees.
    pub peak_nm: f64,
    /// The angle of the fitted well's strongest pull, degrees.
    pub peak_deg: f64,
    /// The fitted well's cut-off, degrees (where its pull ends, unless the scenario gives
    /// `max_attraction_deg`).
    pub reach_deg: f64,
}

/// A physical well with its gap and gain free: the scenario's parts, and its cut-off if the
/// scenario gives one (else where each trial's pull ends).
#[derive(Debug, Clone)]
pub struct PartsModel {
    real: RealParts,
    cutoff: Option<Radians>,
}

impl PartsModel {
    /// The model of a scenario's well, which must be physical (`shape = "dipole"`).
    pub fn of(well: &Well) -> Result<PartsModel, FitError> {
        let WellShape::Dipole(w) = well.shape() else {
            return Err(FitError::Unfit(
                "fitting core_gain and gap_m needs a physical scenario (shape = \"dipole\")".into(),
            ));
        };
        let real = w.real_parts().copied().unwrap_or(RealParts {
            loop_parts: *w.parts(),
            magnet: MagnetShape::Point,
            winding: None,
        });
        // a cut-off the scenario gave differs from where the pull ends (computed alike)
        let ends = Radians(w.reach(0.0));
        let cutoff = (well.max_attraction() != ends).then_some(well.max_attraction());
        Ok(PartsModel { real, cutoff })
    }

    /// The scenario's values (the gap to a picometre: a winding's face, its mid-height less
    /// half its length, loses the last bit of the gap the file gave).
    pub fn values(&self) -> PartsValues {
        PartsValues {
            core_gain: self.real.loop_parts.core_gain,
            gap_m: (self.real.face_gap_m() * 1e12).round() / 1e12,
        }
    }

    /// The well of these parts with `v`'s gap and gain, built as a scenario file builds it
    /// (the error is the parts' own, naming the field).
    pub fn well(&self, v: PartsValues) -> Result<Well, String> {
        let mut parts = self.real.loop_parts;
        parts.core_gain = v.core_gain;
        if self.real.winding.is_none() {
            parts.gap_m = v.gap_m;
        }
        let real = RealParts::new(
            parts,
            self.real.magnet,
            self.real.winding.map(|w| (w, v.gap_m)),
        )?;
        let dipole = DipoleWell::real(real)?;
        let cutoff = self.cutoff.unwrap_or(Radians(dipole.reach(0.0)));
        Ok(Well::new(WellShape::Dipole(dipole), cutoff))
    }
}

/// The curve at a gain of 1 per trial gap (by its bits), built once each.
struct Curves<'a> {
    model: &'a PartsModel,
    angles: Vec<f64>,
    built: Mutex<BTreeMap<u64, Option<Vec<f64>>>>,
}

impl Curves<'_> {
    /// The torques (N m) at the angles with gap `gap_m` and gain `gain` (None: no such well).
    fn at(&self, gain: f64, gap_m: f64) -> Option<Vec<f64>> {
        let unit = {
            let mut built = self.built.lock().unwrap_or_else(|e| e.into_inner());
            built
                .entry(gap_m.to_bits())
                .or_insert_with(|| {
                    let v = PartsValues {
                        core_gain: 1.0,
                        gap_m,
                    };
                    let well = self.model.well(v).ok()?;
                    Some(
                        self.angles
                            .iter()
                            .map(|&d| well.passing_torque(d))
                            .collect(),
                    )
                })
                .clone()
        }?;
        Some(unit.into_iter().map(|t| gain * t).collect())
    }

    /// The residuals (model less measured) at gain `gain` and gap `gap_m`; not finite where
    /// the parts make no well.
    fn residuals(&self, gain: f64, gap_m: f64, measured: &[f64]) -> Vec<f64> {
        match self.at(gain, gap_m) {
            Some(t) => t.iter().zip(measured).map(|(m, y)| m - y).collect(),
            None => vec![f64::NAN; measured.len()],
        }
    }
}

/// The torque curve `pts` (degrees, N m) fitted with the parts of `model`: `core_gain` and
/// `gap_m` from the scenario's values.
pub fn fit_parts(model: &PartsModel, pts: &[(f64, f64)]) -> Result<PartsFit, FitError> {
    let sorted = curve_radians(pts)?;
    let curves = Curves {
        model,
        angles: sorted.iter().map(|p| p.0).collect(),
        built: Mutex::new(BTreeMap::new()),
    };
    let y: Vec<f64> = sorted.iter().map(|p| p.1).collect();
    let start = model.values();
    let start_r = curves.residuals(start.core_gain, start.gap_m, &y);
    if !start_r.iter().all(|r| r.is_finite()) {
        return Err(FitError::Unfit(format!(
            "the scenario's parts make no well to start from: {}",
            model.well(start).err().unwrap_or_default()
        )));
    }
    let both = |x: &[f64]| curves.residuals(x[0].exp(), x[1].exp(), &y);
    let x0 = [start.core_gain.ln(), start.gap_m.ln()];
    let s = levenberg_marquardt(&both, &x0, &[LOG_STEP; 2]);
    let wanted = s.x[0].exp();
    if wanted >= 1.0 {
        return Ok(report(model, &s, None, start, &start_r, s.x[1].exp()));
    }
    // the gain held at its bound, the gap alone
    let gap = |x: &[f64]| curves.residuals(1.0, x[0].exp(), &y);
    let held = levenberg_marquardt(&gap, &[s.x[1]], &[LOG_STEP]);
    Ok(report(
        model,
        &held,
        Some(wanted),
        start,
        &start_r,
        held.x[0].exp(),
    ))
}

/// The report of a fit ending at `s` (the gain and the gap's logarithms, or the gap's alone
/// with the gain held at 1, `wanted` the gain asked for).
fn report(
    model: &PartsModel,
    s: &Solved,
    wanted: Option<f64>,
    start: PartsValues,
    start_r: &[f64],
    gap_m: f64,
) -> PartsFit {
    let n = s.residuals;
    let var = s.ssr / n.saturating_sub(s.x.len()).max(1) as f64;
    // d(value) = value d(ln value)
    let se = |k: usize, value: f64| s.variance[k].map(|v| value * (v * var).sqrt());
    let fitted = PartsValues {
        core_gain: if wanted.is_some() { 1.0 } else { s.x[0].exp() },
        gap_m,
    };
    let gap_index = s.x.len() - 1;
    let estimates = vec![
        Estimate {
            key: "core_gain",
            value: fitted.core_gain,
            std_error: if wanted.is_some() {
                None
            } else {
                se(0, fitted.core_gain)
            },
        },
        Estimate {
            key: "gap_m",
            value: gap_m,
            std_error: se(gap_index, gap_m),
        },
    ];
    let (peak_nm, peak_deg, reach_deg) = match model.well(fitted) {
        Ok(w) => {
            let (d, g) = match w.shape() {
                WellShape::Dipole(dw) => dw.peak(),
                _ => (f64::NAN, f64::NAN),
            };
            (g, d.to_degrees(), w.max_attraction().0.to_degrees())
        }
        Err(_) => (f64::NAN, f64::NAN, f64::NAN),
    };
    let rms = |ssr: f64| (ssr / n.max(1) as f64).sqrt();
    PartsFit {
        start,
        fitted,
        estimates,
        rms_nm: rms(s.ssr),
        start_rms_nm: rms(start_r.iter().map(|r| r * r).sum()),
        points: n,
        core_gain_wanted: wanted,
        peak_nm,
        peak_deg,
        reach_deg,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::physics::magnetics::DipoleParts;

    fn model() -> PartsModel {
        let parts = DipoleParts {
            core_gain: 2.0,
            ..DipoleParts::prototype()
        };
        let well = DipoleWell::new(parts).unwrap();
        let ends = Radians(well.reach(0.0));
        PartsModel::of(&Well::new(WellShape::Dipole(well), ends)).unwrap()
    }

    #[test]
    fn the_torque_is_linear_in_the_gain() {
        let m = model();
        let v = m.values();
        let one = m
            .well(PartsValues {
                core_gain: 1.0,
                ..v
            })
            .unwrap();
        let three = m
            .well(PartsValues {
                core_gain: 3.0,
                ..v
            })
            .unwrap();
        for d in [0.02, 0.1, 0.2, 0.3] {
            let (a, b) = (3.0 * one.passing_torque(d), three.passing_torque(d));
            assert!((a - b).abs() <= 1e-12 * b.abs(), "{d}: {a} {b}");
        }
    }

    /// `well`'s passing torque times `scale` every 0.5 degrees from 0 to `points` halves.
    fn curve(well: &Well, points: usize, scale: f64) -> Vec<(f64, f64)> {
        (0..=points)
            .map(|i| {
                let deg = 0.5 * i as f64;
                (deg, scale * well.passing_torque(deg.to_radians()))
            })
            .collect()
    }

    #[test]
    fn an_exact_curve_of_other_parts_is_fitted_exactly_from_the_scenarios() {
        let m = model();
        assert!(m.cutoff.is_none());
        let truth = PartsValues {
            core_gain: 2.6,
            gap_m: 0.0115,
        };
        let well = m.well(truth).unwrap();
        let pts = curve(&well, 60, 1.0);
        let fit = fit_parts(&m, &pts).unwrap();
        assert_eq!(fit.start, m.values());
        assert!((fit.fitted.core_gain / 2.6 - 1.0).abs() < 1e-6, "{fit:?}");
        assert!((fit.fitted.gap_m / 0.0115 - 1.0).abs() < 1e-6, "{fit:?}");
        assert!(fit.rms_nm < 1e-6 * fit.start_rms_nm, "{fit:?}");
        assert_eq!(fit.core_gain_wanted, None);
    }

    #[test]
    fn a_curve_weaker_than_an_air_coil_holds_the_gain_at_one() {
        let m = model();
        let truth = PartsValues {
            core_gain: 1.0,
            gap_m: 0.01,
        };
        let well = m.well(truth).unwrap();
        // half the air coil's pull: the gain it asks for is about 0.5
        let pts = curve(&well, 40, 0.5);
        let fit = fit_parts(&m, &pts).unwrap();
        let wanted = fit.core_gain_wanted.unwrap();
        assert!((wanted - 0.5).abs() < 1e-4, "{fit:?}");
        assert_eq!(fit.fitted.core_gain, 1.0);
        assert_eq!(fit.estimates[0].std_error, None);
        assert!(fit.estimates[1].std_error.is_some());
    }
}
