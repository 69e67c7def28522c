//! The ball of the virtual motor: the plant's rotor moving under its equations of motion
//! (`physics::dynamics`, the paper's quaternion equations with damping) while the coils the
//! relays switch pull it. Time is the caller's: [`Ball::advance`] integrates the motion over
//! an interval with the coils on now, so a dwell too short really leaves the ball short.
//!
//! Which magnet a coil pulls: with the "coils" interaction every coil pulls every magnet in
//! reach and the question does not arise. With "pairs" a coil pulls one magnet, which the
//! relays do not say: a plan given as a hint says it (the pairs of the plan row whose coils
//! are the ones on now, looked for from the last row matched on); a coil no row names pulls
//! the magnet nearest it when it goes on.

use crate::model::geometry::{CoilId, MagnetId, Orientation, Pair};
use crate::physics::dynamics::{Body, RotorDynamics};
use crate::physics::integrator::{integrate_until, Tolerances, Verdict};
use crate::physics::torque::MagnetTorques;
use nalgebra::{Quaternion, UnitQuaternion};
use std::collections::BTreeSet;

/// The integrator's tolerances for the real-time motion: tight enough that the ball comes to
/// rest where a settle puts it (a settle's own fast path is looser and finishes in closed form).
pub const TOLERANCES: Tolerances = Tolerances {
    rtol: 1e-7,
    atol: 1e-10,
};

/// The rotor, where it is and how fast it turns, and the pairs pulling it.
#[derive(Debug, Clone)]
pub struct Ball {
    torques: MagnetTorques,
    body: Body,
    /// (q1, q2, q3, q4, w1, w2, w3): orientation (vector, scalar) and body rate.
    y: [f64; 7],
    /// The coil:magnet pairs pulling now.
    pairs: Vec<Pair>,
    /// The plan's active sets, in order (empty: no hint).
    hint: Vec<Vec<Pair>>,
    /// The last hint row matched.
    hint_at: usize,
}

impl Ball {
    /// The ball at rest at `start`, no coil on; `hint`: a plan's active sets, in order.
    pub fn new(
        torques: MagnetTorques,
        body: Body,
        start: Orientation,
        hint: Vec<Vec<Pair>>,
    ) -> Ball {
        let q = start.quaternion();
        Ball {
            torques,
            body,
            y: [q.i, q.j, q.k, q.w, 0.0, 0.0, 0.0],
            pairs: Vec::new(),
            hint,
            hint_at: 0,
        }
    }

    /// Where the ball is now (body to world).
    pub fn orientation(&self) -> Orientation {
        UnitQuaternion::from_quaternion(Quaternion::new(self.y[3], self.y[0], self.y[1], self.y[2]))
    }

    /// How fast it turns, rad/s.
    pub fn rate(&self) -> f64 {
        (self.y[4] * self.y[4] + self.y[5] * self.y[5] + self.y[6] * self.y[6]).sqrt()
    }

    /// The pairs pulling now.
    pub fn pairs(&self) -> &[Pair] {
        &self.pairs
    }

    /// The coils on changed to `coils`: the pairs that pull from now on.
    pub fn set_coils(&mut self, coils: &BTreeSet<CoilId>) {
        let matches = |set: &Vec<Pair>| {
            set.len() == coils.len() && set.iter().all(|p| coils.contains(&p.coil))
        };
        let found = (self.hint_at..self.hint.len())
            .chain(0..self.hint_at)
            .find(|&k| matches(&self.hint[k]));
        if let Some(k) = found {
            self.hint_at = k;
            self.pairs = self.hint[k].clone();
            return;
        }
        let q = self.orientation();
        let mut pairs: Vec<Pair> = self
            .pairs
            .iter()
            .filter(|p| coils.contains(&p.coil))
            .copied()
            .collect();
        for &c in coils {
            if !pairs.iter().any(|p| p.coil == c) {
                if let Some(m) = self.nearest_magnet(&q, c) {
                    pairs.push(Pair { coil: c, magnet: m });
                }
            }
        }
        pairs.sort();
        self.pairs = pairs;
    }

    /// The magnet nearest coil `c` at `q` (`None` for a coil not on the stator).
    fn nearest_magnet(&self, q: &Orientation, c: CoilId) -> Option<MagnetId> {
        let s = self.torques.stator.get(c.0)?;
        let r = q.to_rotation_matrix();
        (self.torques.rotor.iter().enumerate())
            .map(|(j, m)| (j, (r * m).dot(s)))
            .max_by(|a, b| a.1.total_cmp(&b.1))
            .map(|(j, _)| MagnetId(j))
    }

    /// Integrates the motion over `dt` seconds with the pairs on now.
    pub fn advance(&mut self, dt: f64) {
        if !(dt.is_finite() && dt > 0.0) {
            return;
        }
        if self.pairs.is_empty() && self.rate() == 0.0 {
            return; // at rest, nothing pulling
        }
        let sys = RotorDynamics::new(&self.torques, &self.pairs, self.body);
        let out = integrate_until(&sys, self.y, dt, TOLERANCES, 0.0, |_, _, _| Verdict::Go);
        let mut y = out.y;
        let n = (y[0] * y[0] + y[1] * y[1] + y[2] * y[2] + y[3] * y[3]).sqrt();
        if n.is_finite() && n > 0.0 {
            for v in &mut y[..4] {
                *v /= n;
            }
            self.y = y;
        }
    }
}
