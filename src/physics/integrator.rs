//! An allocation-free explicit Runge-Kutta integrator for small fixed-size systems: the
//! Bogacki-Shampine 3(2) pair with first-same-as-last and an error-controlled step size, run
//! until a stop test on each accepted step passes. It is the settle engine's fast path; the
//! reference path integrates the same equations with ode_solvers' Dopri5 (see `dynamics`).
//!
//! Why a third-order pair: a settle only needs the trajectory to stay in the right basin and the
//! stop test (evaluated exactly on the accepted state) to decide where it ends, so loose
//! tolerances are enough, and at loose tolerances a low-order pair takes fewer evaluations than
//! Dopri5's seven-stage steps (measured in docs/speed.md).

/// A right-hand side dy/dt = f(y) of an autonomous system with `N` states.
pub trait OdeSystem<const N: usize> {
    /// Writes f(y) into `dy`, every component (`dy` may hold an earlier stage's values).
    fn rhs(&self, y: &[f64; N], dy: &mut [f64; N]);
}

/// Error tolerances: a step is accepted when every component's local error is within
/// `atol + rtol * |y|` in the root-mean-square sense.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Tolerances {
    /// The relative tolerance (a fraction of |y|).
    pub rtol: f64,
    /// The absolute tolerance, in the state's own units.
    pub atol: f64,
}

/// Where an integration ended.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Outcome<const N: usize> {
    /// The time of the last accepted step (the system's unit; seconds for the settle).
    pub t: f64,
    /// The state at `t`.
    pub y: [f64; N],
    /// Right-hand-side evaluations, rejected steps included.
    pub evaluations: u32,
    /// Accepted steps.
    pub steps: u32,
    /// Whether the stop test passed (otherwise `t_max` was reached, or the step size collapsed).
    pub stopped: bool,
    /// Why the integration ended.
    pub end: End,
}

/// Why an integration ended.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum End {
    /// The stop test passed.
    Stopped,
    /// `t_max` was reached.
    TimeLimit,
    /// [`MAX_ATTEMPTS`] steps were tried: a bounded cost whatever the problem's stiffness or
    /// the tolerances asked (an inertia of 1e-12 needs steps of picoseconds).
    StepLimit,
    /// The step size fell below 1e-14 t_max: the tolerances cannot be met in double precision.
    StepSizeUnderflow,
    /// The error estimate was not finite: the state or its rate overflowed double precision
    /// (torques near 1e300 N m), which no smaller step mends.
    Overflow,
}

/// What the caller of [`integrate_until`] says of an accepted step.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Verdict {
    /// Go on.
    Go,
    /// Stop here: the stop test passed.
    Stop,
    /// Take the step again from its start, this long (an event within it: land on it). The
    /// step-size controller is not told of the step taken back.
    Redo(f64),
    /// The system changed at this state (an event landed on): its rate is evaluated again.
    Changed,
}

impl From<bool> for Verdict {
    /// A stop test's answer.
    fn from(stop: bool) -> Verdict {
        if stop {
            Verdict::Stop
        } else {
            Verdict::Go
        }
    }
}

/// The most steps (accepted or rejected) one integration tries: 3 evaluations each.
pub const MAX_ATTEMPTS: u32 = 1_000_000;

const SAFETY: f64 = 0.9;
const MIN_FACTOR: f64 = 0.2;
const MAX_FACTOR: f64 = 5.0;
/// Exponents of the proportional-integral step-size controller (Gustafsson; Hairer and Wanner,
/// Solving ODEs II, IV.2), in the form Hairer's DOPRI5 uses: alpha = 1/3 - 0.75 beta for an
/// error estimate of order 3. Settling is limited by the stability of the damped fast modes
/// (|lambda| up to c/I) more than by accuracy, and a plain controller at the stability boundary
/// alternates between growing the step and rejecting it; the integral term damps that out
/// (5% fewer evaluations on the prototype's sets; 0.7/3 and 0.4/3 were worse).
const ALPHA: f64 = 1.0 / 3.0 - 0.75 * BETA;
const BETA: f64 = 0.08;

/// Integrates from `y0` at t = 0 until `stop(t, y, dy)` says [`Verdict::Stop`] on an accepted
/// step (dy is the exact right-hand side at y) or until `t_max`; [`Verdict::Redo`] takes the
/// step again, shorter, and [`Verdict::Changed`] evaluates the rate at y again (the system
/// changed there). The first step is Hairer's estimate, or
/// `first_step` where that is longer (a caller that knows the system's time scale: from rest
/// the estimate sees only the acceleration, and the controller takes several steps to grow
/// out of it).
pub fn integrate_until<const N: usize, S, F>(
    sys: &S,
    y0: [f64; N],
    t_max: f64,
    tol: Tolerances,
    first_step: f64,
    mut stop: F,
) -> Outcome<N>
where
    S: OdeSystem<N>,
    F: FnMut(f64, &[f64; N], &[f64; N]) -> Verdict,
{
    let mut y = y0;
    let mut k1 = [0.0; N];
    sys.rhs(&y, &mut k1);
    let mut evaluations = 1u32;
    let mut steps = 0u32;
    let mut t = 0.0;
    let mut h = initial_step(sys, &y, &k1, t_max, tol, &mut evaluations)
        .max(first_step)
        .min(t_max);
    let (mut k2, mut k3, mut k4) = ([0.0; N], [0.0; N], [0.0; N]);
    let (mut tmp, mut y_new) = ([0.0; N], [0.0; N]);
    // ln of the error of the last accepted step, and whether the step before this was rejected
    let (mut ln_err_old, mut rejected) = (0.0f64, false);
    let mut end = End::TimeLimit;
    let mut attempts = 0u32;
    while t < t_max {
        attempts += 1;
        if attempts > MAX_ATTEMPTS {
            end = End::StepLimit;
            break;
        }
        let last = t + h >= t_max;
        if last {
            h = t_max - t;
        }
        for i in 0..N {
            tmp[i] = y[i] + 0.5 * h * k1[i];
        }
        sys.rhs(&tmp, &mut k2);
        for i in 0..N {
            tmp[i] = y[i] + 0.75 * h * k2[i];
        }
        sys.rhs(&tmp, &mut k3);
        for i in 0..N {
            y_new[i] = y[i] + h * (2.0 / 9.0 * k1[i] + 1.0 / 3.0 * k2[i] + 4.0 / 9.0 * k3[i]);
        }
        sys.rhs(&y_new, &mut k4);
        evaluations += 3;
        // third order minus the embedded second-order solution
        let mut sum = 0.0;
        for i in 0..N {
            let e = h
                * (-5.0 / 72.0 * k1[i] + 1.0 / 12.0 * k2[i] + 1.0 / 9.0 * k3[i]
                    - 1.0 / 8.0 * k4[i]);
            let scale = tol.atol + tol.rtol * y[i].abs().max(y_new[i].abs());
            sum += (e / scale) * (e / scale);
        }
        let err = (sum / N as f64).sqrt();
        if !err.is_finite() {
            end = End::Overflow;
            break;
        }
        if err <= 1.0 {
            let start = (t, y, k1);
            t = if last { t_max } else { t + h };
            y = y_new;
            k1 = k4;
            steps += 1;
            match stop(t, &y, &k1) {
                Verdict::Go => {}
                Verdict::Stop => {
                    return Outcome {
                        t,
                        y,
                        evaluations,
                        steps,
                        stopped: true,
                        end: End::Stopped,
                    }
                }
                Verdict::Redo(shorter) => {
                    (t, y, k1) = start;
                    steps -= 1;
                    h = shorter;
                    continue;
                }
                Verdict::Changed => {
                    sys.rhs(&y, &mut k1);
                    evaluations += 1;
                }
            }
            // err^-alpha * err_old^beta, with one logarithm and one exponential per step
            let ln_err = err.max(1e-10).ln();
            let factor =
                (SAFETY * (BETA * ln_err_old - ALPHA * ln_err).exp()).clamp(MIN_FACTOR, MAX_FACTOR);
            h *= if rejected { factor.min(1.0) } else { factor };
            ln_err_old = ln_err;
            rejected = false;
        } else {
            h *= (SAFETY / err.cbrt()).max(MIN_FACTOR);
            rejected = true;
            if h < t_max * 1e-14 {
                end = End::StepSizeUnderflow;
                break;
            }
        }
    }
    Outcome {
        t,
        y,
        evaluations,
        steps,
        stopped: false,
        end,
    }
}

/// The starting step of Hairer, Norsett and Wanner (Solving ODEs I, II.4), for order 3.
fn initial_step<const N: usize, S: OdeSystem<N>>(
    sys: &S,
    y: &[f64; N],
    f0: &[f64; N],
    t_max: f64,
    tol: Tolerances,
    evaluations: &mut u32,
) -> f64 {
    let scale = |i: usize| tol.atol + tol.rtol * y[i].abs();
    let rms = |v: &dyn Fn(usize) -> f64| {
        ((0..N).map(|i| (v(i) / scale(i)).powi(2)).sum::<f64>() / N as f64).sqrt()
    };
    let d0 = rms(&|i| y[i]);
    let d1 = rms(&|i| f0[i]);
    let h0 = if d0 < 1e-5 || d1 < 1e-5 {
        1e-6
    } else {
        0.01 * d0 / d1
    }
    .min(t_max);
    let mut y1 = [0.0; N];
    for i in 0..N {
        y1[i] = y[i] + h0 * f0[i];
    }
    let mut f1 = [0.0; N];
    sys.rhs(&y1, &mut f1);
    *evaluations += 1;
    let d2 = rms(&|i| f1[i] - f0[i]) / h0;
    let h1 = if d1.max(d2) <= 1e-15 {
        (h0 * 1e-3).max(1e-6)
    } else {
        (0.01 / d1.max(d2)).powf(1.0 / 3.0)
    };
    (100.0 * h0).min(h1).min(t_max)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A damped oscillator x'' + 2 z w x' + w^2 x = 0.
    struct Oscillator {
        w: f64,
        z: f64,
    }

    impl OdeSystem<2> for Oscillator {
        fn rhs(&self, y: &[f64; 2], dy: &mut [f64; 2]) {
            dy[0] = y[1];
            dy[1] = -2.0 * self.z * self.w * y[1] - self.w * self.w * y[0];
        }
    }

    #[test]
    fn third_order_accuracy_on_a_damped_oscillator() {
        let osc = Oscillator { w: 3.0, z: 0.2 };
        let exact = |t: f64| {
            let wd = osc.w * (1.0 - osc.z * osc.z).sqrt();
            let a = osc.z * osc.w;
            (-a * t).exp() * ((wd * t).cos() + a / wd * (wd * t).sin())
        };
        let mut errs = Vec::new();
        for rtol in [1e-4, 1e-6, 1e-8] {
            let tol = Tolerances {
                rtol,
                atol: rtol * 1e-2,
            };
            let out = integrate_until(&osc, [1.0, 0.0], 2.0, tol, 0.0, |_, _, _| Verdict::Go);
            assert!(!out.stopped);
            assert_eq!(out.t, 2.0);
            errs.push((out.y[0] - exact(2.0)).abs());
        }
        // tighter tolerances give smaller global errors, and the tightest is accurate
        assert!(errs[0] > errs[1] && errs[1] > errs[2], "{errs:?}");
        assert!(errs[2] < 1e-7, "{errs:?}");
    }

    #[test]
    fn the_stop_test_sees_accepted_states_and_their_exact_derivative() {
        let osc = Oscillator { w: 3.0, z: 0.5 };
        let tol = Tolerances {
            rtol: 1e-3,
            atol: 1e-6,
        };
        let mut seen = 0;
        let out = integrate_until(&osc, [1.0, 0.0], 50.0, tol, 0.0, |_, y, dy| {
            seen += 1;
            let mut f = [0.0; 2];
            osc.rhs(y, &mut f);
            assert_eq!(&f, dy);
            Verdict::from(y[0].abs() < 1e-3 && y[1].abs() < 1e-3)
        });
        assert!(out.stopped && out.t < 50.0);
        assert_eq!(seen, out.steps);
        assert!(out.y[0].abs() < 1e-3);
    }
}
