//! Rigid-body dynamics of the rotor (paper section 3.4): the quaternion equations of motion
//! with viscous damping under the summed magnet torques, integrated until the ball has settled;
//! `settle_many` settles many active sets from one orientation in parallel.
//!
//! Two paths reach the same equilibria: the fast path (the default, `fast`), an
//! allocation-free Bogacki-Shampine 3(2) stepper from `integrator` while the motion is
//! nonlinear, the wells' cut-offs crossed as events (`events`), and a closed-form linear end
//! phase about the strict minimum it comes to (`end_phase`; with a tight fallback where it
//! cannot be sure), and the reference path
//! (`reference`), ode_solvers' Dopri5 at whatever tolerances are asked
//! (`SettleParams::reference()` is tight). This file holds the types, the equations of motion
//! and the entry points; tests/it/basins.rs and research/basins.rs check the one path against the
//! other on random sets, tests/it/settle.rs pins 54, and each part's file has its own unit tests.

mod end_phase;
mod events;
mod fast;
mod reference;

use fast::settle_fast;
use reference::settle_dopri5;

use crate::model::geometry::{Degrees, Orientation, Pair, Radians};
use crate::physics::integrator::{End, OdeSystem};
use crate::physics::torque::{rotation_matrix, TorqueModel};
use nalgebra::{Quaternion, UnitQuaternion, Vector3};
use ode_solvers::SVector;
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
    /// The integrator's relative tolerance (`settle.rtol`).
    pub rtol: f64,
    /// The integrator's absolute tolerance (`settle.atol`), on the state: the quaternion's
    /// components and the angular velocity in rad/s.
    pub atol: f64,
    /// The integrator.
    pub method: Method,
    /// Where no strict minimum holds the ball (a pair out of reach, a magnet at its well's
    /// cut-off), where it stops along the free direction depends on the whole coast: `true`
    /// (the default) integrates it again at tight tolerances to find out; `false` stops there
    /// and says [`Stop::Unheld`] (for planners, which discard such sets: a set that holds is
    /// settled the same either way).
    pub follow_unheld: bool,
    /// The ball has arrived once it stays within this angle of where it comes to rest: the
    /// time of that instant ([`SettleResult::arrival_time_s`]) is what a step waits for.
    pub arrival: Radians,
}

/// The default [`SettleParams::arrival`], degrees: a twentieth of a degree, below what an
/// orientation sensor resolves and a thousandth of a step.
pub const DEFAULT_ARRIVAL_DEG: f64 = 0.05;

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
            arrival: Degrees(DEFAULT_ARRIVAL_DEG).to_radians(),
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
    /// Simulated time from which the ball stays within [`SettleParams::arrival`] of where it
    /// settles, s: where the linear end phase settled the ball, the first instant its energy
    /// about the minimum is below that of a displacement of `arrival` along its softest mode
    /// (the energy only falls, so it stays nearer); or the first accepted step from which the
    /// ball provably stays that near (see `arrival_on`), if earlier. At most `settle_time_s`
    /// (equal where the settle did not settle): what a step's dwell waits for, where the
    /// settle test (a torque, which on soft wells is a far smaller angle) may come seconds
    /// later.
    pub arrival_time_s: f64,
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

/// The equations of motion for one active set, on the state `y = [x, y, z, w, wx, wy, wz]`:
/// the orientation (body to world, quaternion `x, y, z, w`) and the body-frame angular
/// velocity (rad/s).
pub struct RotorDynamics<'a, M: TorqueModel> {
    /// The magnet wells' torques.
    pub model: &'a M,
    /// The coil:magnet pairs that are on.
    pub active: &'a [Pair],
    /// The ball's inertia and damping.
    pub body: Body,
    /// 1 / I, per axis.
    inv_inertia: Vector3<f64>,
    /// Whether I is the same about every axis (then w x (I w) = 0).
    isotropic: bool,
}

impl<'a, M: TorqueModel> RotorDynamics<'a, M> {
    /// The equations of `model` under `active` for `body` (its inverse inertia computed once).
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
        self.derivative_under(y, self.body_torque(y), dy)
    }

    /// dy/dt under the body-frame torque `nb` at `y`.
    #[inline(always)]
    fn derivative_under(&self, y: &[f64; 7], nb: Vector3<f64>, dy: &mut [f64; 7]) {
        let (q1, q2, q3, q4) = (y[0], y[1], y[2], y[3]);
        let w = Vector3::new(y[4], y[5], y[6]);
        let qv = Vector3::new(q1, q2, q3);
        let dqv = (w * q4 - w.cross(&qv)) * 0.5;
        dy[0] = dqv.x;
        dy[1] = dqv.y;
        dy[2] = dqv.z;
        dy[3] = -0.5 * w.dot(&qv);
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
    // the steps are kept (the caller's trace, else one of our own) to find the arrival
    let mut own = Vec::with_capacity(64);
    let steps = trace.unwrap_or(&mut own);
    let from = steps.len();
    let r = match params.method {
        Method::Bs32 => settle_fast(&sys, y0, params, Some(&mut *steps)),
        Method::Dopri5 => settle_dopri5(&sys, y0, params, Some(&mut *steps)),
    };
    SettleResult {
        arrival_time_s: r
            .arrival_time_s
            .min(arrival_on(&steps[from..], &r, params.arrival)),
        ..r
    }
}

/// The end of the first of the accepted steps `steps` from which the ball stays within
/// `arrival` of where the settle `r` left it: every later step ends nearer than `arrival` by at
/// least the turn its rate could make over the step after it (the larger of its ends' rates,
/// times its length); the settle's own time where the last step is not that near (or the
/// settle did not settle).
fn arrival_on(steps: &[(f64, State)], r: &SettleResult, arrival: Radians) -> f64 {
    if !r.settled {
        return r.settle_time_s;
    }
    let near = |i: usize| {
        let (t, y) = &steps[i];
        let q = orientation_of(y.as_slice());
        let rate = |y: &State| Vector3::new(y[4], y[5], y[6]).norm();
        let drift = steps
            .get(i + 1)
            .map_or(0.0, |(t1, y1)| (t1 - t) * rate(y).max(rate(y1)));
        q.angle_to(&r.q) + drift <= arrival.0
    };
    let mut first = steps.len();
    while first > 0 && near(first - 1) {
        first -= 1;
    }
    steps
        .get(first)
        .map_or(r.settle_time_s, |(t, _)| t.min(r.settle_time_s))
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

/// The orientation held in a state `[qx, qy, qz, qw, wx, wy, wz]` (normalised).
pub fn orientation_of(y: &[f64]) -> Orientation {
    UnitQuaternion::from_quaternion(Quaternion::new(y[3], y[0], y[1], y[2]))
}

/// The result of a settle that stopped at `y` at time `t`, for `stop`.
fn finish<M: TorqueModel>(
    model: &M,
    active: &[Pair],
    y: &[f64; 7],
    t: f64,
    evaluations: u32,
    steps: u32,
    stop: Stop,
) -> SettleResult {
    let q = orientation_of(y);
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
        arrival_time_s: t,
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

/// The prototype's physics for the parts' unit tests: its packings, gaussian wells (k = 0.25
/// J, sigma = 10 degrees, out to 30 degrees, "pairs"), I = 0.023 kg m^2 and c = 1 N m s.
#[cfg(test)]
pub(super) fn prototype_physics() -> (crate::physics::torque::MagnetTorques, Body) {
    use crate::model::geometry::Radians;
    use crate::model::packing::{prototype_rotor, prototype_stator};
    use crate::physics::torque::{Interaction, MagnetTorques, Well, WellShape};
    let points = |p: crate::model::packing::Packing| {
        p.points.iter().map(|u| u.into_inner()).collect::<Vec<_>>()
    };
    let torques = MagnetTorques {
        rotor: points(prototype_rotor()),
        stator: points(prototype_stator()),
        well: Well::new(
            WellShape::Gaussian {
                strength_j: 0.25,
                width: Radians(10f64.to_radians()),
            },
            Radians(30f64.to_radians()),
        ),
        interaction: Interaction::Pairs,
    };
    let body = Body {
        inertia: Vector3::repeat(0.023),
        damping: 1.0,
    };
    (torques, body)
}
