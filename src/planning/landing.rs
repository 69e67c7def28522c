//! The pair models' landing: which switches may take the ball from where a plan ends to the
//! goal orientation. Two kinds of proposal, both settled by the search's landing
//! (`search::land`, through `StepSource::expand_towards`):
//! - the switches to the sets that hold the ball nearest the goal (its *final sets*, found once
//!   per goal by settling the sets the cheap prediction ranks best from the goal itself), and
//!   the releases that make room in the supply for one;
//! - every switch the supply allows among the pairs in reach of the goal, ranked by how near
//!   the goal the cheap prediction leaves the ball.
//!
//! A landing step holds the ball when every pair's magnet ends within its coil's reach (the
//! well's maximum attraction distance), the settle's own finding of a held equilibrium: the
//! turn's steps keep the stricter capture distance (robust steps along the way), the landing
//! only needs the ball to stay where the physics settles it.

use crate::model::geometry::{CoilId, MagnetId, Orientation, Pair, Radians, SurelyBeyond};
use crate::physics::torque::MagnetTorques;
use crate::planning::commutation::{
    fits_supply, holds, pair_gap, predicted_in_wells, predicted_orientation, settled_states,
    FirstWeighing, Motor, PIVOT_CAPTURE,
};
use crate::planning::plan::PlanSettings;
use crate::planning::search::sorted;
use nalgebra::Vector3;
use rayon::prelude::*;
use std::ops::Range;
use std::sync::{Mutex, PoisonError};

/// A landing weighs the pairs whose magnets lie within the capture distance and this (3
/// degrees) of their coils at the goal: a set settles near the goal, not on it, and its pairs
/// hold there.
const LANDING_MARGIN: Radians = Radians(3.0 * std::f64::consts::PI / 180.0);

/// The final sets are drawn from the pairs whose magnets lie within the capture distance and
/// this (8 degrees) of their coils at the goal: the sets that hold the ball nearest a goal
/// often have a magnet on the well's shoulder.
const FINAL_MARGIN: Radians = Radians(8.0 * std::f64::consts::PI / 180.0);

/// How many sets of pairs in reach of a goal, the nearest to it by the cheap prediction, are
/// settled from the goal to find its final sets (once per goal).
const FINAL_CANDIDATES: usize = 48;

/// How many sets the first, one-solve ranking of a goal's sets keeps for the finer one.
const FINAL_SHORTLIST: usize = 512;

/// How many times the finer ranking weighs the wells again at its prediction.
const WELL_ITERATIONS: usize = 4;

/// How many final sets a landing aims at: the nearest the goal of those that hold the ball.
const FINAL_AIMS: usize = 8;

/// A landing step's set: the pairs it keeps on of those on before it, and the pairs it
/// switches on.
pub(crate) type LandingSet = (Vec<Pair>, Vec<Pair>);

/// The final sets of each goal a plan's landing has aimed at, found once per goal and kept
/// for the plan's other landings (the narrow and the wide one, every plan carried on).
#[derive(Debug, Default)]
pub(crate) struct Finals {
    found: Mutex<Vec<(Orientation, Vec<Vec<Pair>>)>>,
}

impl Finals {
    /// The final sets of `goal` ([`final_sets`]), nearest first, and the settles spent finding
    /// them (0 when they were known).
    pub(crate) fn of(
        &self,
        motor: &Motor,
        s: &PlanSettings,
        goal: &Orientation,
    ) -> (usize, Vec<Vec<Pair>>) {
        // a panic elsewhere cannot leave the list half written: entries are pushed whole
        let mut found = self.found.lock().unwrap_or_else(PoisonError::into_inner);
        if let Some((_, f)) = found.iter().find(|(g, _)| g.angle_to(goal) < 1e-12) {
            return (0, f.clone());
        }
        let (spent, f) = final_sets(motor, s, goal);
        found.push((*goal, f.clone()));
        (spent, f)
    }
}

/// The pairs whose magnets lie within `capture` of their coils at `q`, none on a coil of
/// `avoid`, in coil then magnet order.
fn pairs_near(t: &MagnetTorques, q: &Orientation, capture: Radians, avoid: &[CoilId]) -> Vec<Pair> {
    let r = q.to_rotation_matrix();
    let world: Vec<Vector3<f64>> = t.rotor.iter().map(|m| r * m).collect();
    let far = SurelyBeyond::new(capture);
    (0..t.stator.len())
        .filter(|&c| !avoid.contains(&CoilId(c)))
        .flat_map(|c| (0..t.rotor.len()).map(move |m| (c, m)))
        .filter(|&(c, m)| !far.apart(&world[m], &t.stator[c]))
        .map(|(c, m)| Pair {
            coil: CoilId(c),
            magnet: MagnetId(m),
        })
        .filter(|p| pair_gap(t, &r, *p).0 <= capture.0)
        .collect()
}

/// How far from their coils at the goal a landing looks for pairs: the capture distance and
/// [`LANDING_MARGIN`].
fn landing_reach(s: &PlanSettings) -> Radians {
    Radians(s.limits.capture.unwrap_or(PIVOT_CAPTURE).0 + LANDING_MARGIN.0)
}

/// A goal's final sets and the settles spent: every set of `pairs.min` to `pairs.max` pairs in
/// reach of the goal ([`landing_reach`], distinct coils), ranked by how near the goal the cheap
/// prediction leaves the ball; the [`FINAL_CANDIDATES`] best settled from the goal; of those
/// that settle holding the ball (every magnet within its coil's reach), the [`FINAL_AIMS`]
/// nearest the goal, nearest first.
fn final_sets(motor: &Motor, s: &PlanSettings, goal: &Orientation) -> (usize, Vec<Vec<Pair>>) {
    let t = &motor.torques;
    let reach = Radians(s.limits.capture.unwrap_or(PIVOT_CAPTURE).0 + FINAL_MARGIN.0);
    let near = pairs_near(t, goal, reach, &[]);
    let most = s.pairs.max.min(s.limits.max_coils_on);
    // every set as indices into `near` (increasing, so in the order of its pairs), in one
    // buffer: `spans` says where each lies in `flat`
    let (mut flat, mut spans) = (Vec::new(), Vec::new());
    each_combination(&near, most, &mut Vec::new(), 0, &mut |set| {
        if set.len() >= s.pairs.min {
            spans.push(flat.len()..flat.len() + set.len());
            flat.extend_from_slice(set);
        }
        true
    });
    // ranked in two passes (the wells weighed at the goal, each pair once for every set,
    // then the best again until the prediction settles), in parallel, in order: the same on
    // any number of threads. `near` is in pair order and a set's indices increase, so the
    // indices order the sets as their pairs do.
    let first = FirstWeighing::new(t, goal, &near);
    let shortlist = best_ranked(
        spans,
        (goal, FINAL_SHORTLIST),
        |span| first.predicted(&flat[span.clone()]),
        |a, b| flat[a.clone()].cmp(&flat[b.clone()]),
    );
    let sets: Vec<Vec<Pair>> = (shortlist.into_iter())
        .map(|(_, span)| flat[span].iter().map(|&i| near[i]).collect())
        .collect();
    let sets = best_ranked(
        sets,
        (goal, FINAL_CANDIDATES),
        |set| predicted_in_wells(t, goal, set, goal, WELL_ITERATIONS),
        |a, b| a.cmp(b),
    )
    .into_iter()
    .map(|(_, set)| set)
    .collect::<Vec<_>>();
    let spent = sets.len();
    let reach = t.well.max_attraction();
    let mut held: Vec<(f64, Vec<Pair>)> = settled_states(motor, sets, goal)
        .into_iter()
        .flatten()
        .filter(|st| holds(t, st, reach))
        .map(|st| (st.q.angle_to(goal), st.active))
        .collect();
    held.sort_by(|a, b| a.0.total_cmp(&b.0).then_with(|| a.1.cmp(&b.1)));
    let finals = held
        .into_iter()
        .take(FINAL_AIMS)
        .map(|(_, set)| set)
        .collect();
    (spent, finals)
}

/// The `keep` sets of `sets` whose prediction `predict` (from the goal) leaves the ball
/// nearest the goal, nearest first (ties by `tie`), with that distance: a partial selection
/// and a sort of the kept, the order a sort of all of them gives (the order is total, the sets
/// distinct). Predicted in parallel, in order: the same on any number of threads.
fn best_ranked<S: Send>(
    sets: Vec<S>,
    (goal, keep): (&Orientation, usize),
    predict: impl Fn(&S) -> Orientation + Sync,
    tie: impl Fn(&S, &S) -> std::cmp::Ordering,
) -> Vec<(f64, S)> {
    let mut ranked: Vec<(f64, S)> = sets
        .into_par_iter()
        .map(|set| (predict(&set).angle_to(goal), set))
        .collect();
    let order = |a: &(f64, S), b: &(f64, S)| a.0.total_cmp(&b.0).then_with(|| tie(&a.1, &b.1));
    if keep == 0 {
        return Vec::new();
    }
    if ranked.len() > keep {
        ranked.select_nth_unstable_by(keep - 1, order);
        ranked.truncate(keep);
    }
    ranked.sort_by(order);
    ranked
}

/// How many switches towards each final set a landing weighs (see [`aimed_at`]).
const PER_AIM: usize = 2;

/// The switches towards the final sets `finals` from the pairs `on` (the ball at `q`): a
/// final set the supply lets on at once (make before break, [`fits_supply`]) is switched to
/// directly (the pairs it shares with `on` kept, its others switched on); else the ball goes
/// there in a few steps, each keeping some of the pairs on and switching on what of the final
/// set the supply allows. For each final set, of the switches between `pairs.min` and
/// `pairs.max` pairs, the [`PER_AIM`] that make the most progress (the final set's pairs in the
/// new set, less the others kept), the nearest the goal by the cheap prediction on a tie. None
/// with a coil of `avoid`; each once, in the order of `finals`.
fn aimed_at(
    t: &MagnetTorques,
    s: &PlanSettings,
    (on, q): (&[Pair], &Orientation),
    goal: &Orientation,
    finals: &[Vec<Pair>],
    avoid: &[CoilId],
) -> Vec<LandingSet> {
    let mut out: Vec<LandingSet> = Vec::new();
    let key = landing_key;
    let now = sorted(on);
    let usable: Vec<Pair> = on
        .iter()
        .copied()
        .filter(|p| !avoid.contains(&p.coil))
        .collect();
    for f in finals {
        if sorted(f) == now {
            continue;
        }
        // a tired coil goes off first (its on-time starts again when it comes back on)
        let fresh: Vec<Pair> = f
            .iter()
            .filter(|p| !on.contains(p) && !avoid.contains(&p.coil))
            .copied()
            .collect();
        // (progress, the switch) of every switch towards f
        let mut towards: Vec<(i64, LandingSet)> = Vec::new();
        for kmask in 0..(1usize << usable.len()) {
            let kept: Vec<Pair> = subset(&usable, kmask);
            for nmask in 0..(1usize << fresh.len()) {
                let new: Vec<Pair> = subset(&fresh, nmask);
                let n = kept.len() + new.len();
                if n < s.pairs.min || n > s.pairs.max {
                    continue;
                }
                if new.is_empty() && kept.len() == on.len() {
                    continue; // no switch at all
                }
                if !fits_supply(on, &new, s.limits.max_coils_on) {
                    continue;
                }
                let shared = kept.iter().chain(&new).filter(|p| f.contains(p)).count();
                let others = kept.iter().filter(|p| !f.contains(p)).count();
                towards.push((shared as i64 - others as i64, (kept.clone(), new)));
            }
        }
        let Some(best) = towards.iter().map(|(g, _)| *g).max() else {
            continue;
        };
        // predicted in parallel, in order: the same on any number of threads
        let mut top: Vec<(f64, LandingSet)> = towards
            .into_par_iter()
            .filter(|(g, _)| *g == best)
            .map(|(_, l)| {
                let set: Vec<Pair> = l.0.iter().chain(&l.1).copied().collect();
                (
                    predicted_in_wells(t, q, &set, goal, WELL_ITERATIONS).angle_to(goal),
                    l,
                )
            })
            .collect();
        top.sort_by(|a, b| a.0.total_cmp(&b.0).then_with(|| key(&a.1).cmp(&key(&b.1))));
        for (_, l) in top.into_iter().take(PER_AIM) {
            if !out.iter().any(|o| key(o) == key(&l)) {
                out.push(l);
            }
        }
    }
    out
}

/// A landing set as it is compared: its kept and its new pairs, each sorted.
fn landing_key(l: &LandingSet) -> (Vec<Pair>, Vec<Pair>) {
    (sorted(&l.0), sorted(&l.1))
}

/// The pairs of `pairs` whose bits are set in `mask`, in order.
fn masked(pairs: &[Pair], mask: usize) -> impl Iterator<Item = &Pair> {
    (pairs.iter().enumerate())
        .filter(move |(i, _)| mask >> i & 1 == 1)
        .map(|(_, p)| p)
}

/// [`masked`], collected.
fn subset(pairs: &[Pair], mask: usize) -> Vec<Pair> {
    masked(pairs, mask).copied().collect()
}

/// The sets a landing weighs from `on` (the pairs on, the ball at `q`) towards `goal`, as (the
/// pairs kept on, the pairs switched on): first those aimed at the goal's final sets
/// ([`aimed_at`]); then any of the pairs on kept (none, some or all), with pairs whose magnets
/// lie within [`landing_reach`] of their coils at the goal switched on, or none (a release:
/// some of the pairs on switched off, which lets a full supply take a new coil at the next
/// step); between `pairs.min` and `pairs.max` pairs in all, within the supply (the coils on and
/// the new ones together, make before break: [`fits_supply`]) and none of `avoid`'s coils kept
/// or switched on; ranked by how near the goal their cheap prediction
/// ([`predicted_orientation`]) leaves the ball, the `settles_per_state` nearest not aimed at
/// already.
pub(crate) fn landing_proposals(
    motor: &Motor,
    s: &PlanSettings,
    (on, q): (&[Pair], &Orientation),
    goal: &Orientation,
    finals: &[Vec<Pair>],
    avoid: &[CoilId],
) -> Vec<LandingSet> {
    let t = &motor.torques;
    let near_goal = pairs_near(t, goal, landing_reach(s), avoid);
    let aimed = aimed_at(t, s, (on, q), goal, finals, avoid);
    let (flat, sets) = switches(on, &near_goal, s, avoid);
    // predicted in parallel, in order: the same on any number of threads
    let mut ranked: Vec<(f64, (usize, Range<usize>))> = sets
        .into_par_iter()
        .map_init(Vec::new, |set: &mut Vec<Pair>, (mask, span)| {
            set.clear();
            set.extend(masked(on, mask).copied());
            set.extend_from_slice(&flat[span.clone()]);
            let qp = predicted_orientation(t, q, set);
            (qp.angle_to(goal), (mask, span))
        })
        .collect();
    // nearest first, ties in the order of (kept, new) as lists of pairs; of those the aimed
    // ones are not weighed again
    let order = |a: &(f64, (usize, Range<usize>)), b: &(f64, (usize, Range<usize>))| {
        a.0.total_cmp(&b.0).then_with(|| {
            let ((ma, sa), (mb, sb)) = (&a.1, &b.1);
            (masked(on, *ma).cmp(masked(on, *mb)))
                .then_with(|| flat[sa.clone()].cmp(&flat[sb.clone()]))
        })
    };
    let keep = s.settles_per_state + aimed.len();
    if keep == 0 {
        ranked.clear();
    } else if ranked.len() > keep {
        ranked.select_nth_unstable_by(keep - 1, order);
        ranked.truncate(keep);
    }
    ranked.sort_by(order);
    let taken: Vec<_> = aimed.iter().map(landing_key).collect();
    let rest: Vec<LandingSet> = ranked
        .into_iter()
        .map(|(_, (mask, span))| (subset(on, mask), flat[span].to_vec()))
        .filter(|p| !taken.contains(&landing_key(p)))
        .take(s.settles_per_state)
        .collect();
    aimed.into_iter().chain(rest).collect()
}

/// The switches [`landing_proposals`] weighs besides the aimed ones, in the enumeration's order:
/// each as the mask of the pairs of `on` it keeps and the span of the returned buffer its new
/// pairs (of `near_goal`) fill, so that no set is allocated before it is one of the best.
fn switches(
    on: &[Pair],
    near_goal: &[Pair],
    s: &PlanSettings,
    avoid: &[CoilId],
) -> (Vec<Pair>, Vec<(usize, Range<usize>)>) {
    let (mut flat, mut sets): (Vec<Pair>, Vec<(usize, Range<usize>)>) = (Vec::new(), Vec::new());
    // the supply test of `fits_supply(on, new, ..)` counted as the sets grow: the coils on, and
    // one more for each new pair on a coil not on (a set's new pairs are on distinct coils)
    let coils_on = (0..on.len())
        .filter(|&i| on[..i].iter().all(|p| p.coil != on[i].coil))
        .count();
    // every subset of the pairs on, as a bit mask, in a fixed order
    for mask in 0..(1usize << on.len()) {
        let kept = subset(on, mask);
        if kept.len() > s.pairs.max || kept.iter().any(|p| avoid.contains(&p.coil)) {
            continue;
        }
        if kept.len() >= s.pairs.min && kept.len() < on.len() {
            sets.push((mask, flat.len()..flat.len()));
        }
        if kept.len() == s.pairs.max {
            continue;
        }
        let others: Vec<Pair> = near_goal
            .iter()
            .copied()
            .filter(|p| kept.iter().all(|k| k.coil != p.coil))
            .collect();
        let adds: Vec<bool> = (others.iter())
            .map(|o| on.iter().all(|p| p.coil != o.coil))
            .collect();
        let least = s.pairs.min.saturating_sub(kept.len()).max(1);
        // more pairs switch on at least as many coils: a set the supply cannot take has no
        // extension it can, so its branch ends there (the sets weighed and their order are
        // those of the whole enumeration with the test on each)
        each_combination(
            &others,
            s.pairs.max - kept.len(),
            &mut Vec::new(),
            0,
            &mut |idx| {
                let coils = coils_on + idx.iter().filter(|&&i| adds[i]).count();
                if coils > s.limits.max_coils_on {
                    return false;
                }
                if idx.len() >= least {
                    sets.push((mask, flat.len()..flat.len() + idx.len()));
                    flat.extend(idx.iter().map(|&i| others[i]));
                }
                true
            },
        );
    }
    (flat, sets)
}

/// Visits each set of up to `most` of `pairs` with distinct coils, as the indices of its pairs
/// (increasing), in a deterministic order (depth first, each set before its extensions, the
/// later pairs' branches first), growing `set` from `from` on: one buffer, no set allocated
/// that `visit` does not keep. A set's extensions are visited only when `visit` returns true
/// for it.
fn each_combination(
    pairs: &[Pair],
    most: usize,
    set: &mut Vec<usize>,
    from: usize,
    visit: &mut impl FnMut(&[usize]) -> bool,
) {
    if !visit(set) || set.len() >= most {
        return;
    }
    for (i, p) in pairs.iter().enumerate().skip(from).rev() {
        if set.iter().all(|&j| pairs[j].coil != p.coil) {
            set.push(i);
            each_combination(pairs, most, set, i + 1, visit);
            set.pop();
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::io::scenario::Scenario;
    use crate::planning::commutation::PairsPerStep;

    fn pair(coil: usize, magnet: usize) -> Pair {
        Pair {
            coil: CoilId(coil),
            magnet: MagnetId(magnet),
        }
    }

    fn settings() -> PlanSettings {
        let mut s = Scenario::prototype().plan;
        s.pairs = PairsPerStep { min: 2, max: 4 };
        s.limits.max_coils_on = 4;
        s
    }

    #[test]
    fn the_switches_counted_as_they_grow_are_every_switch_the_supply_takes_in_order() {
        let sc = Scenario::prototype();
        let t = &sc.torques;
        let goal = crate::model::geometry::rot_q(
            &crate::model::geometry::unit(nalgebra::Vector3::new(0.3, -0.5, 0.8)).unwrap(),
            Radians(0.7),
        );
        let near_goal = pairs_near(t, &goal, Radians(0.45), &[]);
        assert!(near_goal.len() > 8, "{}", near_goal.len());
        // two pairs on one coil, a pair on a coil near the goal; supplies of 3 to 5 coils
        let on = [pair(0, 1), pair(0, 2), near_goal[3], pair(15, 70)];
        for most in 3..=5 {
            let mut s = settings();
            s.limits.max_coils_on = most;
            let (flat, sets) = switches(&on, &near_goal, &s, &[CoilId(15)]);
            // the whole enumeration, each set tested by fits_supply
            let mut all: Vec<LandingSet> = Vec::new();
            for mask in 0..(1usize << on.len()) {
                let kept = subset(&on, mask);
                if kept.len() > s.pairs.max || kept.iter().any(|p| p.coil == CoilId(15)) {
                    continue;
                }
                if kept.len() >= s.pairs.min && kept.len() < on.len() {
                    all.push((kept.clone(), Vec::new()));
                }
                if kept.len() == s.pairs.max {
                    continue;
                }
                let others: Vec<Pair> = (near_goal.iter().copied())
                    .filter(|p| kept.iter().all(|k| k.coil != p.coil))
                    .collect();
                let least = s.pairs.min.saturating_sub(kept.len()).max(1);
                each_combination(
                    &others,
                    s.pairs.max - kept.len(),
                    &mut Vec::new(),
                    0,
                    &mut |idx| {
                        let new: Vec<Pair> = idx.iter().map(|&i| others[i]).collect();
                        if idx.len() >= least && fits_supply(&on, &new, most) {
                            all.push((kept.clone(), new));
                        }
                        true
                    },
                );
            }
            let counted: Vec<LandingSet> = (sets.iter())
                .map(|(mask, span)| (subset(&on, *mask), flat[span.clone()].to_vec()))
                .collect();
            assert!(!counted.is_empty());
            assert_eq!(counted, all, "{most} coils");
        }
    }

    #[test]
    fn a_full_supply_releases_towards_a_final_set_then_switches_to_it() {
        let (sc, s) = (Scenario::prototype(), settings());
        let t = &sc.torques;
        let q = Orientation::identity();
        let on = [pair(0, 1), pair(1, 2), pair(2, 3), pair(3, 4)];
        // shares two pairs with what is on: two more coils do not fit beside four
        let f = vec![pair(0, 1), pair(1, 2), pair(4, 5), pair(5, 6)];
        let aims = aimed_at(t, &s, (&on, &q), &q, std::slice::from_ref(&f), &[]);
        assert_eq!(aims, vec![(vec![pair(0, 1), pair(1, 2)], vec![])]);
        // from the release, the final set at once (four coils while switching)
        let released = [pair(0, 1), pair(1, 2)];
        let aims = aimed_at(t, &s, (&released, &q), &q, std::slice::from_ref(&f), &[]);
        assert_eq!(
            aims,
            vec![(released.to_vec(), vec![pair(4, 5), pair(5, 6)])]
        );
        // a tired coil is switched off on the way, not kept and not switched on again
        let aims = aimed_at(t, &s, (&released, &q), &q, &[f], &[CoilId(0)]);
        assert!(!aims.is_empty());
        assert!(aims
            .iter()
            .all(|(kept, new)| kept.iter().chain(new).all(|p| p.coil != CoilId(0))));
        // no switch at all is no proposal
        let here = on.to_vec();
        assert!(aimed_at(t, &s, (&on, &q), &q, &[here], &[]).is_empty());
    }

    #[test]
    fn the_final_sets_hold_the_ball_nearer_the_goal_than_the_sets_the_springs_rank_best() {
        let sc = Scenario::prototype();
        let (motor, s) = (sc.motor(), settings());
        let goal = crate::model::geometry::rot_q(
            &crate::model::geometry::unit(nalgebra::Vector3::new(0.3, -0.5, 0.8)).unwrap(),
            Radians(0.7),
        );
        let finals = Finals::default();
        let (spent, sets) = finals.of(&motor, &s, &goal);
        assert_eq!(spent, FINAL_CANDIDATES);
        assert!(!sets.is_empty() && sets.len() <= FINAL_AIMS);
        // found once per goal
        assert_eq!(finals.of(&motor, &s, &goal), (0, sets.clone()));
        let reach = motor.torques.well.max_attraction();
        let end = |set: &Vec<Pair>| {
            let st = settled_states(&motor, vec![set.clone()], &goal)
                .pop()
                .flatten()
                .unwrap();
            assert!(holds(&motor.torques, &st, reach));
            st.q.angle_to(&goal)
        };
        let nearest: Vec<f64> = sets.iter().map(end).collect();
        assert!(nearest.windows(2).all(|w| w[0] <= w[1]), "{nearest:?}");
        // the same number of sets ranked by the unweighted springs hold it further out
        let near = pairs_near(&motor.torques, &goal, landing_reach(&s), &[]);
        let mut springs: Vec<(f64, Vec<Pair>)> = Vec::new();
        each_combination(&near, 4, &mut Vec::new(), 0, &mut |idx| {
            if idx.len() >= 2 {
                let set: Vec<Pair> = idx.iter().map(|&i| near[i]).collect();
                let qp = predicted_orientation(&motor.torques, &goal, &set);
                springs.push((qp.angle_to(&goal), set));
            }
            true
        });
        springs.sort_by(|a, b| a.0.total_cmp(&b.0).then_with(|| a.1.cmp(&b.1)));
        let by_springs = springs
            .into_iter()
            .take(FINAL_CANDIDATES)
            .map(|(_, set)| set)
            .collect::<Vec<_>>();
        let best_by_springs = settled_states(&motor, by_springs, &goal)
            .into_iter()
            .flatten()
            .filter(|st| holds(&motor.torques, st, reach))
            .map(|st| st.q.angle_to(&goal))
            .fold(f64::INFINITY, f64::min);
        assert!(
            nearest[0] <= best_by_springs,
            "{nearest:?} {best_by_springs}"
        );
        assert!(nearest[0].to_degrees() < 1.0, "{nearest:?}");
    }
}
