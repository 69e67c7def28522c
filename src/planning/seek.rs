//! Steering towards a goal orientation in a given physics: from a commutation state, every
//! coil set the supply allows is settled; the states nearest the goal are expanded again, level
//! by level (a beam search), until one is near enough or the depth is spent, and the path to the
//! nearest state found is the plan. The closed loop plans so in fitted wells (and follows the
//! path until a measurement strays from it); `research/fewest_steps.rs` uses the same search to
//! tell how few steps a physics needs for a motion. Budgets are counted in settles.

use crate::model::geometry::{CoilId, Orientation, Pair};
use crate::physics::torque::MagnetTorques;
use crate::planning::coilsets::{
    coil_sets, coils_in_reach, coils_of, label, settle_following_each, Labels, FOLLOWED_PER_STATE,
};
use crate::planning::commutation::{predicted_orientation, CommutationState, Motor, PairsPerStep};
use crate::planning::on_time::{self, OnTimeLimit, OnTimes};
use std::collections::BTreeMap;

/// How many states nearest the goal the closed loop's search keeps at each depth, and how deep
/// it looks at most. For scale (`research/fewest_steps.rs` on `scenarios/broad-wells.toml`,
/// from the state after the pair model's first step of 90 degrees): a beam of 32 comes within
/// 1 degree of the goal in 9 steps about Z and 10 about Y, and 3.3 degrees after 10 about X;
/// 16 costs half the settles (about 5,000 to 80,000 a search) and gives the closed-loop tables
/// of docs/closed-loop.md.
pub const BEAM: usize = 16;
/// How many steps deep the search looks at most (see [`BEAM`]).
pub const DEPTH: usize = 12;

/// A physics to steer in, and the goal.
pub struct Seek<'a> {
    /// The body and settle of the motor (its torques are not used) ...
    pub motor: &'a Motor,
    /// ... and the torques the steps are settled with.
    pub torques: &'a MagnetTorques,
    /// Coils on after each step, and at most this many on while a step switches.
    pub per_step: PairsPerStep,
    /// The most coils on at once while a step switches (the supply).
    pub max_coils_on: usize,
    /// The orientation to steer to, world frame.
    pub goal: Orientation,
    /// Settle only this many of a state's coil sets, those whose cheap prediction (the
    /// least-squares alignment of each coil with its nearest magnet,
    /// [`predicted_orientation`]) lies nearest the goal; `None`: every set.
    pub ranked: Option<usize>,
    /// The replay's on-time limit (`None`: none), and how long each coil held at the root has
    /// been on: a step that would keep a coil on past the limit is not taken, as the planners
    /// do not take one ([`crate::planning::on_time`]).
    pub on_time: Option<OnTimeLimit>,
    /// How long each coil on at the root has been on (empty without an on-time limit).
    pub held: OnTimes<CoilId>,
    /// Coil sets (sorted) not taken as the first step: those a closed loop took before from
    /// where the ball is again, which led it round in a circle.
    pub not_first: Vec<Vec<CoilId>>,
}

/// Two states with the same coils on whose orientations lie within this (degrees) of each
/// other are one equilibrium reached two ways: a settle stops within its tolerances of the
/// equilibrium (`omega_tol`, `torque_tol`), so where it stops depends on where it started, to
/// far below a sensor's resolution and far below the degrees between two equilibria of one set.
pub const SAME_STATE_DEG: f64 = 0.25;

/// The equilibria a search has met, by the coils on: each with the distance to the goal it was
/// first ranked by. An equilibrium met again (another path to it, at this depth or a later one)
/// is ranked by that same distance, so that the ties between the ways to it are broken by the
/// order they were found in (the nearer parent first, then the set's order), not by where each
/// settle happened to stop: a measurement a rounding away (a sensor's frame mapped back) gives
/// the same plan.
#[derive(Default)]
struct Seen {
    /// The kept states' equilibria ...
    kept: BTreeMap<Vec<CoilId>, Vec<(Orientation, f64)>>,
    /// ... and those of the level being ranked, in its order (its coils, orientation and
    /// distance), with where each set's are in it.
    level: Vec<(Vec<CoilId>, Orientation, f64)>,
    level_of: BTreeMap<Vec<CoilId>, Vec<usize>>,
}

impl Seen {
    /// The distance `s` is ranked by: that of the equilibrium it is the same as, met before,
    /// else its own, `own`. Called in the level's order.
    fn distance(&mut self, s: &CommutationState, own: f64) -> f64 {
        let coils = coils_of(&s.active);
        let same = |q: &Orientation| q.angle_to(&s.q) <= SAME_STATE_DEG.to_radians();
        let kept = self.kept.get(&coils).into_iter().flatten();
        let level = self.level_of.get(&coils).into_iter().flatten();
        let d = (kept.map(|&(q, d)| (q, d)))
            .chain(level.map(|&i| (self.level[i].1, self.level[i].2)))
            .find(|(q, _)| same(q))
            .map_or(own, |(_, d)| d);
        self.level_of
            .entry(coils.clone())
            .or_default()
            .push(self.level.len());
        self.level.push((coils, s.q, d));
        d
    }

    /// The level ranked: the states `keyed` keeps (by their index in the level) are met from
    /// now on.
    fn keep_only(&mut self, keyed: &[(f64, usize)]) {
        let level = std::mem::take(&mut self.level);
        self.level_of.clear();
        for &(_, i) in keyed {
            let (coils, q, d) = level[i].clone();
            self.kept.entry(coils).or_default().push((q, d));
        }
    }
}

/// What a search found.
#[derive(Debug, Clone)]
pub struct Path {
    /// The states from the root's first step on, to the one nearest the goal (the first found
    /// within the tolerance, else the nearest at any depth; empty if none is nearer the goal
    /// than the root).
    pub states: Vec<CommutationState>,
    /// Per depth (1 first), the nearest any state came to the goal (rad).
    pub nearest_by_depth: Vec<f64>,
    /// The settles the search spent.
    pub settles: usize,
}

impl Seek<'_> {
    fn distance(&self, q: &Orientation) -> f64 {
        q.angle_to(&self.goal)
    }

    /// Searches from `root` level by level, keeping the `beam` states nearest the goal at each
    /// depth, until a state within `tolerance` of the goal or `depth` steps; the path to the
    /// nearest state found.
    pub fn search(
        &self,
        root: &CommutationState,
        depth: usize,
        beam: usize,
        tolerance: f64,
    ) -> Path {
        let mut settles = 0;
        // every kept state: its parent (None: the root's child) and itself
        let mut kept: Vec<(Option<usize>, CommutationState)> = Vec::new();
        let mut level: Vec<(Option<usize>, CommutationState)> = vec![];
        // the on-times of each kept state's coils
        let mut kept_on: Vec<OnTimes<CoilId>> = Vec::new();
        let mut best: Option<(f64, usize)> = None;
        let mut nearest_by_depth = Vec::new();
        // one distance per equilibrium, whichever way it was reached (see [`Seen`])
        let mut seen = Seen::default();
        for d in 0..depth {
            let parents: Vec<(Option<usize>, &CommutationState)> = if d == 0 {
                vec![(None, root)]
            } else {
                level.iter().map(|(i, s)| (*i, s)).collect()
            };
            let mut next: Vec<(Option<usize>, CommutationState)> = Vec::new();
            let mut next_on: Vec<OnTimes<CoilId>> = Vec::new();
            let froms: Vec<&CommutationState> = parents.iter().map(|p| p.1).collect();
            let children = self.successors_each(&froms, &mut settles);
            for ((parent, _), cs) in parents.into_iter().zip(children) {
                let on = parent.map_or(&self.held, |i| &kept_on[i]);
                for c in cs {
                    if let Some(held) = self.admitted(on, &c, d) {
                        next.push((parent, c));
                        next_on.push(held);
                    }
                }
            }
            let mut keyed: Vec<(f64, usize)> = next
                .iter()
                .enumerate()
                .map(|(i, (_, s))| (seen.distance(s, self.distance(&s.q)), i))
                .collect();
            keyed.sort_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)));
            keyed.truncate(beam);
            nearest_by_depth.push(keyed.first().map_or(f64::INFINITY, |k| k.0));
            level = Vec::with_capacity(keyed.len());
            seen.keep_only(&keyed);
            for &(dist, i) in &keyed {
                kept.push(next[i].clone());
                kept_on.push(next_on[i].clone());
                let at = kept.len() - 1;
                if best.is_none_or(|(b, _)| dist < b) {
                    best = Some((dist, at));
                }
                level.push((Some(at), next[i].1.clone()));
            }
            if level.is_empty() || best.is_some_and(|(b, _)| b <= tolerance) {
                break;
            }
        }
        let mut states = Vec::new();
        let mut at = best
            .filter(|&(b, _)| b < self.distance(&root.q))
            .map(|b| b.1);
        while let Some(i) = at {
            states.push(kept[i].1.clone());
            at = kept[i].0;
        }
        states.reverse();
        Path {
            states,
            nearest_by_depth,
            settles,
        }
    }

    /// The on-times after `c` is stepped to at depth `d` (0: the root's step) from the on-times
    /// `on`, or `None` when the step is not taken: it keeps a coil on past the on-time limit, or
    /// it is a first step of [`Seek::not_first`].
    fn admitted(
        &self,
        on: &OnTimes<CoilId>,
        c: &CommutationState,
        d: usize,
    ) -> Option<OnTimes<CoilId>> {
        if d == 0 && self.not_first.contains(&coils_of(&c.active)) {
            return None;
        }
        let mut held = on.clone();
        if let Some(l) = self.on_time {
            on_time::hold(&mut held, coils_of(&c.active), d, l.dwell(c.settle_time_s));
            if on_time::over(&held, l.max_on).is_some() {
                return None;
            }
        }
        Some(held)
    }

    /// For each of `froms`, the states one step from it: each coil set the supply allows,
    /// weighed (a set no
    /// strict minimum holds stops where the ball comes to rest), the [`FOLLOWED_PER_STATE`] of
    /// those unheld sets that stop nearest the goal followed to where the ball really stops (as
    /// the coil-set planner does); those that settle, each coil with its nearest magnet there.
    /// Adds the settles spent to `settles`. All their settles run as one parallel batch (a
    /// settle does not depend on what runs beside it).
    pub fn successors_each(
        &self,
        froms: &[&CommutationState],
        settles: &mut usize,
    ) -> Vec<Vec<CommutationState>> {
        if self.motor.cancel.is_cancelled() {
            return froms.iter().map(|_| Vec::new()).collect();
        }
        let torques = self.torques;
        let sets: Vec<Vec<Vec<CoilId>>> = froms.iter().map(|f| self.sets_from(f)).collect();
        let pairs: Vec<Vec<Vec<Pair>>> = froms
            .iter()
            .zip(&sets)
            .map(|(f, ss)| {
                let labels = Labels::at(torques, &f.q);
                ss.iter().map(|c| labels.label(c)).collect()
            })
            .collect();
        let starts: Vec<(Orientation, &[Vec<Pair>])> = froms
            .iter()
            .zip(&pairs)
            .map(|(f, p)| (f.q, p.as_slice()))
            .collect();
        let rank = |q: &Orientation| self.distance(q);
        let follow = FOLLOWED_PER_STATE;
        let (results, spent) = settle_following_each(torques, &starts, self.motor, follow, rank);
        *settles += spent;
        results
            .into_iter()
            .zip(&sets)
            .map(|(rs, ss)| {
                rs.into_iter()
                    .zip(ss)
                    .filter(|(r, _)| r.settled)
                    .map(|(r, coils)| CommutationState {
                        q: r.q,
                        active: label(torques, coils, &r.q),
                        settle_time_s: r.arrival_time_s,
                    })
                    .collect()
            })
            .collect()
    }

    /// The coil sets tried from `from`: those the supply allows among the coils in reach; with
    /// [`Seek::ranked`], the `k` whose cheap prediction lies nearest the goal, in their order.
    fn sets_from(&self, from: &CommutationState) -> Vec<Vec<CoilId>> {
        let torques = self.torques;
        let held = coils_of(&from.active);
        let reach = coils_in_reach(torques, &from.q);
        let sets = coil_sets(&held, &reach, self.per_step, self.max_coils_on);
        let Some(k) = self.ranked.filter(|&k| k < sets.len()) else {
            return sets;
        };
        let labels = Labels::at(torques, &from.q);
        let mut keyed: Vec<(f64, usize)> = sets
            .iter()
            .enumerate()
            .map(|(i, c)| {
                let p = labels.label(c);
                (
                    self.distance(&predicted_orientation(torques, &from.q, &p)),
                    i,
                )
            })
            .collect();
        keyed.sort_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)));
        keyed.truncate(k);
        keyed.sort_by_key(|&(_, i)| i);
        keyed.iter().map(|&(_, i)| sets[i].clone()).collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::geometry::{rot_q, MagnetId, Radians, UnitVec};
    use nalgebra::Vector3;

    fn state(coils: &[usize], deg: f64) -> CommutationState {
        let z = UnitVec::new_normalize(Vector3::z());
        CommutationState {
            q: rot_q(&z, Radians(deg.to_radians())),
            active: (coils.iter())
                .map(|&c| Pair {
                    coil: CoilId(c),
                    magnet: MagnetId(c),
                })
                .collect(),
            settle_time_s: 0.0,
        }
    }

    #[test]
    fn one_equilibrium_met_two_ways_is_ranked_by_the_first_way() {
        let mut seen = Seen::default();
        // the first way, then the same equilibrium a settle's stop away, nearer by 1e-9
        assert_eq!(seen.distance(&state(&[1, 2], 10.0), 0.5), 0.5);
        assert_eq!(seen.distance(&state(&[2, 1], 10.0 + 1e-7), 0.5 - 1e-9), 0.5);
        // other coils, or the same coils a degree away: another state, its own distance
        assert_eq!(seen.distance(&state(&[1, 3], 10.0), 0.4), 0.4);
        assert_eq!(seen.distance(&state(&[1, 2], 11.0), 0.3), 0.3);
        // kept from this level: met at the next depth, it keeps its first distance; what was
        // not kept is forgotten
        seen.keep_only(&[(0.5, 0), (0.3, 3)]);
        assert_eq!(seen.distance(&state(&[1, 2], 10.0), 0.2), 0.5);
        assert_eq!(seen.distance(&state(&[1, 2], 11.0), 0.1), 0.3);
        assert_eq!(seen.distance(&state(&[1, 3], 10.0), 0.35), 0.35);
    }
}
