//! The ball of the virtual motor: the plant's rotor moving under its equations of motion
//! (`physics::dynamics`, the paper's quaternion equations with damping) while the coils the
//! relays switch pull it. Time is the caller's: [`Ball::advance`] integrates the motion over
//! an interval with the coils on now, so a dwell too short really leaves the ball short.
//!
//! At rest it is where the simulated plant puts it. Each switch of the coils has a settle:
//! the plant's own (`dynamics::settle` with its torques, body and settle parameters, the call
//! the simulated closed loop makes for a step) of the pairs on from where the ball last rested,
//! made once, when the integrated ball first comes to rest after the switch (made at the switch,
//! its wall time would hold up the relays' replies). Where the ball last rested stays the
//! settle's start through a transition, whose relays are switched a frame at a time while the
//! ball moves a little under the sets in between. The motion is integrated for the readings
//! while the ball moves; once the settle's time to rest has passed since the switch and the
//! integrated ball rests by the settle's own test (rate and torque below its tolerances) within
//! [`SAME_REST`] of the settle's equilibrium, the ball is at that equilibrium, to the bit, at
//! rate 0, and stays there until the coils switch again. Where it rests elsewhere (the sets of
//! a transition, or a dwell too short, took it into another well), or where the settle did not
//! settle, the settle is forgotten and the ball goes on under its own motion; it rests where it
//! is when a switch finds it at rest by that test.
//!
//! Which magnet a coil pulls: with the "coils" interaction every coil pulls every magnet in
//! reach and the question does not arise (only the coils' order, by index as the planners list
//! them). With "pairs" a coil pulls one magnet, which the relays do not say: a plan given as a
//! hint says it (the pairs of the plan row whose coils are the ones on now, looked for from the
//! last row matched on); a coil no row names pulls the magnet nearest it when it goes on.

use crate::model::geometry::{CoilId, MagnetId, Orientation, Pair};
use crate::physics::dynamics::{
    orientation_of, settle, Body, RotorDynamics, SettleParams, SettleResult,
};
use crate::physics::integrator::{integrate_until, Tolerances, Verdict};
use crate::physics::torque::MagnetTorques;
use std::collections::BTreeSet;

/// The integrator's tolerances for the real-time motion: tight enough that the ball comes to
/// rest where a settle puts it (a settle's own fast path is looser and finishes in closed form).
pub const TOLERANCES: Tolerances = Tolerances {
    rtol: 1e-7,
    atol: 1e-10,
};

/// The integrated ball at rest within this (radians, 0.06 degrees) of the settle's
/// equilibrium rests in that equilibrium: both pass the settle's test of rest about the same
/// minimum, where the torque is below the settle's `torque_tol` (1e-4 N m by default: some
/// 1e-5 rad in the plants' wells, whose distinct minima lie degrees apart). Farther, the ball
/// keeps its own motion.
pub const SAME_REST: f64 = 1e-3;

/// The settle of a switch, from where the ball last rested with the pairs on since.
#[derive(Debug, Clone)]
struct Settling {
    /// Virtual time since the switch, s.
    elapsed: f64,
    /// The settle's result: made once, when the integrated ball first rests (made at the
    /// switch, its wall time would hold up the relays' replies and so lengthen the sets a
    /// transition passes through on the virtual clock).
    result: Option<SettleResult>,
}

/// The rotor, where it is and how fast it turns, and the pairs pulling it.
#[derive(Debug, Clone)]
pub struct Ball {
    torques: MagnetTorques,
    body: Body,
    /// The plant's settle (its tolerances, time limit and integrator).
    params: SettleParams,
    /// (q1, q2, q3, q4, w1, w2, w3): orientation (vector, scalar) and body rate.
    y: [f64; 7],
    /// The ball at rest exactly here (its start, or a settle's equilibrium), rate 0; `None`
    /// while it moves (then `y` says where it is).
    at_rest: Option<Orientation>,
    /// Where the ball last rested: a settle of a switch starts here.
    rested: Orientation,
    /// The settle of the last switch, until the ball rests in its equilibrium or elsewhere.
    settling: Option<Settling>,
    /// The coil:magnet pairs pulling now.
    pairs: Vec<Pair>,
    /// The plan's active sets, in order (empty: no hint).
    hint: Vec<Vec<Pair>>,
    /// The last hint row matched.
    hint_at: usize,
}

impl Ball {
    /// The ball at rest at `start`, no coil on, in the physics of `torques` and `body`, settled
    /// as `params` say; `hint`: a plan's active sets, in order.
    pub fn new(
        torques: MagnetTorques,
        body: Body,
        params: SettleParams,
        start: Orientation,
        hint: Vec<Vec<Pair>>,
    ) -> Ball {
        Ball {
            torques,
            body,
            params,
            y: state_at_rest(&start),
            at_rest: Some(start),
            rested: start,
            settling: None,
            pairs: Vec::new(),
            hint,
            hint_at: 0,
        }
    }

    /// Where the ball is now (body to world).
    pub fn orientation(&self) -> Orientation {
        match self.at_rest {
            Some(q) => q,
            None => orientation_of(&self.y),
        }
    }

    /// How fast it turns, rad/s.
    pub fn rate(&self) -> f64 {
        (self.y[4] * self.y[4] + self.y[5] * self.y[5] + self.y[6] * self.y[6]).sqrt()
    }

    /// Whether the ball is at rest exactly where a settle put it (or at its start).
    pub fn at_rest(&self) -> bool {
        self.at_rest.is_some()
    }

    /// The pairs pulling now.
    pub fn pairs(&self) -> &[Pair] {
        &self.pairs
    }

    /// The coils on changed to `coils`: the pairs that pull from now on, and the settle of
    /// the switch from where the ball last rested (none when the pairs did not change, when
    /// nothing pulls, or when the ball at rest is in equilibrium under them already: then it
    /// does not move).
    pub fn set_coils(&mut self, coils: &BTreeSet<CoilId>) {
        let pairs = self.pairs_for(coils);
        if pairs == self.pairs {
            return; // a read-back, or a frame that changed nothing
        }
        match self.at_rest {
            Some(q) => self.rested = q,
            // moving on its own (no settle pending), and come to rest by the settle's test: it
            // rests here
            None if self.settling.is_none() && self.resting() => {
                let q = orientation_of(&self.y);
                self.y = state_at_rest(&q);
                self.at_rest = Some(q);
                self.rested = q;
            }
            // on its way from rest: through the switches of one transition (the relays
            // switched one at a time), or after a dwell too short (then where the integrated
            // ball comes to rest decides, see `arrive`)
            None => {}
        }
        self.pairs = pairs;
        self.settling = None;
        if self.pairs.is_empty() {
            return;
        }
        if self.at_rest.is_some() {
            // the settle's own first test: in equilibrium already, it does not move
            let sys = RotorDynamics::new(&self.torques, &self.pairs, self.body);
            if sys.body_torque(&self.y).norm() < self.params.torque_tol {
                return;
            }
        }
        self.settling = Some(Settling {
            elapsed: 0.0,
            result: None,
        });
    }

    /// The pairs for `coils`: a hint row's, else those pulling now kept and the new coils
    /// paired with their nearest magnets.
    fn pairs_for(&mut self, coils: &BTreeSet<CoilId>) -> Vec<Pair> {
        let matches = |set: &Vec<Pair>| {
            set.len() == coils.len() && set.iter().all(|p| coils.contains(&p.coil))
        };
        let found = (self.hint_at..self.hint.len())
            .chain(0..self.hint_at)
            .find(|&k| matches(&self.hint[k]));
        if let Some(k) = found {
            self.hint_at = k;
            return self.hint[k].clone();
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
        pairs
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

    /// Whether the integrated ball passes the settle's test of rest with the pairs on now:
    /// its rate below `omega_tol` and the torque on it below `torque_tol`.
    fn resting(&self) -> bool {
        if self.rate() >= self.params.omega_tol {
            return false;
        }
        let sys = RotorDynamics::new(&self.torques, &self.pairs, self.body);
        sys.body_torque(&self.y).norm() < self.params.torque_tol
    }

    /// Integrates the motion over `dt` seconds with the pairs on now; once the switch's
    /// settle has had its time and the ball rests next to its equilibrium, the ball is there.
    pub fn advance(&mut self, dt: f64) {
        if !(dt.is_finite() && dt > 0.0) {
            return;
        }
        if self.at_rest.is_some() && self.settling.is_none() {
            return; // at rest where a settle put it (or nothing pulling)
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
            self.at_rest = None;
        }
        self.arrive(dt);
    }

    /// After `dt` more seconds of the switch's settle: once the settle had its time to rest
    /// and the integrated ball rests by the settle's test, the ball is at the settle's
    /// equilibrium if it rests within [`SAME_REST`] of it; else the settle is forgotten (the
    /// ball rests elsewhere, or the settle did not settle) and the ball goes on moving on its
    /// own.
    fn arrive(&mut self, dt: f64) {
        let resting = self.resting();
        let Some(s) = self.settling.as_mut() else {
            return;
        };
        s.elapsed += dt;
        if !resting && s.result.is_none() {
            return;
        }
        let (torques, pairs, rested) = (&self.torques, &self.pairs, &self.rested);
        let r = *s
            .result
            .get_or_insert_with(|| settle(torques, pairs, rested, self.body, self.params));
        if s.elapsed < r.settle_time_s {
            return;
        }
        if !r.settled {
            self.settling = None;
            return;
        }
        if !resting {
            return;
        }
        self.settling = None;
        if orientation_of(&self.y).angle_to(&r.q) <= SAME_REST {
            self.y = state_at_rest(&r.q);
            self.at_rest = Some(r.q);
        }
    }
}

/// The state (orientation, rate 0) of the ball at rest at `q`.
fn state_at_rest(q: &Orientation) -> [f64; 7] {
    let c = q.quaternion();
    [c.i, c.j, c.k, c.w, 0.0, 0.0, 0.0]
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::io::scenario::Scenario;
    use crate::planning::plan::PlanRow;

    /// The prototype's ball at rest at the start of its plan, the plan's sets its hint, and
    /// the plan's rows.
    fn prototype_ball() -> (Ball, Vec<PlanRow>) {
        let sc = Scenario::prototype();
        let plan = sc.motor().plan(&sc.plan);
        assert!(plan.rows.len() >= 3);
        let hint = plan.rows.iter().map(|r| r.active.clone()).collect();
        let ball = Ball::new(sc.torques.clone(), sc.body, sc.settle, plan.rows[0].q, hint);
        (ball, plan.rows)
    }

    fn coils(row: &PlanRow) -> BTreeSet<CoilId> {
        row.active.iter().map(|p| p.coil).collect()
    }

    /// The settle of `row`'s set from `q`, in the ball's physics.
    fn settled(ball: &Ball, row: &PlanRow, q: &Orientation) -> SettleResult {
        let r = settle(&ball.torques, &row.active, q, ball.body, ball.params);
        assert!(r.settled && r.settle_time_s > 0.05, "{r:?}");
        r
    }

    /// Advances the ball `t` seconds in steps of `dt`.
    fn run(ball: &mut Ball, t: f64, dt: f64) {
        for _ in 0..(t / dt).round() as usize {
            ball.advance(dt);
        }
    }

    #[test]
    fn a_ball_switched_at_rest_rests_at_the_settles_equilibrium_to_the_bit() {
        let (mut ball, rows) = prototype_ball();
        ball.set_coils(&coils(&rows[1]));
        assert_eq!(ball.pairs(), rows[1].active.as_slice());
        let want = settled(&ball, &rows[1], &rows[0].q);
        ball.advance(0.01);
        assert!(!ball.at_rest());
        run(&mut ball, want.settle_time_s + 1.0, 0.01);
        assert!(ball.at_rest());
        assert_eq!(ball.orientation(), want.q);
        assert_eq!(ball.rate(), 0.0);
        // a read-back (the same coils) leaves it there, and so does time
        ball.set_coils(&coils(&rows[1]));
        run(&mut ball, 1.0, 0.1);
        assert_eq!(ball.orientation(), want.q);
    }

    #[test]
    fn a_dwell_too_short_leaves_the_ball_short_and_moving() {
        let (mut ball, rows) = prototype_ball();
        ball.set_coils(&coils(&rows[1]));
        let want = settled(&ball, &rows[1], &rows[0].q);
        run(&mut ball, 0.3 * want.settle_time_s, 0.01);
        assert!(!ball.at_rest());
        assert!(ball.rate() > 1e-3, "{}", ball.rate());
        let short = ball.orientation().angle_to(&want.q);
        assert!(short > 1e-3, "{short}");
        // switched off there: it coasts on from where it was, never to the equilibrium
        ball.set_coils(&BTreeSet::new());
        run(&mut ball, 3.0, 0.01);
        assert!(!ball.at_rest());
        assert!(ball.orientation().angle_to(&want.q) > 1e-4);
    }

    #[test]
    fn the_sets_a_transition_passes_through_briefly_leave_the_settle_from_rest() {
        let (mut ball, rows) = prototype_ball();
        ball.set_coils(&coils(&rows[1]));
        let first = settled(&ball, &rows[1], &rows[0].q);
        run(&mut ball, first.settle_time_s + 1.0, 0.01);
        assert_eq!(ball.orientation(), first.q);
        // row 2's coils on first, then row 1's off, a few milliseconds later: the settle is
        // from where the ball rested, as a simulated plant switches the set at once
        let (from, to) = (coils(&rows[1]), coils(&rows[2]));
        let both: BTreeSet<CoilId> = from.union(&to).copied().collect();
        assert!(both.len() > to.len());
        ball.set_coils(&both);
        run(&mut ball, 0.004, 0.001);
        assert!(!ball.at_rest());
        ball.set_coils(&to);
        assert_eq!(ball.pairs(), rows[2].active.as_slice());
        let want = settled(&ball, &rows[2], &first.q);
        run(&mut ball, want.settle_time_s + 1.0, 0.01);
        assert_eq!(ball.orientation(), want.q);
    }
}
