//! Coil-set steps (docs/model.md, "Commutation", item 5): the hardware's view of commutation.
//! A state is the set of coils on and the orientation the ball settled to; a step switches to
//! another set of 2..=K coils among those in reach of the rotor's magnets, and where the ball
//! goes is what the settle says (every candidate set settled in parallel), with whatever the
//! scenario's interaction and well shape (gaussian, cosine, table) make every coil pull. Each
//! coil on is written with the magnet nearest it at the settled orientation. A step source for
//! the searches of `search`, which it shares with the pair models.

use crate::model::geometry::{
    angular_distance, rotation_axis, CoilId, MagnetId, Orientation, Pair, Radians, UnitVec,
};
use crate::physics::dynamics::{settle, SettleParams, SettleResult, Stop};
use crate::physics::torque::{Interaction, MagnetTorques};
use crate::planning::commutation::{
    admissible, bottom_coil, combinations, holds, nearest_magnet, pivot_error,
    predicted_orientation, CommutationState, Motor, PairsPerStep, Step, StepLimits,
};
use crate::planning::plan::PlanSettings;
use crate::planning::search::{predicted_rank, weighed, Frontier, StepSource, ONWARD};
use rayon::prelude::*;

/// How many of a state's candidate sets that the weighing left unheld are followed again (as
/// `simulate` settles them: at tight tolerances, ten times the cost of a settle). In broad
/// wells the best steps are often among them: on `scenarios/broad-wells.toml` following 4 takes
/// the worst axis error about Y from 20 to 6 degrees; 8 or 16 find no better plans.
pub const FOLLOWED_PER_STATE: usize = 4;

/// The coil-set model as a step source.
pub struct CoilSets<'a> {
    motor: &'a Motor,
    /// The settings, with the capture resolved.
    s: &'a PlanSettings,
    /// A coil counts only when the magnet nearest it is within this (by default the maximum
    /// attraction distance: it pulls).
    capture: Radians,
}

impl<'a> CoilSets<'a> {
    /// The coil-set model of `motor` with the settings `s` (their capture, else the maximum
    /// attraction distance).
    pub fn new(motor: &'a Motor, s: &'a PlanSettings) -> Self {
        let capture = s.limits.capture_for(s.model, &motor.torques.well);
        CoilSets { motor, s, capture }
    }

    /// Settles each coil set from `q`, with the weighing settle, then follows again (as
    /// `simulate` settles them) the sets it left unheld (the ball came to rest, but not near a
    /// strict minimum it could be sure of: with broad wells, often a magnet at its well's
    /// cut-off), the [`FOLLOWED_PER_STATE`] best of them by the rank where the weighing left
    /// the ball would give the plan at `at` (all of them without `at`). Returns the settles
    /// spent and, per set, the state it holds the ball in, each coil written with its nearest
    /// magnet there; `None` where the set does not settle (within `t_max`, or unheld and not
    /// followed), where a coil's nearest magnet is beyond the capture distance (the coil pulls
    /// nothing), or (with the "pairs" interaction, where a coil pulls only its pair's magnet:
    /// the one nearest it at `q`) where a coil's nearest magnet has changed, so that the plan's
    /// pairs are exactly what was settled.
    fn settle_sets(
        &self,
        q: &Orientation,
        sets: &[Vec<CoilId>],
        at: Option<&Frontier>,
    ) -> (usize, Vec<Option<CommutationState>>) {
        match at {
            Some(at) => self.settle_ranked(q, sets, FOLLOWED_PER_STATE, |r| self.rank_at(at, r)),
            None => self.settle_ranked(q, sets, usize::MAX, |_| 0.0),
        }
    }

    /// [`Self::settle_sets`] with the sets left unheld that are followed again chosen by
    /// `rank` (lowest first), `follow` of them.
    fn settle_ranked(
        &self,
        q: &Orientation,
        sets: &[Vec<CoilId>],
        follow: usize,
        rank: impl Fn(&Orientation) -> f64 + Sync,
    ) -> (usize, Vec<Option<CommutationState>>) {
        if self.motor.cancel.is_cancelled() {
            return (0, vec![None; sets.len()]);
        }
        let torques = &self.motor.torques;
        let labels = Labels::at(torques, q);
        let pairs: Vec<Vec<Pair>> = sets.iter().map(|c| labels.label(c)).collect();
        let (results, spent) = settle_following(torques, &pairs, q, self.motor, follow, rank);
        let states = results
            .into_iter()
            .zip(sets)
            .map(|(r, coils)| {
                if !r.settled {
                    return None;
                }
                let active = label(torques, coils, &r.q);
                let expected = label(torques, coils, q);
                if torques.interaction == Interaction::Pairs && active != expected {
                    return None;
                }
                let to = CommutationState {
                    q: r.q,
                    active,
                    settle_time_s: r.arrival_time_s,
                };
                holds(torques, &to, self.capture).then_some(to)
            })
            .collect();
        (spent, states)
    }

    /// The rank a partial plan at `at` would have after a step to `q` (unranked last).
    fn rank_at(&self, at: &Frontier, q: &Orientation) -> f64 {
        predicted_rank(at, q, self.s).unwrap_or(f64::INFINITY)
    }

    /// Settles candidate sets from `at` and keeps the admissible steps; with the settles spent.
    fn weigh(&self, at: &Frontier, sets: &[Vec<CoilId>]) -> (usize, Vec<Step>) {
        let from = at.state;
        let (spent, states) = self.settle_sets(&from.q, sets, Some(at));
        (
            spent,
            self.steps_to(from, states, &self.s.axis, &self.s.limits),
        )
    }

    /// The admissible steps from `from` to the settled `states` (`limits`' angle and axis
    /// error about `axis`), each with the coils it switches on.
    fn steps_to(
        &self,
        from: &CommutationState,
        states: Vec<Option<CommutationState>>,
        axis: &UnitVec,
        limits: &StepLimits,
    ) -> Vec<Step> {
        let on = coils_of(&from.active);
        let torques = &self.motor.torques;
        states
            .into_iter()
            .flatten()
            .filter_map(|to| {
                let (to, angle, axis_error) =
                    admissible(torques, &from.q, to, axis, limits, self.capture)?;
                let new = to
                    .active
                    .iter()
                    .filter(|p| !on.contains(&p.coil))
                    .copied()
                    .collect();
                Some(Step {
                    pivot: None,
                    new,
                    to,
                    angle,
                    axis_error,
                })
            })
            .collect()
    }

    /// The candidate sets from a partial plan's state that are settled: every set of the
    /// smallest size (the prediction is poorest where few coils pull many magnets), and of each
    /// larger size the `settles_per_state` best by the rank their cheap prediction (each coil
    /// pulling its nearest magnet like a spring) would give the plan, those predicted not to
    /// advance last; none that keeps a tired coil on ([`Frontier::tired`]).
    fn ranked_sets(&self, at: &Frontier) -> Vec<Vec<CoilId>> {
        let (torques, s) = (&self.motor.torques, self.s);
        let reach = coils_in_reach(torques, &at.state.q);
        let held = coils_of(&at.state.active);
        let labels = Labels::at(torques, &at.state.q);
        let ranked: Vec<(f64, Vec<CoilId>)> =
            coil_sets(&held, &reach, s.pairs, s.limits.max_coils_on)
                .into_iter()
                .filter(|set| set.iter().all(|c| !at.tired.contains(c)))
                .map(|set| {
                    let qp = predicted_orientation(torques, &at.state.q, &labels.label(&set));
                    (predicted_rank(at, &qp, s).unwrap_or(f64::INFINITY), set)
                })
                .collect();
        weighed(ranked, Vec::len, s.pairs.min, s.settles_per_state)
    }

    /// The initial sets: the coil nearest -Z with each other coil in reach at the start, the
    /// better pivot for the axis first (as the pair models order their second pair), then the
    /// coil whose magnet is nearest.
    fn initial_sets(&self) -> Vec<Vec<CoilId>> {
        let (torques, s) = (&self.motor.torques, self.s);
        let first = bottom_coil(torques);
        let base = pivot_error(torques, first, &s.axis).0;
        let mut seconds: Vec<(f64, f64, CoilId)> = coils_in_reach(torques, &s.start)
            .into_iter()
            .filter(|&c| c != first)
            .map(|c| {
                let pe = pivot_error(torques, c, &s.axis).0;
                let key = if pe < base - 1e-9 { pe } else { base };
                (key, nearest_magnet(torques, c, &s.start).1 .0, c)
            })
            .collect();
        seconds.sort_by(|a, b| {
            a.0.total_cmp(&b.0)
                .then(a.1.total_cmp(&b.1))
                .then(a.2.cmp(&b.2))
        });
        seconds
            .into_iter()
            .map(|(_, _, c)| vec![first, c])
            .collect()
    }
}

impl CoilSets<'_> {
    /// The sets a landing weighs from `state` towards `goal`: every switch [`coil_sets`] allows
    /// from the coils on (some of them kept, coils in reach switched on, or a release), none of
    /// `avoid` kept or switched on; every set of the smallest size and of each larger size the
    /// `settles_per_state` whose cheap prediction ([`predicted_orientation`]) leaves the ball
    /// nearest `goal`.
    fn landing_sets(
        &self,
        state: &CommutationState,
        goal: &Orientation,
        avoid: &[CoilId],
    ) -> Vec<Vec<CoilId>> {
        let (torques, s) = (&self.motor.torques, self.s);
        let reach = coils_in_reach(torques, &state.q);
        let held = coils_of(&state.active);
        let labels = Labels::at(torques, &state.q);
        let ranked: Vec<(f64, Vec<CoilId>)> =
            coil_sets(&held, &reach, s.pairs, s.limits.max_coils_on)
                .into_iter()
                .filter(|set| set.iter().all(|c| !avoid.contains(c)))
                .map(|set| {
                    let qp = predicted_orientation(torques, &state.q, &labels.label(&set));
                    (qp.angle_to(goal), set)
                })
                .collect();
        weighed(ranked, Vec::len, s.pairs.min, s.settles_per_state)
    }
}

impl StepSource for CoilSets<'_> {
    fn initial_states(&self) -> Vec<CommutationState> {
        self.settle_sets(&self.s.start, &self.initial_sets(), None)
            .1
            .into_iter()
            .flatten()
            .collect()
    }

    fn no_initial_state(&self) -> String {
        format!(
            "no initial commutation state: no set of the coil nearest -Z and another coil in \
             reach settles from the start orientation with every coil pulling (its nearest \
             magnet within {:.2} degrees)",
            self.capture.0.to_degrees()
        )
    }

    fn steps(&self, state: &CommutationState, _wide: bool) -> Vec<Step> {
        let at = Frontier {
            state,
            q0: state.q,
            worst: 0.0,
            cum: 0.0,
            tired: &[],
            ranking: ONWARD,
            goal: None,
        };
        self.weigh(&at, &self.ranked_sets(&at)).1
    }

    fn expand(&self, at: &Frontier) -> (usize, Vec<Step>) {
        self.weigh(at, &self.ranked_sets(at))
    }

    fn expand_towards(&self, at: &Frontier, goal: &Orientation) -> (usize, Vec<Step>) {
        let from = at.state;
        let Some(towards) = rotation_axis(&(goal * from.q.inverse())) else {
            return (0, Vec::new());
        };
        let sets = self.landing_sets(from, goal, at.tired);
        let follow = FOLLOWED_PER_STATE;
        let (spent, states) = self.settle_ranked(&from.q, &sets, follow, |r| r.angle_to(goal));
        let landing = self.s.limits.landing();
        (spent, self.steps_to(from, states, &towards, &landing))
    }
}

/// Settles each of `pairs` from `q` in `torques` with `motor`'s body and weighing settle, then
/// follows again with its settle (to where the ball really stops) the `follow` sets left unheld
/// whose weighing left the ball lowest by `rank` (the first of equals): the results, each in
/// its set's place, and the settles spent.
pub fn settle_following(
    torques: &MagnetTorques,
    pairs: &[Vec<Pair>],
    q: &Orientation,
    motor: &Motor,
    follow: usize,
    rank: impl Fn(&Orientation) -> f64 + Sync,
) -> (Vec<SettleResult>, usize) {
    let (mut all, spent) = settle_following_each(torques, &[(*q, pairs)], motor, follow, rank);
    (all.pop().unwrap_or_default(), spent)
}

/// [`settle_following`] for several starts at once, each `(q, pairs)` with its own `follow`
/// sets followed, all of a phase's settles in one parallel batch (the results are those of one
/// call per start: a settle does not depend on what runs beside it): per start its results,
/// and the settles spent in all.
pub fn settle_following_each(
    torques: &MagnetTorques,
    starts: &[(Orientation, &[Vec<Pair>])],
    motor: &Motor,
    follow: usize,
    rank: impl Fn(&Orientation) -> f64 + Sync,
) -> (Vec<Vec<SettleResult>>, usize) {
    let jobs: Vec<(usize, &Vec<Pair>)> = starts
        .iter()
        .enumerate()
        .flat_map(|(j, (_, pairs))| pairs.iter().map(move |p| (j, p)))
        .collect();
    let weigh = motor.weighing();
    let flat = settle_jobs(torques, &jobs, starts, motor, weigh);
    let mut results: Vec<Vec<SettleResult>> = starts.iter().map(|_| Vec::new()).collect();
    for ((j, _), r) in jobs.iter().zip(flat) {
        results[*j].push(r);
    }
    let mut again: Vec<(usize, &Vec<Pair>)> = Vec::new();
    let mut places: Vec<(usize, usize)> = Vec::new();
    for (j, rs) in results.iter().enumerate() {
        let mut unheld: Vec<(f64, usize)> = rs
            .iter()
            .enumerate()
            .filter(|(_, r)| r.stop == Stop::Unheld)
            .map(|(k, r)| (rank(&r.q), k))
            .collect();
        unheld.sort_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)));
        unheld.truncate(follow);
        for &(_, k) in &unheld {
            again.push((j, &starts[j].1[k]));
            places.push((j, k));
        }
    }
    let followed = settle_jobs(torques, &again, starts, motor, motor.settle);
    for ((j, k), r) in places.into_iter().zip(followed) {
        results[j][k] = r;
    }
    (results, jobs.len() + again.len())
}

/// Settles each job (a start's index and a set) from its start, in parallel.
fn settle_jobs(
    torques: &MagnetTorques,
    jobs: &[(usize, &Vec<Pair>)],
    starts: &[(Orientation, &[Vec<Pair>])],
    motor: &Motor,
    params: SettleParams,
) -> Vec<SettleResult> {
    jobs.par_iter()
        .map(|&(j, p)| settle(torques, p, &starts[j].0, motor.body, params))
        .collect()
}

/// The coils of an active set, sorted.
pub fn coils_of(active: &[Pair]) -> Vec<CoilId> {
    let mut c: Vec<CoilId> = active.iter().map(|p| p.coil).collect();
    c.sort();
    c.dedup();
    c
}

/// Each coil's nearest magnet at one orientation, looked for once per coil: the labels of the
/// many sets a state tries (the same pairs as [`label`] of each).
pub struct Labels<'a> {
    torques: &'a MagnetTorques,
    q: Orientation,
    nearest: Vec<std::cell::OnceCell<MagnetId>>,
}

impl<'a> Labels<'a> {
    /// The labels at `q`, none looked for yet.
    pub fn at(torques: &'a MagnetTorques, q: &Orientation) -> Self {
        Labels {
            torques,
            q: *q,
            nearest: vec![std::cell::OnceCell::new(); torques.stator.len()],
        }
    }

    /// Each of `coils` with the magnet nearest to it.
    pub fn label(&self, coils: &[CoilId]) -> Vec<Pair> {
        coils
            .iter()
            .map(|&coil| {
                let near = || nearest_magnet(self.torques, coil, &self.q).0;
                let magnet = match self.nearest.get(coil.0) {
                    Some(cell) => *cell.get_or_init(near),
                    None => near(),
                };
                Pair { coil, magnet }
            })
            .collect()
    }
}

/// Each coil with the magnet nearest to it at `q`.
pub fn label(torques: &MagnetTorques, coils: &[CoilId], q: &Orientation) -> Vec<Pair> {
    coils
        .iter()
        .map(|&coil| Pair {
            coil,
            magnet: nearest_magnet(torques, coil, q).0,
        })
        .collect()
}

/// The coils that pull some magnet at `q` (one within the maximum attraction distance), in
/// index order.
pub fn coils_in_reach(torques: &MagnetTorques, q: &Orientation) -> Vec<CoilId> {
    let r = q.to_rotation_matrix();
    let reach = torques.well.max_attraction().0;
    (0..torques.stator.len())
        .filter(|&i| {
            let s = UnitVec::new_normalize(torques.stator[i]);
            torques
                .rotor
                .iter()
                .any(|m| angular_distance(&UnitVec::new_normalize(r * m), &s).0 <= reach)
        })
        .map(CoilId)
        .collect()
}

/// The coil sets a step from the held coils may switch to: `per_step.min` to `per_step.max`
/// coils, some of the held ones kept and the others from `reach`, other than the held set, and
/// never more than `max_coils_on` coils on while the step switches (its new coils go on before
/// the released ones go off: make before break). Each set sorted; the list in a fixed order.
pub fn coil_sets(
    held: &[CoilId],
    reach: &[CoilId],
    per_step: PairsPerStep,
    max_coils_on: usize,
) -> Vec<Vec<CoilId>> {
    let fresh: Vec<CoilId> = reach
        .iter()
        .filter(|c| !held.contains(c))
        .copied()
        .collect();
    let room = max_coils_on.saturating_sub(held.len()).min(per_step.max);
    let mut out = Vec::new();
    for b in 0..=room {
        let picks: Vec<Vec<usize>> = if b == 0 {
            vec![Vec::new()]
        } else {
            combinations(fresh.len(), b)
        };
        for pick in picks {
            for mask in 0u32..(1 << held.len()) {
                let mut set: Vec<CoilId> = (0..held.len())
                    .filter(|k| mask & (1 << k) != 0)
                    .map(|k| held[k])
                    .collect();
                if b == 0 && set.len() == held.len() {
                    continue; // the held set itself
                }
                set.extend(pick.iter().map(|&k| fresh[k]));
                if (per_step.min..=per_step.max).contains(&set.len()) {
                    set.sort();
                    out.push(set);
                }
            }
        }
    }
    out.sort();
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn labels_of_many_sets_are_those_of_label_one_set_at_a_time() {
        use crate::model::geometry::rot_q;
        let torques = crate::io::scenario::Scenario::prototype().torques;
        let n = torques.stator.len();
        let axis = UnitVec::new_normalize(nalgebra::Vector3::new(0.3, -0.5, 0.8));
        for deg in [0.0, 17.0, 61.0, 143.0] {
            let q = rot_q(&axis, Radians(f64::to_radians(deg)));
            let labels = Labels::at(&torques, &q);
            for set in combinations(n, 2).into_iter().chain(combinations(n, 3)) {
                let set: Vec<CoilId> = set.into_iter().map(CoilId).collect();
                assert_eq!(
                    labels.label(&set),
                    label(&torques, &set, &q),
                    "{set:?} at {deg}"
                );
            }
        }
    }

    #[test]
    fn coil_sets_keep_to_the_supply_and_leave_the_held_set() {
        let held = [CoilId(0), CoilId(3)];
        let reach: Vec<CoilId> = (0..6).map(CoilId).collect();
        let sets = coil_sets(&held, &reach, PairsPerStep::up_to(4), 4);
        assert!(!sets.contains(&held.to_vec()));
        for s in &sets {
            assert!((2..=4).contains(&s.len()), "{s:?}");
            let mut all: Vec<CoilId> = s.iter().chain(&held).copied().collect();
            all.sort();
            all.dedup();
            assert!(all.len() <= 4, "{s:?}");
        }
        // 4 fresh coils: 2 of them with 0..=2 held kept (6 x 4), one with one or both held
        // (4 x 3), none with a held one dropped (no: one coil alone is too few)
        assert_eq!(sets.len(), 6 * 4 + 4 * 3);
        // four coils on: only switching some off is left
        let full = [CoilId(0), CoilId(1), CoilId(2), CoilId(3)];
        let sets = coil_sets(&full, &reach, PairsPerStep::up_to(4), 4);
        assert_eq!(sets.len(), 6 + 4);
        assert!(sets.iter().all(|s| s.iter().all(|c| full.contains(c))));
    }
}
