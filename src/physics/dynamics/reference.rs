//! The reference settle: ode_solvers' Dopri5 at the tolerances asked, the settle test applied
//! at each accepted step and within it; also the fast path's tight fallback.

use super::{
    finish, hermite_weights, RotorDynamics, SettleParams, SettleResult, State, Stop,
    REFERENCE_MAX_STEPS,
};
use crate::physics::torque::TorqueModel;
use nalgebra::Vector3;
use ode_solvers::dop_shared::IntegrationError;
use ode_solvers::{Dopri5, OutputType, System};

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

/// The settle by ode_solvers' Dopri5 at `params`' tolerances: the reference, and the fast
/// path's tight fallback.
pub(super) fn settle_dopri5<M: TorqueModel>(
    sys: &RotorDynamics<'_, M>,
    y0: [f64; 7],
    params: SettleParams,
    trace: Option<&mut Vec<(f64, State)>>,
) -> SettleResult {
    dopri5_run(sys, y0, params, trace).0
}

/// [`settle_dopri5`], also giving the whole state (orientation and rate) where it ended.
pub(super) fn dopri5_run<M: TorqueModel>(
    sys: &RotorDynamics<'_, M>,
    y0: [f64; 7],
    params: SettleParams,
    trace: Option<&mut Vec<(f64, State)>>,
) -> (SettleResult, [f64; 7]) {
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
    (
        finish(sys.model, sys.active, &y_end, t_end, evals, steps, stop),
        y_end,
    )
}

#[cfg(test)]
mod tests {
    use super::super::{prototype_physics, settle_traced};
    use super::*;
    use crate::model::geometry::{Orientation, Pair};

    #[test]
    fn the_reference_settles_to_a_minimum_and_its_trace_ends_there() {
        let (torques, body) = prototype_physics();
        let active = [Pair::new(0, 14), Pair::new(12, 26)];
        let params = SettleParams::default().reference();
        let mut trace = Vec::new();
        let q0 = Orientation::identity();
        let r = settle_traced(&torques, &active, &q0, body, params, Some(&mut trace));
        assert!(r.settled && r.stop == Stop::Settled);
        assert!(r.residual_torque_nm < params.torque_tol);
        // the trace runs forward in time and ends at the instant the test passed
        assert!(trace.windows(2).all(|w| w[0].0 < w[1].0));
        assert_eq!(trace.last().map(|s| s.0), Some(r.settle_time_s));
        // a tighter reference lands on the same minimum
        let tighter = SettleParams {
            rtol: 1e-12,
            atol: 1e-14,
            ..params
        };
        let t = super::super::settle(&torques, &active, &q0, body, tighter);
        assert!(t.q.angle_to(&r.q) < 1e-6, "{}", t.q.angle_to(&r.q));
    }

    #[test]
    fn the_settle_test_is_applied_within_a_step() {
        let (torques, body) = prototype_physics();
        let active = [Pair::new(0, 14)];
        let params = SettleParams::default().reference();
        let sys = RotorDynamics::new(&torques, &active, body);
        let run = ReferenceRun {
            dynamics: &sys,
            params,
            previous: None,
            settled_at: None,
        };
        // a step from a state far from rest to one at rest in the minimum: the test passes at
        // a point of the step no later than its end
        let q = Orientation::identity();
        let far = [q.i, q.j, q.k, q.w, 1.0, 0.0, 0.0];
        let rest = super::super::settle(&torques, &active, &q, body, params);
        let p = rest.q.quaternion();
        let end = [p.i, p.j, p.k, p.w, 0.0, 0.0, 0.0];
        let mut d_far = [0.0; 7];
        let mut d_end = [0.0; 7];
        sys.derivative(&far, &mut d_far);
        sys.derivative(&end, &mut d_end);
        let found = run.settled_within((0.0, far, d_far), (0.1, end, d_end));
        assert!(found.is_some_and(|(t, _)| t <= 0.1));
    }
}
