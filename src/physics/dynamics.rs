//! Rigid-body dynamics of the rotor (paper section 3.4): the quaternion equations of motion
//! with viscous damping under the summed magnet torques, integrated until the ball has settled;
//! `settle_many` settles many active sets from one orientation in parallel.
//!
//! Two paths reach the same equilibria: the fast path (the default, `settle_fast`), an
//! allocation-free Bogacki-Shampine 3(2) stepper from `integrator` while the motion is
//! nonlinear and a closed-form linear end phase about the strict minimum it comes to (with a
//! tight fallback where it cannot be sure), and the reference path, ode_solvers' Dopri5 at
//! whatever tolerances are asked (`SettleParams::reference()` is tight). tests/basins.rs and
//! examples/basins.rs check the one against the other on random sets; tests/settle.rs pins 54.

use crate::model::geometry::{Orientation, Pair};
use crate::physics::integrator::{integrate_until, End, OdeSystem, Outcome, Tolerances};
use crate::physics::torque::{rotation_matrix, TorqueModel};
use nalgebra::{Quaternion, UnitQuaternion, Vector3};
use ode_solvers::dop_shared::IntegrationError;
use ode_solvers::{Dopri5, OutputType, SVector, System};
use rayon::prelude::*;
use serde::{Deserialize, Serialize};

/// Rotor state: (q1, q2, q3, q4, w1, w2, w3), with w the body angular velocity.
pub type State = SVector<f64, 7>;

/// Mass properties and damping of the rotor.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Body {
    /// Principal moments of inertia (Ixx, Iyy, Izz), kg m^2.
    pub inertia: Vector3<f64>,
    /// Viscous damping coefficient c, N m s / rad.
    pub damping: f64,
}

/// Which integrator settles the ball.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Method {
    /// The fast path: spherestep's own Bogacki-Shampine 3(2) stepper.
    #[default]
    Bs32,
    /// The reference path: ode_solvers' Dormand-Prince 5(4).
    Dopri5,
}

/// When the ball counts as settled, and how to integrate.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SettleParams {
    /// |w| below this (rad/s) ...
    pub omega_tol: f64,
    /// ... and |N_B| below this (N m): settled.
    pub torque_tol: f64,
    /// Give up (not settled) at this simulated time, s.
    pub t_max: f64,
    /// Relative and absolute tolerances of the integrator.
    pub rtol: f64,
    pub atol: f64,
    /// The integrator.
    pub method: Method,
    /// Where no strict minimum holds the ball (a pair out of reach, a magnet at its well's
    /// cut-off), where it stops along the free direction depends on the whole coast: `true`
    /// (the default) integrates it again at tight tolerances to find out; `false` stops there
    /// and says [`Stop::Unheld`] (for planners, which discard such sets: a set that holds is
    /// settled the same either way).
    pub follow_unheld: bool,
}

impl Default for SettleParams {
    fn default() -> Self {
        SettleParams {
            omega_tol: 1e-3,
            torque_tol: 1e-4,
            t_max: 5.0,
            rtol: 1e-2,
            atol: 1e-5,
            method: Method::Bs32,
            follow_unheld: true,
        }
    }
}

impl SettleParams {
    /// The same settle test, integrated by ode_solvers' Dopri5 at tight tolerances: the yardstick
    /// that the fast path is checked against.
    pub fn reference(self) -> Self {
        SettleParams {
            rtol: 1e-10,
            atol: 1e-12,
            method: Method::Dopri5,
            ..self
        }
    }
}

/// What a settle found.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct SettleResult {
    /// Final orientation (renormalised), body to world.
    #[serde(skip)]
    pub q: Orientation,
    /// Simulated time at which the ball settled (or `t_max`), s.
    pub settle_time_s: f64,
    /// Right-hand-side evaluations.
    pub evaluations: u32,
    /// Accepted integrator steps.
    pub steps: u32,
    /// Potential energy at the end, J.
    pub energy_j: f64,
    /// |N_B| at the end, N m.
    pub residual_torque_nm: f64,
    /// Whether the settle test passed before `t_max`.
    pub settled: bool,
    /// Why the settle ended (`Settled` exactly when `settled`).
    pub stop: Stop,
}

/// Why a settle ended.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Stop {
    /// The settle test passed.
    Settled,
    /// `t_max` came first.
    TimeLimit,
    /// The cap on integrator steps came first (`integrator::MAX_ATTEMPTS` for the fast path,
    /// [`REFERENCE_MAX_STEPS`] for Dopri5): every settle has a bounded cost.
    StepLimit,
    /// The step size collapsed: the tolerances cannot be met in double precision.
    StepSizeUnderflow,
    /// The motion overflowed double precision (a torque, speed or error estimate beyond
    /// 1e308): the wells are far too strong for the body, not the tolerances too tight.
    Overflow,
    /// No strict minimum holds the ball (a direction is free: a pair out of reach, a magnet at
    /// its well's cut-off), and [`SettleParams::follow_unheld`] said not to follow it.
    Unheld,
}

impl Stop {
    /// A sentence for people.
    pub fn describe(self) -> &'static str {
        match self {
            Stop::Settled => "settled",
            Stop::TimeLimit => "not settled by t_max",
            Stop::StepLimit => "stopped by the cap on integrator steps",
            Stop::StepSizeUnderflow => {
                "stopped: the step size collapsed (tolerances too tight, or wells far too stiff \
                 for the body's inertia?)"
            }
            Stop::Overflow => {
                "stopped: the motion overflowed double precision (torques or speeds beyond \
                 1e308: wells far too strong for the body; check the [magnets] values)"
            }
            Stop::Unheld => "not held: no strict minimum holds the ball (not followed further)",
        }
    }
}

impl From<End> for Stop {
    fn from(e: End) -> Stop {
        match e {
            End::Stopped => Stop::Settled,
            End::TimeLimit => Stop::TimeLimit,
            End::StepLimit => Stop::StepLimit,
            End::StepSizeUnderflow => Stop::StepSizeUnderflow,
            End::Overflow => Stop::Overflow,
        }
    }
}

/// The most steps the Dopri5 path (the reference, and the fast path's tight fallback) takes.
pub const REFERENCE_MAX_STEPS: u32 = 1_000_000;

/// The equations of motion for one active set.
pub struct RotorDynamics<'a, M: TorqueModel> {
    pub model: &'a M,
    pub active: &'a [Pair],
    pub body: Body,
    /// 1 / I, per axis.
    inv_inertia: Vector3<f64>,
    /// Whether I is the same about every axis (then w x (I w) = 0).
    isotropic: bool,
}

impl<'a, M: TorqueModel> RotorDynamics<'a, M> {
    pub fn new(model: &'a M, active: &'a [Pair], body: Body) -> Self {
        RotorDynamics {
            model,
            active,
            body,
            inv_inertia: body.inertia.map(|i| 1.0 / i),
            isotropic: body.inertia.x == body.inertia.y && body.inertia.x == body.inertia.z,
        }
    }

    /// Body-frame torque N_B at the orientation held in `y` (which need not be normalised).
    pub fn body_torque(&self, y: &[f64; 7]) -> Vector3<f64> {
        self.model
            .body_torque_at(&[y[0], y[1], y[2], y[3]], self.active)
    }

    /// dy/dt: dq/dt = 1/2 (q4 w - w x q), dq4/dt = -1/2 w . q,
    /// dw/dt = I^-1 [ -w x (I w) + N_B - c w ].
    #[inline]
    pub fn derivative(&self, y: &[f64; 7], dy: &mut [f64; 7]) {
        let (q1, q2, q3, q4) = (y[0], y[1], y[2], y[3]);
        let w = Vector3::new(y[4], y[5], y[6]);
        let qv = Vector3::new(q1, q2, q3);
        let dqv = (w * q4 - w.cross(&qv)) * 0.5;
        dy[0] = dqv.x;
        dy[1] = dqv.y;
        dy[2] = dqv.z;
        dy[3] = -0.5 * w.dot(&qv);
        let nb = self.body_torque(y);
        let i = self.body.inertia;
        let mut rhs = nb - w * self.body.damping;
        if !self.isotropic {
            rhs -= w.cross(&i.component_mul(&w));
        }
        let dw = rhs.component_mul(&self.inv_inertia);
        dy[4] = dw.x;
        dy[5] = dw.y;
        dy[6] = dw.z;
    }

    /// The settle test on a state and its exact derivative.
    fn settled(&self, params: &SettleParams, y: &[f64], dy: &[f64]) -> bool {
        let w = Vector3::new(y[4], y[5], y[6]);
        // |w| < omega_tol and |N_B| < torque_tol, without square roots
        if w.norm_squared() >= params.omega_tol * params.omega_tol {
            return false;
        }
        self.torque_from(y, dy).norm_squared() < params.torque_tol * params.torque_tol
    }

    /// N_B recovered from a state and its exact derivative, without another torque evaluation:
    /// N_B = I dw/dt + w x (I w) + c w.
    fn torque_from(&self, y: &[f64], dy: &[f64]) -> Vector3<f64> {
        let w = Vector3::new(y[4], y[5], y[6]);
        let dw = Vector3::new(dy[4], dy[5], dy[6]);
        let i = self.body.inertia;
        let mut nb = i.component_mul(&dw) + w * self.body.damping;
        if !self.isotropic {
            nb += w.cross(&i.component_mul(&w));
        }
        nb
    }
}

impl<M: TorqueModel> OdeSystem<7> for RotorDynamics<'_, M> {
    #[inline]
    fn rhs(&self, y: &[f64; 7], dy: &mut [f64; 7]) {
        self.derivative(y, dy)
    }
}

/// ode_solvers' view of the same equations, with the settle test as its stop test (Sparse
/// output: `solout` sees each accepted step and its exact derivative). The test is also applied
/// within each step, at [`SUBSTEPS`] points of the cubic Hermite interpolant of its ends: a
/// tight integration takes steps of 10 ms and more near the end, and a test that passes only
/// briefly (|N_B| dipping below its tolerance as the torque swings through zero) would be seen
/// late or never at the steps alone.
struct ReferenceRun<'a, 'b, M: TorqueModel> {
    dynamics: &'b RotorDynamics<'a, M>,
    params: SettleParams,
    /// The last accepted step: t, y, dy/dt.
    previous: Option<(f64, [f64; 7], [f64; 7])>,
    /// The first instant the settle test passed, and the state there.
    settled_at: Option<(f64, [f64; 7])>,
}

/// Points per step (the step's end included) at which the reference applies the settle test.
const SUBSTEPS: u32 = 8;

impl<M: TorqueModel> ReferenceRun<'_, '_, M> {
    /// The first of the step's test points at which the settle test passes.
    fn settled_within(
        &self,
        (t0, y0, dy0): (f64, [f64; 7], [f64; 7]),
        (t1, y1, dy1): (f64, [f64; 7], [f64; 7]),
    ) -> Option<(f64, [f64; 7])> {
        let h = t1 - t0;
        for j in 1..SUBSTEPS {
            let s = j as f64 / SUBSTEPS as f64;
            let [a0, b0, a1, b1] = hermite_weights(s);
            let (b0, b1) = (b0 * h, b1 * h);
            let y: [f64; 7] =
                std::array::from_fn(|k| a0 * y0[k] + b0 * dy0[k] + a1 * y1[k] + b1 * dy1[k]);
            // |w| first: the torque is evaluated only where the ball is slow enough
            if Vector3::new(y[4], y[5], y[6]).norm() < self.params.omega_tol
                && self.dynamics.body_torque(&y).norm() < self.params.torque_tol
            {
                return Some((t0 + s * h, y));
            }
        }
        self.dynamics
            .settled(&self.params, &y1, &dy1)
            .then_some((t1, y1))
    }
}

impl<M: TorqueModel> System<f64, State> for &mut ReferenceRun<'_, '_, M> {
    fn system(&self, _t: f64, y: &State, dy: &mut State) {
        let mut out = [0.0; 7];
        self.dynamics.derivative(&as_array(y), &mut out);
        dy.copy_from_slice(&out);
    }

    fn solout(&mut self, t: f64, y: &State, dy: &State) -> bool {
        let now = (t, as_array(y), as_array(dy));
        let found = match self.previous {
            Some(before) if t > before.0 => self.settled_within(before, now),
            _ => self
                .dynamics
                .settled(&self.params, &now.1, &now.2)
                .then_some((t, now.1)),
        };
        self.previous = Some(now);
        self.settled_at = found;
        found.is_some()
    }
}

fn as_array(y: &State) -> [f64; 7] {
    [y[0], y[1], y[2], y[3], y[4], y[5], y[6]]
}

/// Settles the ball from rest at `q0` under the active set: integrates until the settle test
/// passes or `t_max` is reached.
pub fn settle<M: TorqueModel>(
    model: &M,
    active: &[Pair],
    q0: &Orientation,
    body: Body,
    params: SettleParams,
) -> SettleResult {
    settle_traced(model, active, q0, body, params, None)
}

/// [`settle`], also appending every accepted step (t, state) to `trace` when one is given.
pub fn settle_traced<M: TorqueModel>(
    model: &M,
    active: &[Pair],
    q0: &Orientation,
    body: Body,
    params: SettleParams,
    trace: Option<&mut Vec<(f64, State)>>,
) -> SettleResult {
    let y0 = [q0.i, q0.j, q0.k, q0.w, 0.0, 0.0, 0.0];
    if let Some(near) = model.nearby(&rotation_matrix(y0[0], y0[1], y0[2], y0[3]), active) {
        // the same torques to the bit, fewer magnets visited
        return settle_from(&near, active, y0, body, params, trace);
    }
    settle_from(model, active, y0, body, params, trace)
}

/// [`settle_traced`] from the state `y0` (at rest) with the model as given.
fn settle_from<M: TorqueModel>(
    model: &M,
    active: &[Pair],
    y0: [f64; 7],
    body: Body,
    params: SettleParams,
    trace: Option<&mut Vec<(f64, State)>>,
) -> SettleResult {
    let sys = RotorDynamics::new(model, active, body);
    if sys.body_torque(&y0).norm() < params.torque_tol {
        // Already in equilibrium and at rest.
        return finish(model, active, &y0, 0.0, 1, 0, Stop::Settled);
    }
    match params.method {
        Method::Bs32 => settle_fast(&sys, y0, params, trace),
        Method::Dopri5 => settle_dopri5(&sys, y0, params, trace),
    }
}

/// The energy-equivalent amplitude (rad) about a minimum below which the fast path hands the
/// rest of the settle to the linear end phase: there the wells' torques are linear in the angle
/// to within about this amplitude over their width (0.2% for 10 degree gaussians). 3e-2 began to
/// move settle times beyond the reference's bounds on heavily damped sets; 2e-3 cost 25% more
/// evaluations for the same agreement.
const LINEAR_RADIUS: f64 = 1e-2;
/// Newton iterations allowed to find the minimum from the switch point.
const NEWTON_ITERATIONS: u32 = 8;
/// A Newton step shorter than this (rad) ends the search without a linearization to verify it:
/// Newton converges quadratically, so the torque left after it is about |dK/d delta| step^2.
/// On the 28,000 sets of examples/basins.rs and its 7,000 "coils" sets it was at most 5.3e-12
/// of the stiffness scale, far below the 1e-9 of the residual test; the stiffness used is the
/// one at 1e-6 rad from the minimum.
const NEWTON_DONE: f64 = 1e-6;
/// Early exits from the end phase's Newton search: after its first and second steps, the
/// amplitude test below is estimated from the steps so far and the stiffness there, and a
/// switch point whose estimate exceeds [`LINEAR_RADIUS`] by these factors is refused at once
/// instead of after the 3 or 4 linearizations a converged search takes. On 7,000 sets of
/// examples/basins.rs (16,637 searches), the estimates of the searches that succeeded were at
/// most 1.24 (first) and 1.02 (second) times the radius; exits at 2.0 and 1.3 refused 24% and
/// then 30% of the 9,869 that failed, and on its 28,000 sets every settle was the same to the
/// bit as without them (1.1 for the second changed one light-damping set: it was refused there,
/// then switched later). 1.3 after the first step too refuses one linearization sooner where
/// 2.0 waited for the second (the benchmark's 3-pair set: 73 evaluations instead of 74; the 200
/// sets of examples/settle_sets.rs settle to the same results).
const EARLY_EXIT: [f64; 2] = [1.3, 1.3];
/// Samples per unit of the fastest mode's natural period over 2 pi (1/omega_0): the end phase
/// looks for the first instant of the settle test on a grid of step 0.1 / omega_0, as fine as
/// the reference's own steps there.
const SAMPLE_STEP: f64 = 0.1;
/// The most samples the end phase takes (a bounded cost whatever t_max and the damping are).
const MAX_SAMPLES: u64 = 1_000_000;

/// The fast path's stiffness scale (isotropic bodies of models that have one: the linear
/// regime and its Newton finish are then available) and its relative tolerance, tighter for
/// light damping.
fn fast_tolerance<M: TorqueModel>(
    sys: &RotorDynamics<'_, M>,
    params: &SettleParams,
) -> (Option<f64>, f64) {
    let i = sys.body.inertia;
    let isotropic = (i.x - i.y).abs() <= 1e-12 * i.x && (i.x - i.z).abs() <= 1e-12 * i.x;
    let scale = sys.model.stiffness_scale().filter(|_| isotropic);
    let rtol = match scale {
        Some(k1) => {
            let zeta = sys.body.damping / (2.0 * (k1 * i.x).sqrt());
            params
                .rtol
                .min(NONLINEAR_RTOL)
                .min((NONLINEAR_RTOL_PER_ZETA2 * zeta * zeta).max(NONLINEAR_RTOL_FLOOR))
        }
        None => params.rtol,
    };
    (scale, rtol)
}

/// What the fast path's integration `out` (ended without the Newton finish) says: the ball
/// where the stepper left it and why it stopped; never settled without damping; a stop near
/// rest but never near a strict minimum (`linear`: the model has a linear regime) is
/// re-integrated tightly, or reported unheld when the set need not be followed.
fn conclude<M: TorqueModel>(
    sys: &RotorDynamics<'_, M>,
    y0: [f64; 7],
    params: SettleParams,
    out: &Outcome<7>,
    evaluations: u32,
    linear: bool,
) -> SettleResult {
    // where the stepper left the ball, and why it says it stopped
    let stopped_here = |stop: Stop| {
        finish(
            sys.model,
            sys.active,
            &out.y,
            out.t,
            evaluations,
            out.steps,
            stop,
        )
    };
    if sys.body.damping <= 0.0 {
        // Undamped, the ball never settles (it was not at rest in equilibrium at the start):
        // whatever the stepper's own dissipation did, the physics says no.
        return stopped_here(match out.end {
            End::Stopped => Stop::TimeLimit,
            e => e.into(),
        });
    }
    let near_rest = |y: &[f64; 7]| {
        Vector3::new(y[4], y[5], y[6]).norm() < NEAR_REST * params.omega_tol
            && sys.body_torque(y).norm() < NEAR_REST * params.torque_tol
    };
    let unsure = match out.end {
        End::Stopped => true,
        End::TimeLimit => near_rest(&out.y),
        _ => false,
    };
    if linear && unsure {
        // settled (or nearly at rest at t_max), but never near a strict minimum: not sure where
        // along the free direction the ball stops, nor when
        if !params.follow_unheld {
            return stopped_here(Stop::Unheld);
        }
        return settle_tight(sys, y0, params, evaluations);
    }
    stopped_here(out.end.into())
}

/// The fast path: Bogacki-Shampine 3(2) at the scenario's (loose) tolerances while the motion
/// is nonlinear, then, once the ball moves within [`LINEAR_RADIUS`] of a strict minimum (found
/// by Newton on the torque, positive-definite stiffness, no magnet near its well's cut-off), the
/// linear damped motion about that minimum solved in closed form, mode by mode, for the first
/// instant it meets the settle test. Integrating that creep step by step is what an explicit
/// stepper does worst: it runs at its stability limit there, where its own (anti-)damping, not
/// the physics', decides when the test passes.
///
/// If the nonlinear phase ends (the settle test passes, or t_max) without a strict minimum (a
/// direction that nothing holds: a pair out of reach, a neutral rotation about a lone pair's
/// axis), where the ball stops along that direction depends on how accurately the whole coast
/// was integrated, which a loose tolerance cannot promise (at its stability limit the stepper
/// neither damps nor stops the free rotation): the settle is run again at tight tolerances.
fn settle_fast<M: TorqueModel>(
    sys: &RotorDynamics<'_, M>,
    y0: [f64; 7],
    params: SettleParams,
    mut trace: Option<&mut Vec<(f64, State)>>,
) -> SettleResult {
    let (scale, rtol) = fast_tolerance(sys, &params);
    let tol = Tolerances {
        rtol,
        atol: params.atol,
    };
    // a tenth of the time scale sqrt(I / K) of the active pairs together
    let first_step = scale.map_or(0.0, |k1| {
        FIRST_STEP * (sys.body.inertia.x / (k1 * sys.active.len().max(1) as f64)).sqrt()
    });
    // The graze watch: each pair's cut-off margin and its rate at the last accepted step, and
    // now. A margin changes no faster than |w| (|d(p . s)/dt| <= |w|), so while the ball has
    // turned less since the margins were last looked at than the least of them (less
    // GRAZE_EPS, with |w| taken at twice the larger of a step's ends), no pair can have come
    // near its cut-off and the margins are not computed.
    let (mut before, mut now) = (Vec::new(), Vec::new());
    let r0 = rotation_matrix(y0[0], y0[1], y0[2], y0[3]);
    let mut watch = scale.is_some()
        && sys
            .model
            .cutoff_margins(&r0, &Vector3::zeros(), sys.active, &mut before);
    // where the watch cannot follow the margins, the approach may have crossed a cut-off
    let trusted = watch && sys.model.trusts_uncrossed_cutoffs();
    let mut search = scale.map(|k1| EndSearch::new(k1, !trusted));
    let least = |m: &[(f64, f64)]| m.iter().fold(f64::INFINITY, |a, &(x, _)| a.min(x.abs()));
    let mut slack = least(&before) - GRAZE_EPS;
    let (mut y_before, mut t_before, mut w_before, mut turned) = (y0, 0.0, 0.0f64, 0.0);
    // whether `now` holds the margins at y_before (the last step looked at them)
    let mut looked = false;
    let mut grazed = false;
    let out = integrate_until(sys, y0, params.t_max, tol, first_step, |t, y, dy| {
        if let Some(tr) = trace.as_deref_mut() {
            tr.push((t, State::from_column_slice(y)));
        }
        if sys.settled(&params, y, dy) {
            return true;
        }
        if watch {
            let w_now = Vector3::new(y[4], y[5], y[6]).norm();
            let h = t - t_before;
            turned += 2.0 * w_now.max(w_before) * h;
            if turned >= slack {
                let margins = |y: &[f64; 7], out: &mut Vec<(f64, f64)>| {
                    out.clear();
                    let r = rotation_matrix(y[0], y[1], y[2], y[3]);
                    let w = Vector3::new(y[4], y[5], y[6]);
                    sys.model.cutoff_margins(&r, &w, sys.active, out)
                };
                if looked {
                    std::mem::swap(&mut before, &mut now);
                }
                // the watch ends where the model offers no margins (a "coils" model beyond its
                // skin)
                watch = (looked || margins(&y_before, &mut before)) && margins(y, &mut now);
                if watch && before.iter().zip(&now).any(|(&a, &b)| grazes(a, b, h)) {
                    grazed = true;
                    return true;
                }
                let crossed = !watch
                    || before
                        .iter()
                        .zip(&now)
                        .any(|(a, b)| (a.0 < 0.0) != (b.0 < 0.0));
                if let Some(s) = search.as_mut().filter(|_| crossed) {
                    s.crossed = true;
                }
                slack = least(&now) - GRAZE_EPS;
                turned = 0.0;
                looked = true;
            } else {
                looked = false;
            }
            (y_before, t_before, w_before) = (*y, t, w_now);
        }
        search.as_mut().is_some_and(|s| s.stops(sys, t, y, dy))
    });
    let (newton_evals, end) = search.map_or((0, None), |s| (s.evaluations, s.found));
    let evaluations = out.evaluations + newton_evals;
    if let Some(e) = end {
        let (t, y, settled) = e.solve(sys.body, &params);
        if let Some(tr) = trace {
            tr.push((t, State::from_column_slice(&y)));
        }
        return finish(
            sys.model,
            sys.active,
            &y,
            t,
            evaluations,
            out.steps,
            if settled {
                Stop::Settled
            } else {
                Stop::TimeLimit
            },
        );
    }
    if grazed {
        // where the ball goes from a graze hangs on errors this tolerance allows
        return settle_tight(sys, y0, params, evaluations);
    }
    conclude(sys, y0, params, &out, evaluations, scale.is_some())
}

/// The fast path's fallback: the settle from the start by Dopri5 at [`FALLBACK_RTOL`], its
/// evaluations counted on top of the `spent` ones.
fn settle_tight<M: TorqueModel>(
    sys: &RotorDynamics<'_, M>,
    y0: [f64; 7],
    params: SettleParams,
    spent: u32,
) -> SettleResult {
    let tight = SettleParams {
        rtol: FALLBACK_RTOL,
        atol: FALLBACK_ATOL,
        ..params
    };
    let mut r = settle_dopri5(sys, y0, tight, None);
    r.evaluations = r.evaluations.saturating_add(spent);
    r
}

/// The fast path's least first step, in units of the time scale sqrt(I / (n K)) of its n
/// active pairs: from rest Hairer's estimate starts 50 to 100 times shorter, and the step took
/// 6 or 7 steps to grow out of it. On the 200 sets of examples/settle_sets.rs the median settle
/// takes 70.5 evaluations instead of 81; on the 28,000 of examples/basins.rs none lands in
/// another equilibrium, and 297 settle times are outside the reference's bounds (307 without).
/// 0.2 saves 2 evaluations more but leaves 319 outside.
const FIRST_STEP: f64 = 0.1;

/// The loosest relative tolerance of the fast path's nonlinear phase (a looser scenario rtol is
/// tightened to it) ...
const NONLINEAR_RTOL: f64 = 1e-2;
/// ... and, for light damping, at most this times the damping ratio squared (zeta = c over
/// 2 sqrt(K I), K one aligned pair's stiffness), never below [`NONLINEAR_RTOL_FLOOR`]: the
/// stepper's error per oscillation must stay small against the damping's loss per oscillation
/// (about 4 pi zeta of the energy). At 0.2 of critical damping and rtol 1e-2, the stepper's own
/// damping of the oscillations, not the physics', decided when sets came near their minimum
/// (settle times 0.2 to 0.6 s early) and 3 sets in 1,000 ended in another equilibrium; rtol 1e-3
/// still put 1 in 2,000 there, 1e-4 none (examples/basins.rs).
const NONLINEAR_RTOL_PER_ZETA2: f64 = 2.5e-3;
const NONLINEAR_RTOL_FLOOR: f64 = 1e-5;

/// A minimum with a magnet closer than this (rad, 2 degrees) to its well's cut-off is not
/// trusted where the approach may have crossed a cut-off (the graze watch saw a margin change
/// sign, or cannot follow the margins): the ball came there across the discontinuity of the
/// torque, where whether a magnet drifts out of reach or falls back in is decided by errors a
/// loose tolerance allows (before the graze watch, one set in 4,000 of examples/basins.rs ended
/// 3.4 degrees from the reference's equilibrium so): the settle is run again at tight
/// tolerances. In the "pairs" interaction an approach that stayed on one side of every cut-off
/// is as smooth as any other, and its minimum is trusted
/// ([`TorqueModel::trusts_uncrossed_cutoffs`]): on the 28,000 sets of examples/basins.rs (seeds
/// 17 to 19) none lands in another equilibrium and 247, 243 and 270 settle times are outside
/// the reference's bounds (261, 256 and 273 before), for 13% fewer evaluations (seed 17); on
/// the 200 sets of examples/settle_sets.rs it spares the tight run of a set in two orders
/// (2,254 evaluations each). In the "coils" interaction it moved 17 more of the 7,000 sets of
/// `basins --coils` outside the bounds, and one set's settled flag at t_max: not trusted there.
/// (One of them, looked at: the end phase's motion is right, to 1e-5 N m against the reference's
/// trajectory, but the reference meets the settle test in a dip of the oscillation about 0.2 ms
/// wide, which the end phase's grid of [`SAMPLE_STEP`] / omega_0 steps over, even 10 times finer;
/// it then meets it one period, 0.14 s, later. The reference saw the dip at one of its
/// [`SUBSTEPS`] test points in a step of about 1 ms: so narrow a dip is found by either grid or
/// not, and the first instant of the continuous test, in both, would settle the question.)
const CUTOFF_SAFETY: f64 = 0.035;

/// A pair's magnet that comes this close to its well's cut-off (in cosine: 1e-4 is 0.013
/// degrees at a 25 degree cut-off) and turns back, or dips across and back within a step, sends
/// the fast path to its tight fallback: whether it leaves reach there, and the torque jumps, is
/// decided by errors its tolerance allows. On examples/basins.rs one set in 4,000 of the
/// cosine, light-damping kind (seeds 18 and 19) ended 0.12 and 0.32 rad from the reference's
/// equilibrium so; 1e-5 caught seed 19's only. The cost: the sets that graze (3 to 15% of the
/// random sets, most at light damping) settle at tight tolerances.
const GRAZE_EPS: f64 = 1e-4;

/// Points of a step's interpolant at which [`grazes`] looks.
const GRAZE_SAMPLES: u32 = 16;

/// Whether a pair's cut-off margin m, (m0, dm0/dt) at a step's start and (m1, dm1/dt) at its
/// end `h` later, grazes the cut-off over the step: comes within [`GRAZE_EPS`] of 0 on the
/// cubic Hermite interpolant without ending on the other side, or dips across and back.
fn grazes((m0, rate0): (f64, f64), (m1, rate1): (f64, f64), h: f64) -> bool {
    if m0.signum() != m1.signum() {
        // a crossing, not a graze
        return false;
    }
    let (d0, d1, dm) = (rate0 * h, rate1 * h, m1 - m0);
    // the interpolant departs from the chord by at most a quarter of |d0 - dm| + |d1 - dm|:
    // most steps are ruled out here
    if m0.abs().min(m1.abs()) > GRAZE_EPS + 0.25 * ((d0 - dm).abs() + (d1 - dm).abs()) {
        return false;
    }
    (0..=GRAZE_SAMPLES).any(|j| {
        let [a0, b0, a1, b1] = hermite_weights(j as f64 / GRAZE_SAMPLES as f64);
        let m = a0 * m0 + b0 * d0 + a1 * m1 + b1 * d1;
        m.abs() < GRAZE_EPS || m.signum() != m0.signum()
    })
}

/// The cubic Hermite basis at s in [0, 1] of a step: the weights of the value at its start, of
/// the step times the rate there, of the value at its end and of the step times the rate there.
fn hermite_weights(s: f64) -> [f64; 4] {
    let (s2, s3) = (s * s, s * s * s);
    [
        2.0 * s3 - 3.0 * s2 + 1.0,
        s3 - 2.0 * s2 + s,
        3.0 * s2 - 2.0 * s3,
        s3 - s2,
    ]
}

/// At t_max without a strict minimum, the fast path falls back to the tight integration only
/// if the ball is this close to the settle test (times its tolerances): a free rotation the
/// stepper neither damps nor stops at its stability limit. A ball still moving faster than that
/// is not settling by t_max on either path, and is reported so at once. On examples/basins.rs
/// (seeds 17, 18 and 19: 84,000 sets) 30 gives the same results as 100 did; 10 let 11 sets of
/// seed 17 say "not settled" where the reference settles before t_max, 20 none. On the 200
/// sets of examples/settle_sets.rs, 30 spares the tight run of the two orders of a set still
/// creeping at t_max (2,700 evaluations each): 103 evaluations per settle on average, not 127.
const NEAR_REST: f64 = 30.0;

/// Tolerances of the tight integration the fast path falls back to. On the 28,000 sets of
/// examples/basins.rs, 1e-8 leaves as many sets outside the reference's bounds as 1e-9 (303 and
/// 302, none in another equilibrium) for 21% fewer evaluations; 1e-7 leaves 322, DOP853 at 1e-9
/// 341. (Before the reference applied its settle test within its steps, 1e-8 seemed worse: 756
/// against 666, most of them the reference's own late detection.)
const FALLBACK_RTOL: f64 = 1e-8;
const FALLBACK_ATOL: f64 = 1e-10;

/// Hamilton product of quaternions stored (x, y, z, w).
fn quat_mul(a: [f64; 4], b: [f64; 4]) -> [f64; 4] {
    [
        a[3] * b[0] + a[0] * b[3] + a[1] * b[2] - a[2] * b[1],
        a[3] * b[1] - a[0] * b[2] + a[1] * b[3] + a[2] * b[0],
        a[3] * b[2] + a[0] * b[1] - a[1] * b[0] + a[2] * b[3],
        a[3] * b[3] - a[0] * b[0] - a[1] * b[1] - a[2] * b[2],
    ]
}

/// The unit quaternion (x, y, z, w) of the rotation vector `v`.
fn quat_exp(v: &Vector3<f64>) -> [f64; 4] {
    let a = v.norm();
    let s = if a < 1e-8 {
        0.5 - a * a / 48.0
    } else {
        (0.5 * a).sin() / a
    };
    [v.x * s, v.y * s, v.z * s, (0.5 * a).cos()]
}

fn normalized(q: [f64; 4]) -> [f64; 4] {
    let n = (q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3]).sqrt();
    [q[0] / n, q[1] / n, q[2] / n, q[3] / n]
}

/// The watch for the linear end phase at accepted steps: once the torque and the rate are small
/// against the stiffness scale `k1`, Newton looks for the strict minimum ([`EndPhase::find`]).
/// Where it finds none it looks again after 1, 2, 4 ... 64 steps while the ball stays slow, and
/// from the first slow step again once the ball has moved fast in between: a slow pass near a
/// saddle must not put off the search near the minimum the ball goes on to (on one set of
/// examples/basins.rs the search came 5 s late so, the stepper meanwhile hovering at its
/// tolerance's noise floor near the minimum). A strict minimum refused only because the motion
/// about it would reach a magnet's cut-off is looked at again at the next step.
struct EndSearch {
    k1: f64,
    skip: u32,
    backoff: u32,
    /// Linearizations spent.
    evaluations: u32,
    /// Whether the approach may have crossed a well's cut-off (the graze watch saw a margin
    /// change sign, or could not follow the margins): a minimum near a cut-off is then not
    /// trusted ([`CUTOFF_SAFETY`]).
    crossed: bool,
    found: Option<EndPhase>,
}

/// Why [`EndPhase::find`] found no end phase.
enum Refusal {
    /// No strict minimum near (Newton diverged or left the linear radius, the stiffness is not
    /// positive definite, the motion from here is beyond the linear radius).
    NotNear,
    /// A strict minimum, but the motion about it would reach a magnet's cut-off: it shrinks as
    /// the ball settles.
    Wide,
    /// A strict minimum within [`CUTOFF_SAFETY`] of a cut-off that the approach may have
    /// crossed: the settle is unsure.
    NearCutoff,
}

impl EndSearch {
    fn new(k1: f64, crossed: bool) -> EndSearch {
        EndSearch {
            k1,
            skip: 0,
            backoff: 1,
            evaluations: 0,
            crossed,
            found: None,
        }
    }

    /// Whether the integration stops at the accepted step (t, y) with derivative dy: the end
    /// phase is found, or a minimum near a well's cut-off is (the settle is then unsure).
    fn stops<M: TorqueModel>(
        &mut self,
        sys: &RotorDynamics<'_, M>,
        t: f64,
        y: &[f64; 7],
        dy: &[f64; 7],
    ) -> bool {
        let w = Vector3::new(y[4], y[5], y[6]);
        let nb = sys.torque_from(y, dy);
        let k1 = self.k1;
        // |N_B| > r k1 or |w| > r sqrt(k1 / I), without square roots
        let r2 = LINEAR_RADIUS * LINEAR_RADIUS;
        if nb.norm_squared() > r2 * k1 * k1 || w.norm_squared() > r2 * k1 / sys.body.inertia.x {
            // moving: the next slow stretch is searched from its start
            (self.skip, self.backoff) = (0, 1);
            return false;
        }
        if self.skip > 0 {
            self.skip -= 1;
            return false;
        }
        match EndPhase::find(sys, y, t, &mut self.evaluations, self.crossed) {
            Ok(e) => {
                self.found = Some(e);
                true
            }
            Err(Refusal::NearCutoff) => true,
            Err(Refusal::Wide) => false,
            Err(Refusal::NotNear) => {
                // not yet (or never) near a strict minimum: look again later, less often
                self.skip = self.backoff;
                self.backoff = (self.backoff * 2).min(64);
                false
            }
        }
    }
}

/// The linear end phase: a strict minimum q* of the potential, its stiffness modes, and the
/// state (rotation delta from q*, in q*'s body frame, and w) at the switch time.
struct EndPhase {
    t0: f64,
    q_star: [f64; 4],
    /// Stiffness eigenvalues (N m / rad) and unit eigenvectors (columns).
    k: Vector3<f64>,
    modes: nalgebra::Matrix3<f64>,
    /// Mode coordinates of delta and of w at t0.
    x0: Vector3<f64>,
    v0: Vector3<f64>,
}

impl EndPhase {
    /// Newton on the torque from the state `y` at time `t`: the end phase if it converges to a
    /// strict minimum near which the motion from `y` stays linear and within reach of the same
    /// magnets; a minimum with a magnet within [`CUTOFF_SAFETY`] of its well's cut-off is
    /// refused too where the approach may have `crossed` a cut-off (it is not trusted).
    fn find<M: TorqueModel>(
        sys: &RotorDynamics<'_, M>,
        y: &[f64; 7],
        t: f64,
        evaluations: &mut u32,
        crossed: bool,
    ) -> Result<EndPhase, Refusal> {
        let q_sw = normalized([y[0], y[1], y[2], y[3]]);
        let w = Vector3::new(y[4], y[5], y[6]);
        let mut q = q_sw;
        let mut converged = None;
        let mut margin = f64::INFINITY;
        // minus the sum of the Newton steps so far: about delta0
        let mut moved = Vector3::zeros();
        for it in 0..NEWTON_ITERATIONS as usize {
            let lin = sys
                .model
                .linearize(&rotation_matrix(q[0], q[1], q[2], q[3]), sys.active)
                .ok_or(Refusal::NotNear)?;
            *evaluations += 1;
            margin = margin.min(lin.cutoff_margin);
            let k = -(lin.jacobian + lin.jacobian.transpose()) * 0.5;
            let chol = k.cholesky().ok_or(Refusal::NotNear)?;
            if lin.torque.norm() < 1e-9 * sys.model.stiffness_scale().ok_or(Refusal::NotNear)? {
                converged = Some(k);
                break;
            }
            let step = chol.solve(&lin.torque);
            if step.norm() > 4.0 * LINEAR_RADIUS {
                return Err(Refusal::NotNear);
            }
            moved -= step;
            if let Some(&factor) = EARLY_EXIT.get(it) {
                // the amplitude test below, estimated: the least diagonal element of K bounds
                // its least eigenvalue from above
                let k_diag = k[(0, 0)].min(k[(1, 1)]).min(k[(2, 2)]);
                let estimate =
                    (moved.norm_squared() + sys.body.inertia.x * w.norm_squared() / k_diag).sqrt();
                if estimate > factor * LINEAR_RADIUS {
                    return Err(Refusal::NotNear);
                }
            }
            q = normalized(quat_mul(q, quat_exp(&step)));
            if step.norm_squared() < NEWTON_DONE * NEWTON_DONE {
                // converged: a linearization at the new q would only confirm it
                converged = Some(k);
                break;
            }
        }
        let k = converged.ok_or(Refusal::NotNear)?;
        let eig = nalgebra::SymmetricEigen::new(k);
        let (kmin, kmax) = (eig.eigenvalues.min(), eig.eigenvalues.max());
        if kmin <= 1e-6 * kmax {
            return Err(Refusal::NotNear);
        }
        // delta0: q_sw = q* exp(delta0)
        let conj = [-q[0], -q[1], -q[2], q[3]];
        let mut rel = quat_mul(conj, q_sw);
        if rel[3] < 0.0 {
            rel = rel.map(|c| -c);
        }
        let v = Vector3::new(rel[0], rel[1], rel[2]);
        let sv = v.norm();
        let delta0 = if sv < 1e-12 {
            v * 2.0
        } else {
            v * (2.0 * sv.atan2(rel[3]) / sv)
        };
        let amplitude =
            (delta0.norm_squared() + sys.body.inertia.x * w.norm_squared() / kmin).sqrt();
        if amplitude > LINEAR_RADIUS {
            return Err(Refusal::NotNear);
        }
        if margin < 2.0 * amplitude + 1e-9 {
            return Err(Refusal::Wide);
        }
        if crossed && margin < CUTOFF_SAFETY {
            return Err(Refusal::NearCutoff);
        }
        let modes = eig.eigenvectors;
        Ok(EndPhase {
            t0: t,
            q_star: q,
            k: eig.eigenvalues,
            modes,
            x0: modes.tr_mul(&delta0),
            v0: modes.tr_mul(&w),
        })
    }

    /// The first instant from t0 on a grid of step [`SAMPLE_STEP`] / omega_0,max at which the
    /// linear motion I x'' + c x' + K x = 0 meets the settle test (|w| < omega_tol,
    /// |K x| < torque_tol), or t_max: (time, state, settled).
    fn solve(&self, body: Body, params: &SettleParams) -> (f64, [f64; 7], bool) {
        let inertia = body.inertia.x;
        let c = body.damping;
        let a = 0.5 * c / inertia;
        let w02 = self.k / inertia;
        let (x, v) = (self.x0, self.v0);
        let settled_at = |x: &Vector3<f64>, v: &Vector3<f64>| {
            x.component_mul(&self.k).norm_squared() < params.torque_tol * params.torque_tol
                && v.norm_squared() < params.omega_tol * params.omega_tol
        };
        let horizon = params.t_max - self.t0;
        if settled_at(&x, &v) {
            return (self.t0, self.state(&x, &v), true);
        }
        // the energy never falls faster than exp(-2 c t / I); below e_settle it may pass
        let kmin = self.k.min();
        let energy = 0.5 * (self.k.dot(&x.component_mul(&x)) + inertia * v.norm_squared());
        let e_settle = 0.5 * params.torque_tol * params.torque_tol / kmin
            + 0.5 * inertia * params.omega_tol * params.omega_tol;
        let t_lo = if energy <= e_settle {
            0.0
        } else if c > 0.0 {
            0.5 * inertia / c * (energy / e_settle).ln()
        } else {
            f64::INFINITY
        };
        let dt = SAMPLE_STEP / w02.max().sqrt();
        // the grid from t_lo, entered at the first sample no mode's own bound excludes
        let first = self.first_possible(inertia, a, params) - t_lo;
        let skip = if first > 0.0 {
            (first / dt).floor()
        } else {
            0.0
        };
        let start = t_lo + skip * dt;
        if start > horizon || horizon / dt > MAX_SAMPLES as f64 + start / dt {
            let (x, v) = propagate(a, &w02, horizon, &x, &v);
            return (params.t_max, self.state(&x, &v), false);
        }
        let (mut x, mut v) = propagate(a, &w02, start, &x, &v);
        let step = Propagator::new(a, &w02, dt);
        let mut n = skip;
        loop {
            let t = t_lo + n * dt;
            if t > horizon {
                break;
            }
            if settled_at(&x, &v) {
                return (self.t0 + t, self.state(&x, &v), true);
            }
            step.apply(&mut x, &mut v);
            n += 1.0;
        }
        let (x, v) = propagate(a, &w02, horizon, &self.x0, &self.v0);
        (params.t_max, self.state(&x, &v), false)
    }

    /// A time from t0 before which the linear motion cannot meet the settle test: the latest of
    /// the modes' own bounds, each from a quantity that decays exactly as a known exponential
    /// (with a = c / 2I and the test's |k x| < torque_tol, |v| < omega_tol in every mode):
    /// underdamped, Q = w0^2 x^2 + 2 a x v + v^2 = Q0 e^{-2at}, and a settled mode has
    /// Q < (torque_tol / (I w0) + omega_tol)^2; overdamped, with rates l1 < l2, the slow part
    /// l2 x + v decays as e^{-l1 t} and the fast part l1 x + v as e^{-l2 t}, and a settled mode
    /// has |l x + v| < l torque_tol / k + omega_tol; near critical damping, the mode's energy,
    /// which falls no faster than e^{-2ct/I}. The energy bound of the whole motion that
    /// [`EndPhase::solve`] starts from is twice as steep as the damping's decay: it left 289,
    /// 338 and 200 samples to test on the benchmark's 2-, 3- and 4-pair sets, this 49, 55 and
    /// 50 (on the 24,852 end phases of examples/basins.rs, 143 of 479 on average, and never
    /// past the first instant that meets the test).
    fn first_possible(&self, inertia: f64, a: f64, params: &SettleParams) -> f64 {
        let (tt, tw) = (params.torque_tol, params.omega_tol);
        let mut t_first = 0.0f64;
        for i in 0..3 {
            let (k, x, v) = (self.k[i], self.x0[i], self.v0[i]);
            let w02 = k / inertia;
            let disc = a * a - w02;
            let t_i = if disc < -1e-12 * w02 {
                let q0 = w02 * x * x + 2.0 * a * x * v + v * v;
                let bound = tt / (inertia * w02.sqrt()) + tw;
                exceeds(q0, bound * bound) / (2.0 * a)
            } else if disc > 1e-12 * w02 {
                let mu = disc.sqrt();
                let (l1, l2) = (a - mu, a + mu);
                let slow = exceeds((l2 * x + v).abs(), l2 * tt / k + tw) / l1;
                let fast = exceeds((l1 * x + v).abs(), l1 * tt / k + tw) / l2;
                slow.max(fast)
            } else {
                let e0 = k * x * x + inertia * v * v;
                exceeds(e0, tt * tt / k + inertia * tw * tw) / (4.0 * a)
            };
            t_first = t_first.max(t_i);
        }
        t_first
    }

    /// The state (q, w) of mode coordinates x, v.
    fn state(&self, x: &Vector3<f64>, v: &Vector3<f64>) -> [f64; 7] {
        let q = quat_mul(self.q_star, quat_exp(&(self.modes * x)));
        let w = self.modes * v;
        [q[0], q[1], q[2], q[3], w.x, w.y, w.z]
    }
}

/// ln(value / bound) where the value exceeds the bound, else 0: the time, in units of its decay
/// rate, a quantity decaying exactly as an exponential takes to fall below the bound.
fn exceeds(value: f64, bound: f64) -> f64 {
    if value > bound {
        (value / bound).ln()
    } else {
        0.0
    }
}

/// The exact flow of x'' + 2 a x' + w0^2 x = 0 over a time `t`, for three modes at once:
/// exp(A t) = e^{-a t} [C(t) 1 + S(t) (A + a 1)], (A + a 1)^2 = (a^2 - w0^2) 1.
struct Propagator {
    m: [[f64; 4]; 3],
}

impl Propagator {
    fn new(a: f64, w02: &Vector3<f64>, t: f64) -> Self {
        let mut m = [[0.0; 4]; 3];
        for (i, mi) in m.iter_mut().enumerate() {
            let disc = a * a - w02[i];
            let decay = (-a * t).exp();
            // e^{-at} C and e^{-at} S
            let (ec, es) = if disc < -1e-12 * w02[i] {
                let wd = (-disc).sqrt();
                (decay * (wd * t).cos(), decay * (wd * t).sin() / wd)
            } else if disc > 1e-12 * w02[i] {
                let mu = disc.sqrt();
                let (e1, e2) = ((-(a - mu) * t).exp(), (-(a + mu) * t).exp());
                (0.5 * (e1 + e2), 0.5 * (e1 - e2) / mu)
            } else {
                (decay, decay * t)
            };
            *mi = [ec + a * es, es, -w02[i] * es, ec - a * es];
        }
        Propagator { m }
    }

    #[inline]
    fn apply(&self, x: &mut Vector3<f64>, v: &mut Vector3<f64>) {
        for i in 0..3 {
            let m = &self.m[i];
            let (xi, vi) = (x[i], v[i]);
            x[i] = m[0] * xi + m[1] * vi;
            v[i] = m[2] * xi + m[3] * vi;
        }
    }
}

fn propagate(
    a: f64,
    w02: &Vector3<f64>,
    t: f64,
    x: &Vector3<f64>,
    v: &Vector3<f64>,
) -> (Vector3<f64>, Vector3<f64>) {
    let (mut x, mut v) = (*x, *v);
    if t > 0.0 {
        Propagator::new(a, w02, t).apply(&mut x, &mut v);
    }
    (x, v)
}

/// The settle by ode_solvers' Dopri5 at `params`' tolerances: the reference, and the fast
/// path's tight fallback.
fn settle_dopri5<M: TorqueModel>(
    sys: &RotorDynamics<'_, M>,
    y0: [f64; 7],
    params: SettleParams,
    trace: Option<&mut Vec<(f64, State)>>,
) -> SettleResult {
    let mut run = ReferenceRun {
        dynamics: sys,
        params,
        previous: None,
        settled_at: None,
    };
    let start = State::from_column_slice(&y0);
    // Hairer's defaults (safety 0.9, beta 0.04, step factors 0.2 to 10), a cap on the steps,
    // and no stiffness test: a settle is mildly stiff (fast damped modes), which Dopri5 handles
    // with more steps, and giving up there stopped heavily damped references early.
    let mut solver = Dopri5::from_param(
        &mut run,
        0.0,
        params.t_max,
        params.t_max,
        start,
        params.rtol,
        params.atol,
        0.9,
        0.04,
        0.2,
        10.0,
        params.t_max,
        0.0,
        REFERENCE_MAX_STEPS,
        u32::MAX,
        OutputType::Sparse,
    );
    let outcome = solver.integrate();
    let solver_steps = solver.x_out().len().saturating_sub(1) as u32;
    let last = (
        *solver.x_out().last().unwrap_or(&0.0),
        as_array(solver.y_out().last().unwrap_or(&start)),
    );
    let steps_out: Vec<(f64, State)> = match trace {
        Some(_) => solver
            .x_out()
            .iter()
            .copied()
            .zip(solver.y_out().iter().copied())
            .collect(),
        None => Vec::new(),
    };
    drop(solver);
    let (t_end, y_end) = run.settled_at.unwrap_or(last);
    let (evals, steps) = match &outcome {
        Ok(stats) => (stats.num_eval, stats.accepted_steps),
        // ode_solvers keeps its counts private when it stops with an error: at least the
        // steps it wrote out
        Err(_) => (0, solver_steps),
    };
    if let Some(trace) = trace {
        // the accepted steps up to the instant the test passed, and that instant
        trace.extend(steps_out.into_iter().filter(|(t, _)| *t < t_end));
        trace.push((t_end, State::from_column_slice(&y_end)));
    }
    let stop = match (&outcome, run.settled_at.is_some()) {
        (_, true) => Stop::Settled,
        (Ok(_), false) => Stop::TimeLimit,
        (Err(IntegrationError::StepSizeUnderflow { .. }), false) => Stop::StepSizeUnderflow,
        (Err(_), false) => Stop::StepLimit,
    };
    finish(sys.model, sys.active, &y_end, t_end, evals, steps, stop)
}

fn finish<M: TorqueModel>(
    model: &M,
    active: &[Pair],
    y: &[f64; 7],
    t: f64,
    evaluations: u32,
    steps: u32,
    stop: Stop,
) -> SettleResult {
    let q = UnitQuaternion::from_quaternion(Quaternion::new(y[3], y[0], y[1], y[2]));
    let r = q.to_rotation_matrix();
    let (tau, energy) = model.torque_energy(r.matrix(), active);
    let residual = tau.norm();
    // a settle that stopped where the torque (or the state) is not finite overflowed, whatever
    // the stepper took it for (Dopri5 reports a collapsed step)
    let overflowed = !(residual.is_finite() && y.iter().all(|v| v.is_finite()));
    let stop = match stop {
        Stop::StepSizeUnderflow | Stop::StepLimit if overflowed => Stop::Overflow,
        s => s,
    };
    SettleResult {
        q,
        settle_time_s: t,
        evaluations,
        steps,
        energy_j: energy,
        residual_torque_nm: residual,
        settled: stop == Stop::Settled,
        stop,
    }
}

/// Settles every active set from the same start, in parallel; results in input order.
pub fn settle_many<M: TorqueModel>(
    model: &M,
    sets: &[Vec<Pair>],
    q0: &Orientation,
    body: Body,
    params: SettleParams,
) -> Vec<SettleResult> {
    sets.par_iter()
        .map(|s| settle(model, s, q0, body, params))
        .collect()
}
