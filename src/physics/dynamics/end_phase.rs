//! The linear end phase: near a strict minimum of the potential the motion is the damped linear
//! motion about it, solved in closed form mode by mode for the first instant it meets the settle
//! test; and the watch (`EndSearch`) that finds the minimum by Newton on the torque while the
//! fast path integrates.

use super::{Body, RotorDynamics, SettleParams};
use crate::physics::torque::{rotation_matrix, TorqueModel};
use nalgebra::Vector3;

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
/// On the 28,000 sets of research/basins.rs and its 7,000 "coils" sets it was at most 5.3e-12
/// of the stiffness scale, far below the 1e-9 of the residual test; the stiffness used is the
/// one at 1e-6 rad from the minimum.
const NEWTON_DONE: f64 = 1e-6;
/// Early exits from the end phase's Newton search: after its first and second steps, the
/// amplitude test below is estimated from the steps so far and the stiffness there, and a
/// switch point whose estimate exceeds [`LINEAR_RADIUS`] by these factors is refused at once
/// instead of after the 3 or 4 linearizations a converged search takes. On 7,000 sets of
/// research/basins.rs (16,637 searches), the estimates of the searches that succeeded were at
/// most 1.24 (first) and 1.02 (second) times the radius; exits at 2.0 and 1.3 refused 24% and
/// then 30% of the 9,869 that failed, and on its 28,000 sets every settle was the same to the
/// bit as without them (1.1 for the second changed one light-damping set: it was refused there,
/// then switched later). 1.3 after the first step too refuses one linearization sooner where
/// 2.0 waited for the second (the benchmark's 3-pair set: 73 evaluations instead of 74; the 200
/// sets of research/settle_sets.rs settle to the same results).
const EARLY_EXIT: [f64; 2] = [1.3, 1.3];
/// Samples per unit of the fastest mode's natural period over 2 pi (1/omega_0): the end phase
/// looks for the first instant of the settle test on a grid of step 0.1 / omega_0, as fine as
/// the reference's own steps there.
const SAMPLE_STEP: f64 = 0.1;
/// Bisections of the end phase's arrival time (to 1/4096 of the end phase's span: a
/// millisecond on a span of seconds).
const ARRIVAL_BISECTIONS: u32 = 12;
/// The share of the time [`EndPhase::narrow_after`] predicts for a minimum too wide for its
/// cut-off margin that the search waits before it looks again.
const WIDE_WAIT: f64 = 0.75;
/// The most samples the end phase takes (a bounded cost whatever t_max and the damping are).
const MAX_SAMPLES: u64 = 1_000_000;

/// A minimum with a magnet closer than this (rad, 2 degrees) to its well's cut-off is not
/// trusted where the approach may have crossed a cut-off (the graze watch saw a margin change
/// sign, or cannot follow the margins): the ball came there across the discontinuity of the
/// torque, where whether a magnet drifts out of reach or falls back in is decided by errors a
/// loose tolerance allows (before the graze watch, one set in 4,000 of research/basins.rs ended
/// 3.4 degrees from the reference's equilibrium so): the settle is run again at tight
/// tolerances. In the "pairs" interaction an approach that stayed on one side of every cut-off
/// is as smooth as any other, and its minimum is trusted
/// ([`TorqueModel::trusts_uncrossed_cutoffs`]): on the 28,000 sets of research/basins.rs (seeds
/// 17 to 19) none lands in another equilibrium and 247, 243 and 270 settle times are outside
/// the reference's bounds (261, 256 and 273 before), for 13% fewer evaluations (seed 17); on
/// the 200 sets of research/settle_sets.rs it spares the tight run of a set in two orders
/// (2,254 evaluations each). In the "coils" interaction it moved 17 more of the 7,000 sets of
/// `basins --coils` outside the bounds, and one set's settled flag at t_max: not trusted there.
/// (One of them, looked at: the end phase's motion is right, to 1e-5 N m against the reference's
/// trajectory, but the reference meets the settle test in a dip of the oscillation about 0.2 ms
/// wide, which the end phase's grid of [`SAMPLE_STEP`] / omega_0 steps over, even 10 times finer;
/// it then meets it one period, 0.14 s, later. The reference saw the dip at one of its
/// [`SUBSTEPS`](super::reference::SUBSTEPS) test points in a step of about 1 ms: so narrow a dip is found by either grid or
/// not, and the first instant of the continuous test, in both, would settle the question.)
const CUTOFF_SAFETY: f64 = 0.035;

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
/// research/basins.rs the search came 5 s late so, the stepper meanwhile hovering at its
/// tolerance's noise floor near the minimum). A strict minimum refused only because the motion
/// about it would reach a magnet's cut-off is looked at again once the linear motion about it
/// has nearly shrunk clear of the cut-off ([`Refusal::Wide`]).
pub(super) struct EndSearch {
    k1: f64,
    skip: u32,
    backoff: u32,
    /// The settle's horizon (its t_max).
    horizon: f64,
    /// No search before this time: a minimum was refused as too wide for its cut-off margin, and
    /// the linear motion about it stays so wide until about then.
    wait_until: f64,
    /// Linearizations spent.
    pub(super) evaluations: u32,
    /// Whether the approach may have crossed a well's cut-off (the graze watch saw a margin
    /// change sign, or could not follow the margins): a minimum near a cut-off is then not
    /// trusted ([`CUTOFF_SAFETY`]).
    pub(super) crossed: bool,
    pub(super) found: Option<EndPhase>,
    /// Whether the search stopped the integration at a minimum within [`CUTOFF_SAFETY`] of a
    /// cut-off that the approach may have crossed (the settle is unsure there).
    pub(super) near_cutoff: bool,
}

/// Why [`EndPhase::find`] found no end phase.
enum Refusal {
    /// No strict minimum near (Newton diverged or left the linear radius, the stiffness is not
    /// positive definite, the motion from here is beyond the linear radius).
    NotNear,
    /// A strict minimum, but the motion about it would reach a magnet's cut-off: it shrinks as
    /// the ball settles, by the linear motion about the minimum not before `after` (s) from the
    /// switch point ([`EndPhase::narrow_after`]).
    Wide { after: f64 },
    /// A strict minimum within [`CUTOFF_SAFETY`] of a cut-off that the approach may have
    /// crossed: the settle is unsure.
    NearCutoff,
}

impl EndSearch {
    pub(super) fn new(k1: f64, crossed: bool, horizon: f64) -> EndSearch {
        EndSearch {
            k1,
            skip: 0,
            backoff: 1,
            horizon,
            wait_until: f64::NEG_INFINITY,
            evaluations: 0,
            crossed,
            found: None,
            near_cutoff: false,
        }
    }

    /// Whether the integration stops at the accepted step (t, y) with derivative dy: the end
    /// phase is found, or a minimum near a well's cut-off is (the settle is then unsure).
    pub(super) fn stops<M: TorqueModel>(
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
            (self.skip, self.backoff, self.wait_until) = (0, 1, f64::NEG_INFINITY);
            return false;
        }
        if t < self.wait_until {
            return false;
        }
        if self.skip > 0 {
            self.skip -= 1;
            return false;
        }
        match EndPhase::find(sys, y, t, self.horizon, &mut self.evaluations, self.crossed) {
            Ok(e) => {
                self.found = Some(e);
                true
            }
            Err(Refusal::NearCutoff) => {
                self.near_cutoff = true;
                true
            }
            Err(Refusal::Wide { after }) => {
                self.wait_until = t + WIDE_WAIT * after;
                false
            }
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
pub(super) struct EndPhase {
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
        horizon: f64,
        evaluations: &mut u32,
        crossed: bool,
    ) -> Result<EndPhase, Refusal> {
        let q_sw = normalized([y[0], y[1], y[2], y[3]]);
        let w = Vector3::new(y[4], y[5], y[6]);
        let (q, k, margin) = newton(sys, q_sw, &w, evaluations)?;
        let delta0 = rotation_from(q, q_sw);
        // the amplitude test below with the least diagonal element of K, which bounds its least
        // eigenvalue from above: a switch point it refuses is refused without the
        // eigen-decomposition (on the 4,000 planner-like sets, 1,343 of the 5,600 searches that
        // converged)
        let k_diag = k[(0, 0)].min(k[(1, 1)]).min(k[(2, 2)]);
        let at_least = amplitude2(&delta0, &w, sys.body.inertia.x, k_diag);
        if at_least > LINEAR_RADIUS * LINEAR_RADIUS {
            return Err(Refusal::NotNear);
        }
        let eig = nalgebra::SymmetricEigen::new(k);
        let (kmin, kmax) = (eig.eigenvalues.min(), eig.eigenvalues.max());
        if kmin <= 1e-6 * kmax {
            return Err(Refusal::NotNear);
        }
        let amplitude = amplitude2(&delta0, &w, sys.body.inertia.x, kmin).sqrt();
        if amplitude > LINEAR_RADIUS {
            return Err(Refusal::NotNear);
        }
        let modes = eig.eigenvectors;
        let end = EndPhase {
            t0: t,
            q_star: q,
            k: eig.eigenvalues,
            modes,
            x0: modes.tr_mul(&delta0),
            v0: modes.tr_mul(&w),
        };
        if margin < 2.0 * amplitude + 1e-9 {
            let after = end.narrow_after(sys.body, 0.5 * (margin - 1e-9), horizon - t);
            return Err(Refusal::Wide { after });
        }
        if crossed && margin < CUTOFF_SAFETY {
            return Err(Refusal::NearCutoff);
        }
        Ok(end)
    }

    /// The first of the times 2^j / omega_0,max (j = 0, 1, ...) from t0 at which the linear
    /// motion's amplitude (the test of [`EndPhase::find`], sqrt(|x|^2 + I |v|^2 / k_min)) is
    /// within `limit`, less one doubling: the search cannot pass the amplitude test much
    /// sooner (it may between two samples of an oscillating mode; the wait is
    /// [`WIDE_WAIT`] of it). `span` where the motion is still that wide then.
    fn narrow_after(&self, body: Body, limit: f64, span: f64) -> f64 {
        let inertia = body.inertia.x;
        let a = 0.5 * body.damping / inertia;
        let w02 = self.k / inertia;
        let kmin = self.k.min();
        let wide =
            |x: &Vector3<f64>, v: &Vector3<f64>| amplitude2(x, v, inertia, kmin) > limit * limit;
        let mut t = 1.0 / w02.max().sqrt();
        let mut before = 0.0;
        while t < span {
            let (x, v) = propagate(a, &w02, t, &self.x0, &self.v0);
            if !wide(&x, &v) {
                return before;
            }
            before = t;
            t *= 2.0;
        }
        span.max(0.0)
    }

    /// The first instant from t0 on a grid of step [`SAMPLE_STEP`] / omega_0,max at which the
    /// linear motion I x'' + c x' + K x = 0 meets the settle test (|w| < omega_tol,
    /// |K x| < torque_tol), or t_max: (time, state, settled).
    pub(super) fn solve(&self, body: Body, params: &SettleParams) -> (f64, [f64; 7], bool) {
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

    /// The first instant in [t0, `t_end`] from which the ball stays within `params.arrival` of
    /// the minimum: where the energy of the linear motion about it, 1/2 (x' K x + I v^2), is at
    /// most 1/2 k_min arrival^2 (then k_min |x|^2 <= x' K x <= that, and the damping never lets
    /// the energy rise again), bisected to 1/4096 of the interval; `t_end` if the energy
    /// is still above it there, t0 if it already was at t0.
    pub(super) fn arrival(&self, body: Body, params: &SettleParams, t_end: f64) -> f64 {
        let inertia = body.inertia.x;
        let a = 0.5 * body.damping / inertia;
        let w02 = self.k / inertia;
        let limit = 0.5 * self.k.min() * params.arrival.0 * params.arrival.0;
        let energy = |t: f64| {
            let (x, v) = propagate(a, &w02, t, &self.x0, &self.v0);
            0.5 * (self.k.dot(&x.component_mul(&x)) + inertia * v.norm_squared())
        };
        let span = t_end - self.t0;
        if energy(0.0) <= limit {
            return self.t0;
        }
        if span <= 0.0 || energy(span) > limit {
            return t_end;
        }
        let (mut lo, mut hi) = (0.0, span);
        for _ in 0..ARRIVAL_BISECTIONS {
            let mid = 0.5 * (lo + hi);
            if energy(mid) <= limit {
                hi = mid;
            } else {
                lo = mid;
            }
        }
        self.t0 + hi
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
    /// 50 (on the 24,852 end phases of research/basins.rs, 143 of 479 on average, and never
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

/// Newton on the torque from the orientation `q_sw` (the ball turning at `w`): the strict
/// minimum it converges to within [`NEWTON_ITERATIONS`], the stiffness K there and the least
/// cut-off margin met on the way; refused (not near) where a linearization fails, K is not
/// positive definite, a step leaves 4 linear radii, or the amplitude estimated after the first
/// steps exceeds [`EARLY_EXIT`] times [`LINEAR_RADIUS`].
fn newton<M: TorqueModel>(
    sys: &RotorDynamics<'_, M>,
    q_sw: [f64; 4],
    w: &Vector3<f64>,
    evaluations: &mut u32,
) -> Result<([f64; 4], nalgebra::Matrix3<f64>, f64), Refusal> {
    let mut q = q_sw;
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
            return Ok((q, k, margin));
        }
        let step = chol.solve(&lin.torque);
        if step.norm() > 4.0 * LINEAR_RADIUS {
            return Err(Refusal::NotNear);
        }
        moved -= step;
        if let Some(&factor) = EARLY_EXIT.get(it) {
            // the amplitude test of `find`, estimated: the least diagonal element of K bounds
            // its least eigenvalue from above
            let k_diag = k[(0, 0)].min(k[(1, 1)]).min(k[(2, 2)]);
            let estimate = amplitude2(&moved, w, sys.body.inertia.x, k_diag).sqrt();
            if estimate > factor * LINEAR_RADIUS {
                return Err(Refusal::NotNear);
            }
        }
        q = normalized(quat_mul(q, quat_exp(&step)));
        if step.norm_squared() < NEWTON_DONE * NEWTON_DONE {
            // converged: a linearization at the new q would only confirm it
            return Ok((q, k, margin));
        }
    }
    Err(Refusal::NotNear)
}

/// The rotation vector delta (in the body frame of `q_star`) with q = q_star exp(delta), the
/// shorter way round.
fn rotation_from(q_star: [f64; 4], q: [f64; 4]) -> Vector3<f64> {
    let conj = [-q_star[0], -q_star[1], -q_star[2], q_star[3]];
    let mut rel = quat_mul(conj, q);
    if rel[3] < 0.0 {
        rel = rel.map(|c| -c);
    }
    let v = Vector3::new(rel[0], rel[1], rel[2]);
    let sv = v.norm();
    if sv < 1e-12 {
        v * 2.0
    } else {
        v * (2.0 * sv.atan2(rel[3]) / sv)
    }
}

/// The square of the energy-equivalent amplitude of the motion (rotation `delta` from a
/// minimum, rate `w`) about a minimum of least stiffness `k`, |delta|^2 + I |w|^2 / k: the
/// end phase's test of the linear radius and of a cut-off's margin (in any orthonormal frame,
/// the modes' too).
fn amplitude2(delta: &Vector3<f64>, w: &Vector3<f64>, inertia: f64, k: f64) -> f64 {
    delta.norm_squared() + inertia * w.norm_squared() / k
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
        // the same for every mode
        let decay = (-a * t).exp();
        for (i, mi) in m.iter_mut().enumerate() {
            let disc = a * a - w02[i];
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

#[cfg(test)]
mod tests {
    use super::*;

    /// The end phase of the linear motion I x'' + c x' + K x = 0 about the identity, the modes
    /// along the axes.
    fn linear(k: [f64; 3], x0: [f64; 3], v0: [f64; 3]) -> EndPhase {
        EndPhase {
            t0: 0.0,
            q_star: [0.0, 0.0, 0.0, 1.0],
            k: Vector3::from(k),
            modes: nalgebra::Matrix3::identity(),
            x0: Vector3::from(x0),
            v0: Vector3::from(v0),
        }
    }

    #[test]
    fn the_rotation_from_a_minimum_inverts_its_exponential() {
        let q_star = normalized([0.1, -0.3, 0.2, 0.9]);
        for delta in [
            Vector3::new(1e-3, -2e-3, 5e-4),
            Vector3::new(0.3, 0.1, -0.2),
            Vector3::zeros(),
        ] {
            let q = normalized(quat_mul(q_star, quat_exp(&delta)));
            assert!((rotation_from(q_star, q) - delta).norm() < 1e-12, "{delta}");
            // -q is the same orientation: the same rotation, the shorter way round
            let minus = q.map(|c| -c);
            assert!(
                (rotation_from(q_star, minus) - delta).norm() < 1e-12,
                "{delta}"
            );
        }
    }

    #[test]
    fn the_propagator_is_the_exact_damped_flow_in_every_regime() {
        // underdamped, critically damped and overdamped modes, x(0) = 1, v(0) = 0
        let a = 2.0;
        let w02 = Vector3::new(25.0, 4.0, 1.0);
        let t = 0.37;
        let (x, v) = propagate(a, &w02, t, &Vector3::repeat(1.0), &Vector3::zeros());
        let e = (-a * t).exp();
        let wd = (25.0f64 - a * a).sqrt();
        let under = e * ((wd * t).cos() + a / wd * (wd * t).sin());
        let critical = e * (1.0 + a * t);
        let mu = (a * a - 1.0f64).sqrt();
        let (l1, l2) = (a - mu, a + mu);
        let over = (l2 * (-l1 * t).exp() - l1 * (-l2 * t).exp()) / (l2 - l1);
        assert!(
            (x - Vector3::new(under, critical, over)).norm() < 1e-14,
            "{x}"
        );
        // the rates are the derivatives of the same motions
        let dunder = -e * (a * a + wd * wd) / wd * (wd * t).sin();
        let dcritical = -e * a * a * t;
        let dover = l1 * l2 * ((-l2 * t).exp() - (-l1 * t).exp()) / (l2 - l1);
        assert!(
            (v - Vector3::new(dunder, dcritical, dover)).norm() < 1e-13,
            "{v}"
        );
    }

    /// One classical Runge-Kutta step `h` of the linear motion I x'' + c x' + K x = 0 of `e`'s
    /// modes from (x, v).
    fn linear_rk4(
        e: &EndPhase,
        body: Body,
        (x, v): (Vector3<f64>, Vector3<f64>),
        h: f64,
    ) -> (Vector3<f64>, Vector3<f64>) {
        let (i, c) = (body.inertia.x, body.damping);
        let f = |x: &Vector3<f64>, v: &Vector3<f64>| (*v, -(e.k.component_mul(x) + v * c) / i);
        let (k1x, k1v) = f(&x, &v);
        let (k2x, k2v) = f(&(x + k1x * (h / 2.0)), &(v + k1v * (h / 2.0)));
        let (k3x, k3v) = f(&(x + k2x * (h / 2.0)), &(v + k2v * (h / 2.0)));
        let (k4x, k4v) = f(&(x + k3x * h), &(v + k3v * h));
        (
            x + (k1x + k2x * 2.0 + k3x * 2.0 + k4x) * (h / 6.0),
            v + (k1v + k2v * 2.0 + k3v * 2.0 + k4v) * (h / 6.0),
        )
    }

    /// The first instant of the settle test on the linear motion, integrated by classical
    /// Runge-Kutta with step `h` (the test looked at after every step).
    fn integrated_settle_time(e: &EndPhase, body: Body, params: &SettleParams, h: f64) -> f64 {
        let (mut x, mut v, mut t) = (e.x0, e.v0, 0.0);
        while t < params.t_max {
            let settled =
                e.k.component_mul(&x).norm() < params.torque_tol && v.norm() < params.omega_tol;
            if settled {
                return t;
            }
            (x, v) = linear_rk4(e, body, (x, v), h);
            t += h;
        }
        f64::INFINITY
    }

    #[test]
    fn the_closed_form_settle_time_is_the_integrated_one() {
        // long enough for the heavily damped set's slow mode
        let params = SettleParams {
            t_max: 20.0,
            ..SettleParams::default()
        };
        // the prototype's body, light and heavy damping, stiffnesses of one to a few pairs
        for (damping, k, x0, v0) in [
            (1.0, [2.5, 3.0, 5.0], [5e-3, -3e-3, 2e-3], [0.0, 0.0, 0.0]),
            (0.2, [2.5, 2.5, 7.5], [-4e-3, 1e-3, 0.0], [0.02, 0.0, -0.01]),
            (3.0, [1.0, 4.0, 9.0], [2e-3, 2e-3, -6e-3], [0.0, 0.05, 0.0]),
        ] {
            let body = Body {
                inertia: Vector3::repeat(0.023),
                damping,
            };
            let e = linear(k, x0, v0);
            let (t, y, settled) = e.solve(body, &params);
            assert!(settled, "c = {damping}");
            // the grid of the end phase: SAMPLE_STEP / omega_0 of the fastest mode
            let dt = SAMPLE_STEP / (e.k.max() / 0.023).sqrt();
            let t_int = integrated_settle_time(&e, body, &params, dt / 50.0);
            assert!(
                (t - t_int).abs() <= dt,
                "c = {damping}: {t} against {t_int}"
            );
            // and the state it gives there meets the test
            let w = Vector3::new(y[4], y[5], y[6]);
            assert!(
                w.norm() < params.omega_tol,
                "c = {damping}: |w| = {}",
                w.norm()
            );
        }
    }

    #[test]
    fn a_minimum_too_wide_for_its_margin_is_searched_again_once_its_motion_has_nearly_shrunk() {
        // a light and a heavy damping: an oscillating and a creeping slow mode
        for damping in [0.3, 3.0] {
            let body = Body {
                inertia: Vector3::repeat(0.023),
                damping,
            };
            let e = linear([2.0, 6.0, 12.0], [6e-3, -4e-3, 3e-3], [0.02, 0.0, -0.01]);
            let (i, kmin) = (body.inertia.x, e.k.min());
            let amplitude = |x: &Vector3<f64>, v: &Vector3<f64>| amplitude2(x, v, i, kmin).sqrt();
            let limit = 0.2 * amplitude(&e.x0, &e.v0);
            let after = e.narrow_after(body, limit, 30.0);
            // the motion integrated by classical Runge-Kutta, its amplitude at each step
            let h = 1e-4;
            let (mut x, mut v) = (e.x0, e.v0);
            let mut first_narrow = None;
            let mut t = 0.0;
            while t < 2.0 * after + h {
                if first_narrow.is_none() && amplitude(&x, &v) <= limit {
                    first_narrow = Some(t);
                }
                if (t - after).abs() < 0.5 * h {
                    assert!(
                        amplitude(&x, &v) > limit,
                        "c = {damping}: narrow at {after}"
                    );
                }
                (x, v) = linear_rk4(&e, body, (x, v), h);
                t += h;
            }
            // narrow by the next doubling, and not before the search looks again
            let Some(first) = first_narrow else {
                panic!("c = {damping}: still wide at {}", 2.0 * after);
            };
            assert!(
                after > 0.0 && first >= WIDE_WAIT * after && first <= 2.0 * after + h,
                "c = {damping}: first narrow at {first}, the wait {after}"
            );
        }
        // a motion that stays wide past the horizon waits for all of it
        let body = Body {
            inertia: Vector3::repeat(0.023),
            damping: 0.0,
        };
        let e = linear([2.0, 6.0, 12.0], [6e-3, -4e-3, 3e-3], [0.0; 3]);
        assert_eq!(e.narrow_after(body, 1e-4, 7.0), 7.0);
    }

    #[test]
    fn no_mode_can_settle_before_its_first_possible_instant() {
        let params = SettleParams::default();
        let body = Body {
            inertia: Vector3::repeat(0.023),
            damping: 0.5,
        };
        let e = linear([2.0, 6.0, 12.0], [8e-3, -5e-3, 3e-3], [0.0; 3]);
        let a = 0.5 * body.damping / body.inertia.x;
        let bound = e.first_possible(body.inertia.x, a, &params);
        let (t, _, settled) = e.solve(body, &params);
        assert!(settled && bound > 0.0 && bound <= t, "{bound} against {t}");
    }

    #[test]
    fn newton_finds_the_minimum_of_two_pairs_and_the_end_phase_is_linear_there() {
        use crate::model::geometry::Pair;
        let (torques, body) = super::super::prototype_physics();
        let active = [Pair::new(0, 14), Pair::new(12, 26)];
        let sys = RotorDynamics::new(&torques, &active, body);
        // the two pairs' minimum, from the reference settle
        let at = super::super::settle(
            &torques,
            &active,
            &crate::model::geometry::Orientation::identity(),
            body,
            SettleParams::default().reference(),
        );
        assert!(at.settled);
        let q = at.q.quaternion();
        let q_min = [q.i, q.j, q.k, q.w];
        // 0.3 degrees away, at rest
        let q_sw = normalized(quat_mul(q_min, quat_exp(&Vector3::new(3e-3, -3e-3, 2e-3))));
        let y = [q_sw[0], q_sw[1], q_sw[2], q_sw[3], 0.0, 0.0, 0.0];
        let mut evaluations = 0;
        let Ok(e) = EndPhase::find(&sys, &y, 0.0, 5.0, &mut evaluations, false) else {
            panic!("no end phase 0.3 degrees from a strict minimum");
        };
        assert!((1..=NEWTON_ITERATIONS).contains(&evaluations));
        // Newton lands on the minimum the integration settles to, within its settle test
        let to_min = rotation_from(q_min, e.q_star).norm();
        assert!(to_min < 1e-4, "{to_min} rad");
        assert!(e.k.min() > 0.0);
    }
}
