//! Steering towards a goal orientation in a given physics, a few steps ahead: from a
//! commutation state, every coil set the supply allows is settled; the states nearest the goal
//! are expanded again, level by level, and each first step is judged by the nearest any of its
//! descendants comes to the goal. The closed loop steers so with a fitted model (one step taken,
//! then measured, then looked ahead again); `examples/fewest_steps.rs` uses the same search to
//! tell how few steps a physics needs for a motion. Budgets are counted in settles.

use crate::model::geometry::{Orientation, Pair};
use crate::physics::dynamics::{settle_many, Stop};
use crate::physics::torque::MagnetTorques;
use crate::planning::coilsets::{coil_sets, coils_in_reach, coils_of, label, FOLLOWED_PER_STATE};
use crate::planning::commutation::{CommutationState, Motor, PairsPerStep};

/// How many steps ahead the closed loop looks by default ...
pub const HORIZON: usize = 3;
/// ... keeping this many states nearest the goal at each depth. Measured on the pair model's
/// 90 degree plans played on `scenarios/broad-wells.toml` (1 degree of sensor noise): horizon 3
/// and beam 8 reach the goal about Y and X within 1.2 degrees; horizon 4 and beam 24 (four
/// times the settles) look no further about Z (about 8 degrees of progress a step either way).
pub const BEAM: usize = 8;

/// A physics to steer in, and the goal.
pub struct Seek<'a> {
    /// The body and settle of the motor (its torques are not used) ...
    pub motor: &'a Motor<'a>,
    /// ... and the torques the steps are settled with.
    pub torques: &'a MagnetTorques,
    /// Coils on after each step, and at most this many on while a step switches.
    pub per_step: PairsPerStep,
    pub max_coils_on: usize,
    pub goal: Orientation,
}

/// What a look ahead found.
#[derive(Debug, Clone)]
pub struct Lookahead {
    /// The states one step from the root ...
    pub first: Vec<CommutationState>,
    /// ... and per first step the nearest (rad) it or any of its descendants in the beam came
    /// to the goal.
    pub reach: Vec<f64>,
    /// Per depth (1 first), the nearest any state came to the goal (rad).
    pub nearest_by_depth: Vec<f64>,
    pub settles: usize,
}

impl Lookahead {
    /// The first step that leads nearest the goal (the nearer first step of equals, then the
    /// first), if it leads nearer than `now`.
    pub fn best(&self, goal: &Orientation, now: f64) -> Option<usize> {
        (0..self.first.len())
            .min_by(|&a, &b| {
                let d = |i: usize| self.first[i].q.angle_to(goal);
                self.reach[a]
                    .total_cmp(&self.reach[b])
                    .then(d(a).total_cmp(&d(b)))
                    .then(a.cmp(&b))
            })
            .filter(|&i| self.reach[i] < now)
    }
}

impl Seek<'_> {
    fn distance(&self, q: &Orientation) -> f64 {
        q.angle_to(&self.goal)
    }

    /// Looks `horizon` steps ahead of `root`, keeping the `beam` states nearest the goal at
    /// each depth.
    pub fn look_ahead(&self, root: &CommutationState, horizon: usize, beam: usize) -> Lookahead {
        let mut settles = 0;
        let first = self.successors(root, &mut settles);
        let mut reach: Vec<f64> = first.iter().map(|s| self.distance(&s.q)).collect();
        let mut nearest_by_depth = vec![reach.iter().copied().fold(f64::INFINITY, f64::min)];
        let mut level = self.nearest(first.iter().cloned().enumerate().collect(), beam);
        for _ in 1..horizon {
            let mut next = Vec::new();
            for (origin, st) in &level {
                for c in self.successors(st, &mut settles) {
                    reach[*origin] = reach[*origin].min(self.distance(&c.q));
                    next.push((*origin, c));
                }
            }
            let best = next
                .iter()
                .map(|(_, s)| self.distance(&s.q))
                .fold(f64::INFINITY, f64::min);
            nearest_by_depth.push(best);
            level = self.nearest(next, beam);
        }
        Lookahead {
            first,
            reach,
            nearest_by_depth,
            settles,
        }
    }

    /// The `beam` states nearest the goal (the first of equals), with their first steps.
    fn nearest(
        &self,
        states: Vec<(usize, CommutationState)>,
        beam: usize,
    ) -> Vec<(usize, CommutationState)> {
        let mut keyed: Vec<(f64, usize, CommutationState)> = states
            .into_iter()
            .map(|(origin, s)| (self.distance(&s.q), origin, s))
            .collect();
        // a stable sort: equals keep their order
        keyed.sort_by(|a, b| a.0.total_cmp(&b.0));
        keyed.truncate(beam);
        keyed.into_iter().map(|(_, o, s)| (o, s)).collect()
    }

    /// The states one step from `from`: each coil set the supply allows, weighed (a set no
    /// strict minimum holds stops where the ball comes to rest), the [`FOLLOWED_PER_STATE`] of
    /// those unheld sets that stop nearest the goal followed to where the ball really stops
    /// (as the coil-set planner does); those that settle, each coil with its nearest magnet
    /// there. Adds the settles spent to `settles`.
    pub fn successors(
        &self,
        from: &CommutationState,
        settles: &mut usize,
    ) -> Vec<CommutationState> {
        let torques = self.torques;
        let held = coils_of(&from.active);
        let reach = coils_in_reach(torques, &from.q);
        let sets = coil_sets(&held, &reach, self.per_step, self.max_coils_on);
        let pairs: Vec<Vec<Pair>> = sets.iter().map(|c| label(torques, c, &from.q)).collect();
        let (body, weighing) = (self.motor.body, self.motor.weighing());
        let mut results = settle_many(torques, &pairs, &from.q, body, weighing);
        let mut unheld: Vec<(f64, usize)> = results
            .iter()
            .enumerate()
            .filter(|(_, r)| r.stop == Stop::Unheld)
            .map(|(i, r)| (self.distance(&r.q), i))
            .collect();
        unheld.sort_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)));
        unheld.truncate(FOLLOWED_PER_STATE);
        let again: Vec<Vec<Pair>> = unheld.iter().map(|&(_, i)| pairs[i].clone()).collect();
        let followed = settle_many(torques, &again, &from.q, body, self.motor.settle);
        for ((_, i), r) in unheld.iter().zip(followed) {
            results[*i] = r;
        }
        *settles += sets.len() + again.len();
        results
            .into_iter()
            .zip(&sets)
            .filter(|(r, _)| r.settled)
            .map(|(r, coils)| CommutationState {
                q: r.q,
                active: label(torques, coils, &r.q),
                settle_time_s: r.settle_time_s,
            })
            .collect()
    }
}
