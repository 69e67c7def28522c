//! Fitting the wells to what the bench measures (`spherestep fit`): a torque curve (one coil's
//! torque on one magnet against the angle) fits each well shape with continuous parameters
//! (gaussian: strength and width; cosine: strength; both: the reach) by Levenberg-Marquardt
//! with numeric Jacobians, and the shape with the least residual is chosen; measured steps (the
//! ball at rest where it was measured, a set of coils switched on, measured again) fit the
//! parameters that decide where a step settles (a gaussian's width, the reach) by the same
//! method on the angles between each step's predicted and measured end. Each parameter comes
//! with its standard error (from (J^T J)^-1 times the residual variance), or none where the
//! data do not determine it. Everything is counted, nothing timed: the same data give the same
//! fit on any machine and thread count (the settles run in parallel, the sums in order).

use crate::model::geometry::{CoilId, Degrees, Orientation, Pair};
use crate::physics::dynamics::settle;
use crate::physics::torque::{Interaction, MagnetTorques, Well, WellShape};
use crate::planning::commutation::{nearest_magnet, Motor};
use nalgebra::{DMatrix, DVector};
use rayon::prelude::*;

/// The fewest points of a torque curve a fit accepts (two parameters and the reach, with room
/// for a residual variance).
pub const MIN_CURVE_POINTS: usize = 5;
/// The fewest measured steps a fit of the steps accepts (after the held-out ones).
pub const MIN_STEPS: usize = 3;
/// Levenberg-Marquardt's most iterations.
pub const MAX_ITERATIONS: usize = 60;

/// Why a fit cannot be made: the crate's `Error` gathers it as its `Fit`.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum FitError {
    /// Too few points or steps for the parameters.
    #[error("fitting the wells: {what}: expected at least {needed}, got {got}")]
    TooFew {
        /// What was counted ("torque curve points", "measured steps to fit").
        what: String,
        /// The fewest the fit needs.
        needed: usize,
        /// How many there were.
        got: usize,
    },
    /// The data cannot fit this scenario's wells (no pull measured, a shape without
    /// continuous parameters).
    #[error("fitting the wells: {0}")]
    Unfit(String),
}

/// A well shape with continuous parameters, as the scenario format names it.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "lowercase")]
pub enum FitShape {
    /// `U = -k exp(-d^2 / (2 w^2))`: a strength k and a width w.
    Gaussian,
    /// `U = -k cos d`: a strength k alone.
    Cosine,
}

impl FitShape {
    /// Its name in a scenario's `magnets.shape`.
    pub fn name(self) -> &'static str {
        match self {
            FitShape::Gaussian => "gaussian",
            FitShape::Cosine => "cosine",
        }
    }
}

/// Fitted wells: a shape, its strength (J), width (degrees, gaussian only) and reach (the
/// maximum attraction distance, degrees), as a scenario's `[magnets]` writes them.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct WellFit {
    /// The well's shape.
    pub shape: FitShape,
    /// The well's depth k, J (`magnets.strength_j`).
    pub strength_j: f64,
    /// A gaussian's width, degrees (`magnets.width_deg`); `None` for a cosine.
    pub width_deg: Option<f64>,
    /// The maximum attraction distance, degrees (`magnets.max_attraction_deg`).
    pub reach_deg: f64,
}

impl WellFit {
    /// The well these parameters make, built as a scenario file's `[magnets]` builds it (the
    /// degrees converted the same way), so that a written scenario loads this very well.
    pub fn well(&self) -> Well {
        let shape = match (self.shape, self.width_deg) {
            (FitShape::Gaussian, Some(w)) => WellShape::Gaussian {
                strength_j: self.strength_j,
                width: Degrees(w).to_radians(),
            },
            _ => WellShape::Cosine {
                strength_j: self.strength_j,
            },
        };
        Well::new(shape, Degrees(self.reach_deg).to_radians())
    }

    /// The fitted wells of a scenario's well, if it is of a shape with parameters.
    pub fn of(well: &Well) -> Option<WellFit> {
        // in the degrees they were given in (radians and back lose the last bit)
        let deg = |r: f64| (r.to_degrees() * 1e9).round() / 1e9;
        let reach_deg = deg(well.max_attraction().0);
        match well.shape() {
            WellShape::Gaussian { strength_j, width } => Some(WellFit {
                shape: FitShape::Gaussian,
                strength_j: *strength_j,
                width_deg: Some(deg(width.0)),
                reach_deg,
            }),
            WellShape::Cosine { strength_j } => Some(WellFit {
                shape: FitShape::Cosine,
                strength_j: *strength_j,
                width_deg: None,
                reach_deg,
            }),
            _ => None,
        }
    }
}

/// One fitted parameter: its scenario key, value and standard error (`None`: the data do not
/// determine it).
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct Estimate {
    /// The key in `[magnets]` (`strength_j`, `width_deg`, `max_attraction_deg`).
    pub key: &'static str,
    /// The fitted value, in the key's unit.
    pub value: f64,
    /// Its standard error, in the same unit; `None` where the data do not determine it.
    pub std_error: Option<f64>,
}

impl Estimate {
    /// "width_deg = 12.49 +- 0.03" (or "not determined").
    pub fn text(&self) -> String {
        match self.std_error {
            Some(se) => format!("{} = {:.5} +- {:.5}", self.key, self.value, se),
            None => format!("{} = {:.5} (not determined)", self.key, self.value),
        }
    }
}

/// A torque curve fitted with one shape.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct CurveFit {
    /// The fitted wells of this shape.
    pub wells: WellFit,
    /// Each parameter with its standard error.
    pub estimates: Vec<Estimate>,
    /// The root mean square residual, N m.
    pub rms_nm: f64,
    /// The curve's points fitted.
    pub points: usize,
}

/// What Levenberg-Marquardt ends with.
pub(super) struct Solved {
    /// The parameters at the end.
    pub(super) x: Vec<f64>,
    /// The sum of squared residuals.
    pub(super) ssr: f64,
    /// How many residuals there were.
    pub(super) residuals: usize,
    /// (J^T J)^-1 at the end, per parameter its variance factor (`None`: not determined).
    pub(super) variance: Vec<Option<f64>>,
}

/// The residuals at `x` and their sum of squares.
fn ssr(r: &[f64]) -> f64 {
    r.iter().map(|v| v * v).sum()
}

/// The Jacobian of `f` at `x` by central differences of steps `h`.
fn jacobian(
    f: &(dyn Fn(&[f64]) -> Vec<f64> + Sync),
    x: &[f64],
    h: &[f64],
    n: usize,
) -> DMatrix<f64> {
    let mut j = DMatrix::zeros(n, x.len());
    for k in 0..x.len() {
        let (mut up, mut down) = (x.to_vec(), x.to_vec());
        up[k] += h[k];
        down[k] -= h[k];
        let (a, b) = (f(&up), f(&down));
        for i in 0..n {
            j[(i, k)] = (a[i] - b[i]) / (2.0 * h[k]);
        }
    }
    j
}

/// The variance factors, the diagonal of (J^T J)^-1 over the columns that the data move
/// (the others, and all of a singular matrix's, `None`).
fn variances(jtj: &DMatrix<f64>) -> Vec<Option<f64>> {
    let p = jtj.nrows();
    let top = (0..p).map(|k| jtj[(k, k)]).fold(0.0, f64::max);
    let moved: Vec<usize> = (0..p).filter(|&k| jtj[(k, k)] > 1e-12 * top).collect();
    let sub = DMatrix::from_fn(moved.len(), moved.len(), |a, b| jtj[(moved[a], moved[b])]);
    let mut out = vec![None; p];
    if let Some(inv) = sub.try_inverse() {
        for (a, &k) in moved.iter().enumerate() {
            out[k] = Some(inv[(a, a)]).filter(|v| v.is_finite() && *v >= 0.0);
        }
    }
    out
}

/// Levenberg-Marquardt from `x0` on the residuals `f`, central-difference steps `h` (a trial
/// whose residuals are not finite is refused, as one that does not improve).
pub(super) fn levenberg_marquardt(
    f: &(dyn Fn(&[f64]) -> Vec<f64> + Sync),
    x0: &[f64],
    h: &[f64],
) -> Solved {
    let mut x = x0.to_vec();
    let mut r = f(&x);
    let mut s = ssr(&r);
    let mut lambda = 1e-3;
    let n = r.len();
    let mut j = jacobian(f, &x, h, n);
    for _ in 0..MAX_ITERATIONS {
        let jtj = j.transpose() * &j;
        let g = j.transpose() * DVector::from_column_slice(&r);
        let mut improved = false;
        while lambda < 1e12 {
            let mut a = jtj.clone();
            for k in 0..x.len() {
                a[(k, k)] += lambda * jtj[(k, k)].max(1e-12);
            }
            let Some(delta) = a.lu().solve(&(-&g)) else {
                lambda *= 10.0;
                continue;
            };
            let trial: Vec<f64> = x.iter().zip(delta.iter()).map(|(a, b)| a + b).collect();
            let rt = f(&trial);
            let st = ssr(&rt);
            if st.is_finite() && st < s {
                let gain = (s - st) / s.max(f64::MIN_POSITIVE);
                (x, r, s) = (trial, rt, st);
                lambda = (lambda / 3.0).max(1e-9);
                improved = gain > 1e-12;
                break;
            }
            lambda *= 4.0;
        }
        if !improved {
            break;
        }
        j = jacobian(f, &x, h, n);
    }
    let jtj = j.transpose() * &j;
    Solved {
        variance: variances(&jtj),
        x,
        ssr: s,
        residuals: n,
    }
}

/// The pull of `shape` with parameters `p` (ln strength, and for a gaussian ln width in
/// radians) at `d` (radians), cut off beyond `reach` (radians).
fn pull(shape: FitShape, p: &[f64], d: f64, reach: f64) -> f64 {
    if d > reach {
        return 0.0;
    }
    let k = p[0].exp();
    match shape {
        FitShape::Gaussian => {
            let s = p[1].exp();
            k * d / (s * s) * (-d * d / (2.0 * s * s)).exp()
        }
        FitShape::Cosine => k * d.sin(),
    }
}

/// The starting parameters of `shape` from the curve's peak (a gaussian peaks at its width).
fn start(shape: FitShape, pts: &[(f64, f64)]) -> Vec<f64> {
    let peak = pts.iter().copied().fold(
        (0.0, f64::NEG_INFINITY),
        |a, p| if p.1 > a.1 { p } else { a },
    );
    match shape {
        FitShape::Gaussian => {
            let s = peak.0.max(1e-3);
            vec![(peak.1 * s * 0.5f64.exp()).ln(), s.ln()]
        }
        FitShape::Cosine => vec![(peak.1 / peak.0.sin().max(1e-3)).ln()],
    }
}

/// The reach (an angle of the curve, radians) that leaves the least squared residual with
/// parameters `p`: the points beyond it are predicted at zero.
fn best_reach(shape: FitShape, p: &[f64], pts: &[(f64, f64)]) -> usize {
    // the residual with every point inside, minus what cutting after point i changes
    let inside: Vec<f64> = pts
        .iter()
        .map(|&(d, y)| (y - pull(shape, p, d, f64::INFINITY)).powi(2))
        .collect();
    let outside: Vec<f64> = pts.iter().map(|&(_, y)| y * y).collect();
    let mut best = (pts.len() - 1, f64::INFINITY);
    let mut tail = 0.0;
    let total: f64 = inside.iter().sum();
    let mut kept = total;
    for i in (0..pts.len()).rev() {
        let cost = kept + tail;
        if cost < best.1 {
            best = (i, cost);
        }
        kept -= inside[i];
        tail += outside[i];
    }
    best.0
}

/// The torque curve `pts` (degrees, N m) in radians, sorted by angle: at least
/// [`MIN_CURVE_POINTS`] points, pulling somewhere.
pub(super) fn curve_radians(pts: &[(f64, f64)]) -> Result<Vec<(f64, f64)>, FitError> {
    let mut sorted: Vec<(f64, f64)> = pts.iter().map(|&(a, t)| (a.to_radians(), t)).collect();
    sorted.sort_by(|a, b| a.0.total_cmp(&b.0));
    if sorted.len() < MIN_CURVE_POINTS {
        return Err(FitError::TooFew {
            what: "torque curve points".into(),
            needed: MIN_CURVE_POINTS,
            got: sorted.len(),
        });
    }
    if !sorted.iter().any(|p| p.1 > 0.0 && p.0 > 0.0) {
        return Err(FitError::Unfit(
            "the torque curve pulls nowhere (no positive torque at a positive angle)".into(),
        ));
    }
    Ok(sorted)
}

/// The torque curve `pts` (degrees, N m) fitted with `shape`.
pub fn fit_shape(shape: FitShape, pts: &[(f64, f64)]) -> Result<CurveFit, FitError> {
    let sorted = curve_radians(pts)?;
    let mut p = start(shape, &sorted);
    let mut reach = sorted.len() - 1;
    let mut solved = None;
    for _ in 0..6 {
        let r = sorted[reach].0;
        let data = &sorted;
        let f = move |x: &[f64]| -> Vec<f64> {
            data.iter()
                .map(|&(d, y)| pull(shape, x, d, r) - y)
                .collect()
        };
        let h = vec![1e-6; p.len()];
        let s = levenberg_marquardt(&f, &p, &h);
        p = s.x.clone();
        solved = Some(s);
        let next = best_reach(shape, &p, &sorted);
        if next == reach {
            break;
        }
        reach = next;
    }
    let s = solved.ok_or_else(|| FitError::Unfit("no fit".into()))?;
    Ok(curve_fit(shape, &s, &sorted, reach))
}

/// The fit's report: the parameters in the scenario's units with their standard errors.
fn curve_fit(shape: FitShape, s: &Solved, pts: &[(f64, f64)], reach: usize) -> CurveFit {
    let dof = s.residuals.saturating_sub(s.x.len() + 1).max(1) as f64;
    let var = s.ssr / dof;
    // d(value) = value d(ln value)
    let se = |k: usize, value: f64| s.variance[k].map(|v| value * (v * var).sqrt());
    let strength = s.x[0].exp();
    let mut estimates = vec![Estimate {
        key: "strength_j",
        value: strength,
        std_error: se(0, strength),
    }];
    let width_deg = (shape == FitShape::Gaussian).then(|| s.x[1].exp().to_degrees());
    if let Some(w) = width_deg {
        estimates.push(Estimate {
            key: "width_deg",
            value: w,
            std_error: se(1, w),
        });
    }
    // the reach lies between its point and the next (the last: at least there)
    let reach_deg = pts[reach].0.to_degrees();
    let spacing = match (pts.get(reach + 1), reach.checked_sub(1).map(|i| pts[i])) {
        (Some(next), _) => next.0.to_degrees() - reach_deg,
        (None, Some(prev)) => reach_deg - prev.0.to_degrees(),
        _ => 0.0,
    };
    estimates.push(Estimate {
        key: "max_attraction_deg",
        value: reach_deg,
        std_error: Some(spacing / 12f64.sqrt()),
    });
    CurveFit {
        wells: WellFit {
            shape,
            strength_j: strength,
            width_deg,
            reach_deg,
        },
        estimates,
        rms_nm: (s.ssr / s.residuals.max(1) as f64).sqrt(),
        points: pts.len(),
    }
}

/// The torque curve `pts` (degrees, N m) fitted with every shape with continuous parameters,
/// the least residual first.
pub fn fit_curve(pts: &[(f64, f64)]) -> Result<Vec<CurveFit>, FitError> {
    let mut fits = [FitShape::Gaussian, FitShape::Cosine]
        .into_iter()
        .map(|s| fit_shape(s, pts))
        .collect::<Result<Vec<_>, _>>()?;
    fits.sort_by(|a, b| a.rms_nm.total_cmp(&b.rms_nm));
    Ok(fits)
}

/// One measured step: the ball at rest at `from` (measured), `coils` switched on, measured at
/// `to`.
#[derive(Debug, Clone, PartialEq)]
pub struct MeasuredStep {
    /// The measured orientation the step starts from, the ball at rest.
    pub from: Orientation,
    /// The coils that were on when `from` was measured (the step before's; empty when none
    /// were, or when the log does not say): the ball rests where they hold it.
    pub held_by: Vec<CoilId>,
    /// Where the ball was measured when `held_by` were switched on (the step before's start;
    /// `from` when the log does not say): where their pairs were made.
    pub held_since: Orientation,
    /// The coils on during the step.
    pub coils: Vec<CoilId>,
    /// The measured orientation the step ends at.
    pub to: Orientation,
}

/// The pairs `coils` switch on in `torques` with the ball at `at`: each coil with the magnet
/// nearest it (with every coil pulling, the pairing does not matter).
fn pairs_at(torques: &MagnetTorques, coils: &[CoilId], at: &Orientation) -> Vec<Pair> {
    coils
        .iter()
        .map(|&c| Pair {
            coil: c,
            magnet: nearest_magnet(torques, c, at).0,
        })
        .collect()
}

/// Where the ball rests at a step's start in `torques`: the equilibrium the coils that held it
/// (`held_by`, paired where they were switched on) settle it to from the measured `from`. A sensor reads a ball at rest with its
/// noise (a degree for a good one); the ball itself sits in an equilibrium of the coils that
/// hold it, and a start a degree off can lie across a basin boundary of the step's own coils
/// where the true start does not. With no holding coils the measurement is the start.
pub fn step_start(motor: &Motor, torques: &MagnetTorques, step: &MeasuredStep) -> Orientation {
    if step.held_by.is_empty() {
        return step.from;
    }
    let pairs = pairs_at(torques, &step.held_by, &step.held_since);
    settle(torques, &pairs, &step.from, motor.body, motor.settle).q
}

/// Where `torques` (with `motor`'s body and settle) predict each step ends: from where the
/// ball rests at its start ([`step_start`]), its coils paired with the magnets nearest them.
pub fn predict_steps(
    motor: &Motor,
    torques: &MagnetTorques,
    steps: &[MeasuredStep],
) -> Vec<Orientation> {
    steps
        .par_iter()
        .map(|s| {
            let from = step_start(motor, torques, s);
            let pairs = pairs_at(torques, &s.coils, &from);
            settle(torques, &pairs, &from, motor.body, motor.settle).q
        })
        .collect()
}

/// The angles (degrees) between each step's predicted and measured end.
pub fn step_errors_deg(motor: &Motor, torques: &MagnetTorques, steps: &[MeasuredStep]) -> Vec<f64> {
    predict_steps(motor, torques, steps)
        .iter()
        .zip(steps)
        .map(|(p, s)| p.angle_to(&s.to).to_degrees())
        .collect()
}

/// Measured steps fitted: the wells, their estimates, the fit's and the held-out steps' errors
/// (degrees) before (the starting wells) and after.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct StepFit {
    /// The fitted wells.
    pub wells: WellFit,
    /// The parameters the steps determine, with their standard errors.
    pub estimates: Vec<Estimate>,
    /// The interaction the steps were predicted with (the scenario's).
    pub interaction: Interaction,
    /// The steps fitted (the log's steps less the held-out ones).
    pub fitted_steps: usize,
    /// RMS prediction error of the fitted steps with the starting wells, degrees.
    pub rms_before_deg: f64,
    /// RMS prediction error of the fitted steps with the fitted wells, degrees.
    pub rms_after_deg: f64,
    /// Each held-out step's prediction error with the starting wells, degrees.
    pub holdout_before_deg: Vec<f64>,
    /// Each held-out step's prediction error with the fitted wells, degrees.
    pub holdout_after_deg: Vec<f64>,
}

/// The scale of the steps' robust loss, degrees: a step predicted well within this counts as
/// its square, one much further (ended in another basin than predicted: a start across a
/// basin boundary, a pairing the noise flips) no more than this squared (a Geman-McClure
/// loss, e^2 c^2 / (c^2 + e^2)). A loss that grows without bound (a Cauchy loss's logarithm)
/// lets one such step pull a parameter the other steps do not pin to where it explains it.
pub const ROBUST_DEG: f64 = 2.0;
/// The reaches a fit of the steps tries, degrees: from 5 to 75 by 0.5.
pub const REACH_GRID: (f64, f64, f64) = (5.0, 75.0, 0.5);
/// Rounds of the fit of the steps: the reach over its grid, then the width by
/// Levenberg-Marquardt.
pub const STEP_ROUNDS: usize = 3;

/// The rotation (degrees, as a vector) from each measured end to its prediction, scaled to
/// the robust loss: its squared length is e^2 ROBUST^2 / (ROBUST^2 + e^2).
fn step_residuals(motor: &Motor, wells: &WellFit, steps: &[MeasuredStep]) -> Vec<f64> {
    let torques = MagnetTorques {
        well: wells.well(),
        ..motor.torques.clone()
    };
    predict_steps(motor, &torques, steps)
        .iter()
        .zip(steps)
        .flat_map(|(p, s)| {
            let v = (p * s.to.inverse()).scaled_axis().map(f64::to_degrees);
            let e = v.norm();
            let c = ROBUST_DEG;
            let f = c / (c * c + e * e).sqrt();
            [v.x * f, v.y * f, v.z * f]
        })
        .collect()
}

/// The trial wells (indices, in order) whose robust loss on `steps` is within `var`, the loss
/// per degree of freedom, of the least: those the steps do not tell from the best.
fn near_best(motor: &Motor, trials: &[WellFit], steps: &[MeasuredStep]) -> Vec<usize> {
    let losses: Vec<f64> = trials
        .par_iter()
        .map(|w| ssr(&step_residuals(motor, w, steps)))
        .collect();
    let least = losses.iter().copied().fold(f64::INFINITY, f64::min);
    let var = least / (3 * steps.len()).saturating_sub(2).max(1) as f64;
    (0..trials.len())
        .filter(|&i| losses[i] <= least + var)
        .collect()
}

/// The reach of the grid for `wells`' other parameters: of the reaches whose robust loss is
/// within `var` (the loss per degree of freedom) of the least, the one nearest `prefer` (the
/// steps do not tell them apart: the reach moves no further than they say); and the
/// half-width of those reaches (`None`: they reach the grid's end, the steps do not bound it).
fn best_step_reach(
    motor: &Motor,
    wells: &WellFit,
    steps: &[MeasuredStep],
    prefer: f64,
) -> (f64, Option<f64>) {
    let (lo, hi, by) = REACH_GRID;
    let min = wells.width_deg.map_or(lo, |w| w.max(lo));
    let mut grid: Vec<f64> = grid_points(REACH_GRID)
        .into_iter()
        .filter(|&r| r >= min)
        .collect();
    if !grid.contains(&prefer) && (min..=hi).contains(&prefer) {
        grid.push(prefer);
        grid.sort_by(f64::total_cmp);
    }
    let trials: Vec<WellFit> = grid
        .iter()
        .map(|&r| WellFit {
            reach_deg: r,
            ..*wells
        })
        .collect();
    let within = near_best(motor, &trials, steps);
    let chosen = within
        .iter()
        .copied()
        .min_by(|&a, &b| {
            (grid[a] - prefer)
                .abs()
                .total_cmp(&(grid[b] - prefer).abs())
        })
        .map_or(wells.reach_deg, |i| grid[i]);
    let width = match (within.first(), within.last()) {
        (Some(&first), Some(&last)) if first > 0 && last + 1 < grid.len() => {
            Some((grid[last] - grid[first] + by) / 2.0)
        }
        _ => None,
    };
    (chosen, width)
}

/// The widths (degrees, of a gaussian well) the coarse search of a fit of the steps tries:
/// from 3 to 15 by 1.
pub const COARSE_WIDTHS: (f64, f64, f64) = (3.0, 15.0, 1.0);
/// The reaches (degrees) the coarse search tries: from 10 to 40 by 2.5.
pub const COARSE_REACHES: (f64, f64, f64) = (10.0, 40.0, 2.5);

/// The points of a grid `(lo, hi, by)`.
fn grid_points((lo, hi, by): (f64, f64, f64)) -> Vec<f64> {
    let n = ((hi - lo) / by).round() as usize;
    (0..=n).map(|i| lo + by * i as f64).collect()
}

/// The coarse start of a fit of the steps: the robust loss over a grid of widths (a gaussian's;
/// a cosine keeps none) and reaches, and of the grid's points within a degree of freedom's
/// loss of the least, the one nearest `start` (relative changes summed; the steps do not tell
/// those apart). A fit of the steps from the scenario's own wells alone can stall where the
/// loss is flat or rough: a step's end jumps between basins as a parameter moves.
fn coarse_start(motor: &Motor, start: &WellFit, steps: &[MeasuredStep]) -> WellFit {
    let widths: Vec<Option<f64>> = match start.width_deg {
        Some(_) => grid_points(COARSE_WIDTHS).into_iter().map(Some).collect(),
        None => vec![None],
    };
    let trials: Vec<WellFit> = widths
        .iter()
        .flat_map(|&w| {
            grid_points(COARSE_REACHES)
                .into_iter()
                .filter(move |&r| w.is_none_or(|w| r > w))
                .map(move |r| WellFit {
                    width_deg: w,
                    reach_deg: r,
                    ..*start
                })
        })
        .chain(std::iter::once(*start))
        .collect();
    let away = |w: &WellFit| {
        let rel = |a: f64, b: f64| (a / b - 1.0).abs();
        rel(w.reach_deg, start.reach_deg)
            + match (w.width_deg, start.width_deg) {
                (Some(a), Some(b)) => rel(a, b),
                _ => 0.0,
            }
    };
    near_best(motor, &trials, steps)
        .into_iter()
        .min_by(|&a, &b| away(&trials[a]).total_cmp(&away(&trials[b])))
        .map_or(*start, |i| trials[i])
}

/// Measured `steps` fitted from `start` (the wells of `motor`, or a curve's fit): the
/// parameters that decide where a step settles (the reach, over a grid, and a gaussian's
/// width, by Levenberg-Marquardt, in turns; the strength scales every torque alike and moves
/// no equilibrium, so it is kept), the last `holdout` steps kept out of the fit and predicted.
pub fn fit_steps(
    motor: &Motor,
    start: &WellFit,
    steps: &[MeasuredStep],
    holdout: usize,
) -> Result<StepFit, FitError> {
    let fitted = steps.len().saturating_sub(holdout);
    if fitted < MIN_STEPS {
        return Err(FitError::TooFew {
            what: format!(
                "measured steps to fit (of {} after {holdout} held out)",
                steps.len()
            ),
            needed: MIN_STEPS,
            got: fitted,
        });
    }
    let (train, test) = steps.split_at(fitted);
    let mut wells = coarse_start(motor, start, train);
    let mut width_se = None;
    for _ in 0..STEP_ROUNDS {
        wells.reach_deg = best_step_reach(motor, &wells, train, start.reach_deg).0;
        if let Some(w) = wells.width_deg {
            let f = |x: &[f64]| {
                let trial = WellFit {
                    width_deg: Some(x[0].exp().min(wells.reach_deg)),
                    ..wells
                };
                step_residuals(motor, &trial, train)
            };
            // the settle's own tolerance makes the residuals rough below ~1e-3: a wide step
            let s = levenberg_marquardt(&f, &[w.ln()], &[0.02]);
            let width = s.x[0].exp().min(wells.reach_deg);
            let var = s.ssr / s.residuals.saturating_sub(2).max(1) as f64;
            width_se = s.variance[0].map(|v| width * (v * var).sqrt());
            wells.width_deg = Some(width);
        }
    }
    let (_, reach_se) = best_step_reach(motor, &wells, train, start.reach_deg);
    let mut estimates = Vec::new();
    if let Some(w) = wells.width_deg {
        estimates.push(Estimate {
            key: "width_deg",
            value: w,
            std_error: width_se,
        });
    }
    estimates.push(Estimate {
        key: "max_attraction_deg",
        value: wells.reach_deg,
        std_error: reach_se,
    });
    Ok(report_steps(motor, start, wells, estimates, train, test))
}

/// The report of a fit of the steps: the errors before and after.
fn report_steps(
    motor: &Motor,
    start: &WellFit,
    wells: WellFit,
    estimates: Vec<Estimate>,
    train: &[MeasuredStep],
    test: &[MeasuredStep],
) -> StepFit {
    let torques = |w: &WellFit| MagnetTorques {
        well: w.well(),
        ..motor.torques.clone()
    };
    let rms = |e: &[f64]| (e.iter().map(|v| v * v).sum::<f64>() / e.len().max(1) as f64).sqrt();
    let (before, after) = (torques(start), torques(&wells));
    StepFit {
        wells,
        estimates,
        interaction: motor.torques.interaction,
        fitted_steps: train.len(),
        rms_before_deg: rms(&step_errors_deg(motor, &before, train)),
        rms_after_deg: rms(&step_errors_deg(motor, &after, train)),
        holdout_before_deg: step_errors_deg(motor, &before, test),
        holdout_after_deg: step_errors_deg(motor, &after, test),
    }
}

/// "gaussian wells of width 12.48 deg, strength 0.3209 J, reaching 34.00 deg".
pub fn describe(w: &WellFit) -> String {
    let width = w
        .width_deg
        .map(|x| format!(" of width {x:.2} deg"))
        .unwrap_or_default();
    format!(
        "{} wells{width}, strength {:.4} J, reaching {:.2} deg",
        w.shape.name(),
        w.strength_j,
        w.reach_deg
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    fn curve(w: &WellFit, step: f64) -> Vec<(f64, f64)> {
        let well = w.well();
        let n = (w.reach_deg / step).round() as usize;
        (0..=n)
            .map(|i| {
                let d = w.reach_deg * i as f64 / n as f64;
                (d, well.passing_torque(d.to_radians()))
            })
            .collect()
    }

    #[test]
    fn an_exact_gaussian_curve_is_fitted_exactly_and_beats_the_cosine() {
        let w = WellFit {
            shape: FitShape::Gaussian,
            strength_j: 0.3,
            width_deg: Some(12.5),
            reach_deg: 34.0,
        };
        let fits = fit_curve(&curve(&w, 0.5)).unwrap();
        assert_eq!(fits[0].wells.shape, FitShape::Gaussian);
        let got = fits[0].wells;
        assert!((got.strength_j - 0.3).abs() < 1e-8, "{got:?}");
        assert!((got.width_deg.unwrap() - 12.5).abs() < 1e-8, "{got:?}");
        assert_eq!(got.reach_deg, 34.0);
        assert!(fits[0].rms_nm < 1e-9 && fits[1].rms_nm > 1e-3, "{fits:?}");
    }

    #[test]
    fn the_reach_is_found_where_the_measured_pull_stops() {
        let w = WellFit {
            shape: FitShape::Cosine,
            strength_j: 2.0,
            width_deg: None,
            reach_deg: 20.0,
        };
        let mut pts = curve(&w, 1.0);
        pts.extend((21..=40).map(|d| (d as f64, 0.0)));
        let fit = fit_shape(FitShape::Cosine, &pts).unwrap();
        assert_eq!(fit.wells.reach_deg, 20.0);
        assert!((fit.wells.strength_j - 2.0).abs() < 1e-9);
    }

    #[test]
    fn a_singular_direction_has_no_standard_error() {
        let jtj = DMatrix::from_row_slice(2, 2, &[4.0, 0.0, 0.0, 0.0]);
        assert_eq!(variances(&jtj), vec![Some(0.25), None]);
    }
}
