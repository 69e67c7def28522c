//! Rigid-body dynamics of the rotor (paper section 3.4): the quaternion equations of motion
//! with viscous damping under the summed magnet torques, integrated with ode_solvers until the
//! ball has settled; `settle_many` settles many active sets from one orientation in parallel.

use crate::geometry::{Orientation, Pair};
use crate::torque::TorqueModel;
use nalgebra::{Quaternion, UnitQuaternion, Vector3};
use ode_solvers::{Dopri5, OutputType, SVector, System};
use rayon::prelude::*;
use serde::Serialize;

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

/// When the ball counts as settled, and how accurately to integrate.
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
}

impl Default for SettleParams {
    fn default() -> Self {
        SettleParams {
            omega_tol: 1e-3,
            torque_tol: 1e-4,
            t_max: 5.0,
            rtol: 1e-6,
            atol: 1e-8,
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
    /// |w| at the end, rad/s.
    pub omega_rad_s: f64,
    /// Whether the settle test passed before `t_max`.
    pub settled: bool,
}

/// The equations of motion for one active set.
pub struct RotorDynamics<'a, M: TorqueModel> {
    pub model: &'a M,
    pub active: &'a [Pair],
    pub body: Body,
    pub params: SettleParams,
    /// Set by the stop test: the time it passed.
    settled_at: Option<f64>,
}

impl<'a, M: TorqueModel> RotorDynamics<'a, M> {
    pub fn new(model: &'a M, active: &'a [Pair], body: Body, params: SettleParams) -> Self {
        RotorDynamics {
            model,
            active,
            body,
            params,
            settled_at: None,
        }
    }

    /// Body-frame torque N_B at the orientation held in `y`.
    pub fn body_torque(&self, y: &State) -> Vector3<f64> {
        let q = unit_q(y);
        let r = q.to_rotation_matrix();
        r.transpose() * self.model.torque(r.matrix(), self.active)
    }

    /// |N_B| recovered from the state and its derivative (no extra torque evaluation):
    /// N_B = I dw/dt + w x (I w) + c w.
    fn torque_from_derivative(&self, y: &State, dy: &State) -> f64 {
        let w = Vector3::new(y[4], y[5], y[6]);
        let dw = Vector3::new(dy[4], dy[5], dy[6]);
        let i = self.body.inertia;
        let nb = i.component_mul(&dw) + w.cross(&i.component_mul(&w)) + w * self.body.damping;
        nb.norm()
    }
}

fn unit_q(y: &State) -> Orientation {
    UnitQuaternion::from_quaternion(Quaternion::new(y[3], y[0], y[1], y[2]))
}

impl<M: TorqueModel> System<f64, State> for RotorDynamics<'_, M> {
    fn system(&self, _t: f64, y: &State, dy: &mut State) {
        let (q1, q2, q3, q4) = (y[0], y[1], y[2], y[3]);
        let w = Vector3::new(y[4], y[5], y[6]);
        let qv = Vector3::new(q1, q2, q3);
        // dq/dt = 1/2 (q4 w - w x q), dq4/dt = -1/2 w . q
        let dqv = (w * q4 - w.cross(&qv)) * 0.5;
        dy[0] = dqv.x;
        dy[1] = dqv.y;
        dy[2] = dqv.z;
        dy[3] = -0.5 * w.dot(&qv);
        // dw/dt = I^-1 [ -w x (I w) + N_B - c w ]
        let nb = self.body_torque(y);
        let i = self.body.inertia;
        let rhs = -w.cross(&i.component_mul(&w)) + nb - w * self.body.damping;
        dy[4] = rhs.x / i.x;
        dy[5] = rhs.y / i.y;
        dy[6] = rhs.z / i.z;
    }

    fn solout(&mut self, t: f64, y: &State, dy: &State) -> bool {
        let w = (y[4] * y[4] + y[5] * y[5] + y[6] * y[6]).sqrt();
        if w < self.params.omega_tol && self.torque_from_derivative(y, dy) < self.params.torque_tol
        {
            self.settled_at = Some(t);
            return true;
        }
        false
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
    let y0 = State::from_column_slice(&[q0.i, q0.j, q0.k, q0.w, 0.0, 0.0, 0.0]);
    let mut sys = RotorDynamics::new(model, active, body, params);
    let r0 = q0.to_rotation_matrix();
    let tau0 = model.torque(r0.matrix(), active).norm();
    if tau0 < params.torque_tol {
        // Already in equilibrium and at rest.
        return finish(model, active, y0, 0.0, 1, 0, true);
    }
    let mut solver = Dopri5::new(
        &mut sys,
        0.0,
        params.t_max,
        params.t_max,
        y0,
        params.rtol,
        params.atol,
    );
    solver.set_output(OutputType::Sparse);
    let outcome = solver.integrate();
    let y_end = *solver.y_out().last().unwrap_or(&y0);
    let t_end = *solver.x_out().last().unwrap_or(&0.0);
    if let Some(trace) = trace {
        trace.extend(solver.x_out().iter().copied().zip(solver.y_out().iter().copied()));
    }
    drop(solver);
    let (evals, steps) = match &outcome {
        Ok(stats) => (stats.num_eval, stats.accepted_steps),
        Err(_) => (0, 0),
    };
    let settled_at = sys.settled_at;
    finish(
        model,
        active,
        y_end,
        settled_at.unwrap_or(t_end),
        evals,
        steps,
        settled_at.is_some(),
    )
}

impl<M: TorqueModel> System<f64, State> for &mut RotorDynamics<'_, M> {
    fn system(&self, t: f64, y: &State, dy: &mut State) {
        (**self).system(t, y, dy)
    }
    fn solout(&mut self, t: f64, y: &State, dy: &State) -> bool {
        (**self).solout(t, y, dy)
    }
}

fn finish<M: TorqueModel>(
    model: &M,
    active: &[Pair],
    y: State,
    t: f64,
    evaluations: u32,
    steps: u32,
    settled: bool,
) -> SettleResult {
    let q = unit_q(&y);
    let r = q.to_rotation_matrix();
    let (tau, energy) = model.torque_energy(r.matrix(), active);
    SettleResult {
        q,
        settle_time_s: t,
        evaluations,
        steps,
        energy_j: energy,
        residual_torque_nm: tau.norm(),
        omega_rad_s: Vector3::new(y[4], y[5], y[6]).norm(),
        settled,
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
