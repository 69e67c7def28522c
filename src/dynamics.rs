//! Rigid-body dynamics of the rotor (paper section 3.4): the quaternion equations of motion
//! with viscous damping under the summed magnet torques, integrated until the ball has settled;
//! `settle_many` settles many active sets from one orientation in parallel.
//!
//! Two integrators reach the same equilibria: the fast path (the default), an allocation-free
//! Bogacki-Shampine 3(2) stepper from `integrator` at loose tolerances, and the reference path,
//! ode_solvers' Dopri5 at whatever tolerances are asked (`SettleParams::reference()` is tight).
//! Where the ball stops is decided by the settle test on an exactly evaluated state, not by the
//! integration error, which is why the loose tolerances land on the same equilibrium (the tests
//! in tests/settle.rs pin this).

use crate::geometry::{Orientation, Pair};
use crate::integrator::{integrate_until, OdeSystem, Tolerances};
use crate::torque::{rotation_matrix, TorqueModel};
use nalgebra::{Quaternion, UnitQuaternion, Vector3};
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
    /// 1 / I, per axis.
    inv_inertia: Vector3<f64>,
}

impl<'a, M: TorqueModel> RotorDynamics<'a, M> {
    pub fn new(model: &'a M, active: &'a [Pair], body: Body) -> Self {
        RotorDynamics {
            model,
            active,
            body,
            inv_inertia: body.inertia.map(|i| 1.0 / i),
        }
    }

    /// Body-frame torque N_B at the orientation held in `y` (which need not be normalised).
    pub fn body_torque(&self, y: &[f64; 7]) -> Vector3<f64> {
        let r = rotation_matrix(y[0], y[1], y[2], y[3]);
        self.model.body_torque(&r, self.active)
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
        let rhs = -w.cross(&i.component_mul(&w)) + nb - w * self.body.damping;
        let dw = rhs.component_mul(&self.inv_inertia);
        dy[4] = dw.x;
        dy[5] = dw.y;
        dy[6] = dw.z;
    }

    /// The settle test on a state and its exact derivative. |N_B| is recovered from them
    /// without another torque evaluation: N_B = I dw/dt + w x (I w) + c w.
    fn settled(&self, params: &SettleParams, y: &[f64], dy: &[f64]) -> bool {
        let w = Vector3::new(y[4], y[5], y[6]);
        if w.norm() >= params.omega_tol {
            return false;
        }
        let dw = Vector3::new(dy[4], dy[5], dy[6]);
        let i = self.body.inertia;
        let nb = i.component_mul(&dw) + w.cross(&i.component_mul(&w)) + w * self.body.damping;
        nb.norm() < params.torque_tol
    }
}

impl<M: TorqueModel> OdeSystem<7> for RotorDynamics<'_, M> {
    #[inline]
    fn rhs(&self, y: &[f64; 7], dy: &mut [f64; 7]) {
        self.derivative(y, dy)
    }
}

/// ode_solvers' view of the same equations, with the settle test as its stop test (Sparse
/// output: `solout` sees each accepted step and its exact derivative).
struct ReferenceRun<'a, 'b, M: TorqueModel> {
    dynamics: &'b RotorDynamics<'a, M>,
    params: SettleParams,
    settled_at: Option<f64>,
}

impl<M: TorqueModel> System<f64, State> for &mut ReferenceRun<'_, '_, M> {
    fn system(&self, _t: f64, y: &State, dy: &mut State) {
        let mut out = [0.0; 7];
        self.dynamics.derivative(&as_array(y), &mut out);
        dy.copy_from_slice(&out);
    }

    fn solout(&mut self, t: f64, y: &State, dy: &State) -> bool {
        if self
            .dynamics
            .settled(&self.params, y.as_slice(), dy.as_slice())
        {
            self.settled_at = Some(t);
            return true;
        }
        false
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
    let sys = RotorDynamics::new(model, active, body);
    if sys.body_torque(&y0).norm() < params.torque_tol {
        // Already in equilibrium and at rest.
        return finish(model, active, &y0, 0.0, 1, 0, true);
    }
    match params.method {
        Method::Bs32 => {
            let mut trace = trace;
            let tol = Tolerances {
                rtol: params.rtol,
                atol: params.atol,
            };
            let out = integrate_until(&sys, y0, params.t_max, tol, |t, y, dy| {
                if let Some(tr) = trace.as_deref_mut() {
                    tr.push((t, State::from_column_slice(y)));
                }
                sys.settled(&params, y, dy)
            });
            finish(
                model,
                active,
                &out.y,
                out.t,
                out.evaluations,
                out.steps,
                out.stopped,
            )
        }
        Method::Dopri5 => settle_dopri5(&sys, y0, params, trace),
    }
}

fn settle_dopri5<M: TorqueModel>(
    sys: &RotorDynamics<'_, M>,
    y0: [f64; 7],
    params: SettleParams,
    trace: Option<&mut Vec<(f64, State)>>,
) -> SettleResult {
    let mut run = ReferenceRun {
        dynamics: sys,
        params,
        settled_at: None,
    };
    let start = State::from_column_slice(&y0);
    let mut solver = Dopri5::new(
        &mut run,
        0.0,
        params.t_max,
        params.t_max,
        start,
        params.rtol,
        params.atol,
    );
    solver.set_output(OutputType::Sparse);
    let outcome = solver.integrate();
    let y_end = as_array(solver.y_out().last().unwrap_or(&start));
    let t_end = *solver.x_out().last().unwrap_or(&0.0);
    if let Some(trace) = trace {
        trace.extend(
            solver
                .x_out()
                .iter()
                .copied()
                .zip(solver.y_out().iter().copied()),
        );
    }
    drop(solver);
    let (evals, steps) = match &outcome {
        Ok(stats) => (stats.num_eval, stats.accepted_steps),
        Err(_) => (0, 0),
    };
    finish(
        sys.model,
        sys.active,
        &y_end,
        run.settled_at.unwrap_or(t_end),
        evals,
        steps,
        run.settled_at.is_some(),
    )
}

fn finish<M: TorqueModel>(
    model: &M,
    active: &[Pair],
    y: &[f64; 7],
    t: f64,
    evaluations: u32,
    steps: u32,
    settled: bool,
) -> SettleResult {
    let q = UnitQuaternion::from_quaternion(Quaternion::new(y[3], y[0], y[1], y[2]));
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
