//! Motion planning (paper section 3.2 and 4.1): sequences of commutation steps that turn the
//! ball by a target angle about a desired axis. A consumer of settled equilibria: it chooses
//! among the steps that `commutation` (pairs) and `coilsets` (coil sets) predict and never
//! integrates anything itself. `plan` picks the step source of the settings' model: the pair
//! models here, coil sets in `coilsets`, both searched by `search` (the paper's three greedy
//! schemes, a beam search and a best-first branch and bound). The settings and the plan are in
//! `plan` (re-exported here).

use crate::model::geometry::{
    rotation_axis, CoilId, MagnetId, Orientation, Pair, Radians, UnitVec,
};
use crate::physics::dynamics::settle;
use crate::physics::torque::MagnetTorques;
use crate::planning::coilsets::CoilSets;
use crate::planning::commutation::{
    admissible, candidate_steps, evaluate_proposals, fits_supply, initial_states, pair_gap,
    predicted_orientation, proposals_within, settled_states, CommutationState, Motor, Proposal,
    Step, StepLimits, StepModel, PIVOT_CAPTURE,
};
use crate::planning::landing::{landing_proposals, Finals};
use crate::planning::on_time::OnTimes;
use crate::planning::plan::PlanRow;
use crate::planning::search::{
    self, predicted_rank, sorted, weighed, wide_limits, Frontier, StepSource,
};
use rayon::prelude::*;

pub use crate::planning::plan::{
    max_axis_error_deg, target_angle, total_settle_time, Plan, PlanSettings, PlanSummary, Scheme,
    DEFAULT_SETTLES_PER_STATE, DEFAULT_SETTLE_BUDGET, DEFAULT_STALL_SETTLES, MAX_TARGET_DEG,
};

/// Plans a motion, with the settings' step model. With a target orientation
/// ([`PlanSettings::target`]) the motion is planned twice: as asked (the turn from the start),
/// and again from where the first plan's initial commutation leaves the ball, aimed at the
/// target from there (`replanned_from_row0`); the plan kept is the one that reaches the
/// target, of two that do the one that strays less from the straight way (its worst path
/// deviation), of two that do not the one that ends nearer (the first on a tie), with the
/// settles of both.
pub fn plan(motor: &Motor, s: &PlanSettings) -> Plan {
    let p = plan_with(motor, s, None);
    let Some(goal) = s.target else {
        return p;
    };
    let Some(again) = replanned_from_row0(motor, s, &p, &goal) else {
        return p;
    };
    let settles = p.settles + again.settles;
    let end = |p: &Plan| p.rows.last().map_or(f64::INFINITY, |r| r.q.angle_to(&goal));
    let strays = |p: &Plan| crate::planning::plan::max_path_deviation_deg(s, &p.rows);
    let better = match (again.reached, p.reached) {
        (a, b) if a != b => a,
        (true, true) => strays(&again) < strays(&p) - 1e-9,
        _ => end(&again) < end(&p) - 1e-12,
    };
    let mut kept = if better { again } else { p };
    kept.settles = settles;
    kept
}

/// `p` (a plan made for `s` from `s.start`) planned again from its row 0 (the initial
/// commutation's state, its coils on for row 0's dwell), aimed at `goal` from there: the
/// initial commutation moves the ball before the first step, so the turn from `s.start`
/// misses `goal` by as much. `None` when `p` has no rows or row 0 is at `goal` already.
pub(crate) fn replanned_from_row0(
    motor: &Motor,
    s: &PlanSettings,
    p: &Plan,
    goal: &Orientation,
) -> Option<Plan> {
    let row0 = p.rows.first()?;
    let (axis, angle) = crate::planning::plan::turn_to(&row0.q, goal, "row 0").ok()?;
    let aimed = PlanSettings {
        axis,
        angle,
        start: row0.q,
        ..s.clone()
    };
    let on = search::on_times_of(&p.rows[..1], s.limits.on_time, None);
    Some(plan_on_from(motor, &aimed, row0.state(), on))
}

/// Plans the motion from a given commutation state (the ball where it is, held by what is on:
/// a measured orientation in closed loop) instead of the initial states the model finds from
/// `s.start`; the plan's row 0 is that state.
pub fn plan_from(motor: &Motor, s: &PlanSettings, state: CommutationState) -> Plan {
    plan_with(motor, s, Some((state, None)))
}

/// [`plan_from`] a state whose coils are still on from the motion before (a motion that goes on
/// where another left off): `held` says how long each has been on (the dwell of the row that
/// left it included), and the plan keeps every coil within the on-time limit counting from
/// there.
pub fn plan_on_from(
    motor: &Motor,
    s: &PlanSettings,
    state: CommutationState,
    held: OnTimes<CoilId>,
) -> Plan {
    plan_with(motor, s, Some((state, Some(held))))
}

fn plan_with(
    motor: &Motor,
    s: &PlanSettings,
    from: Option<(CommutationState, Option<OnTimes<CoilId>>)>,
) -> Plan {
    // The capture in force, resolved once (the dynamic model's is a search over its well's
    // pull), not in every evaluation of a step.
    let capture = s.limits.capture_for(s.model, &motor.torques.well);
    let resolved = PlanSettings {
        limits: StepLimits {
            capture: Some(capture),
            ..s.limits
        },
        ..s.clone()
    };
    let s = &resolved;
    let run = |src: &dyn StepSource| match &from {
        Some((state, held)) => search::run(
            &FromState {
                inner: src,
                state: state.clone(),
                held: held.clone(),
            },
            s,
        ),
        None => search::run(src, s),
    };
    let p = match s.model {
        StepModel::Coils => run(&CoilSets::new(motor, s)),
        StepModel::Dynamic => run(&PairSteps::new(motor, s)),
        StepModel::Pivot => {
            let mut p = run(&PairSteps::new(motor, s));
            predict_settle_times(motor, &mut p.rows, &s.start);
            // the search counted the dwell floor only: the settle times are known now
            if let Some(why) = search::over_on_time(&p.rows, s.limits.on_time) {
                let before = p
                    .message
                    .take()
                    .map(|m| format!("{m}; "))
                    .unwrap_or_default();
                p.message = Some(format!("{before}{why}"));
            }
            p
        }
    };
    crate::planning::plan::judged(p, s)
}

/// A step source that starts from one given state (its coils on for `held`, when given).
struct FromState<'a> {
    inner: &'a dyn StepSource,
    state: CommutationState,
    held: Option<OnTimes<CoilId>>,
}

impl StepSource for FromState<'_> {
    fn initial_states(&self) -> Vec<CommutationState> {
        vec![self.state.clone()]
    }

    fn no_initial_state(&self) -> String {
        self.inner.no_initial_state()
    }

    fn steps(&self, state: &CommutationState, wide: bool) -> Vec<Step> {
        self.inner.steps(state, wide)
    }

    fn expand(&self, at: &Frontier) -> (usize, Vec<Step>) {
        self.inner.expand(at)
    }

    fn expand_towards(&self, at: &Frontier, goal: &Orientation) -> (usize, Vec<Step>) {
        self.inner.expand_towards(at, goal)
    }

    fn key(&self, state: &CommutationState) -> Vec<crate::model::geometry::Pair> {
        self.inner.key(state)
    }

    fn bridges(
        &self,
        from: &CommutationState,
        next: &PlanRow,
        aim: &Orientation,
    ) -> (usize, Vec<Step>) {
        self.inner.bridges(from, next, aim)
    }

    fn step_to(&self, from: &CommutationState, row: &PlanRow) -> Option<Step> {
        self.inner.step_to(from, row)
    }

    fn initial_on_times(&self) -> Option<OnTimes<CoilId>> {
        self.held.clone()
    }
}

/// The settle time of each step of a geometric (pivot) plan, which its model does not predict:
/// the dynamics' settle of the step's active set from the orientation the plan predicts before
/// it (`start` for step 0), all steps in parallel, and whether it settles (a step that does not
/// has t_max). `replay` waits this long (times its factor).
fn predict_settle_times(motor: &Motor, rows: &mut [PlanRow], start: &Orientation) {
    if motor.cancel.is_cancelled() {
        return;
    }
    let froms: Vec<Orientation> = std::iter::once(*start)
        .chain(rows.iter().map(|r| r.q))
        .take(rows.len())
        .collect();
    let times: Vec<(f64, bool)> = rows
        .par_iter()
        .zip(&froms)
        .map(|(r, from)| settle(&motor.torques, &r.active, from, motor.body, motor.settle))
        .map(|res| (res.arrival_time_s, res.settled))
        .collect();
    for (r, (t, settled)) in rows.iter_mut().zip(times) {
        r.settle_time_s = t;
        r.settled = settled;
    }
}

/// The pair models (pivot and dynamic) as a step source: each step keeps one held pair and
/// switches on new ones that pass the paper's filter.
struct PairSteps<'a> {
    motor: &'a Motor,
    /// The settings, with the capture resolved.
    s: &'a PlanSettings,
    /// The final sets the landing aims at, per goal.
    finals: Finals,
}

impl<'a> PairSteps<'a> {
    fn new(motor: &'a Motor, s: &'a PlanSettings) -> Self {
        PairSteps {
            motor,
            s,
            finals: Finals::default(),
        }
    }
}

impl StepSource for PairSteps<'_> {
    fn initial_states(&self) -> Vec<CommutationState> {
        let s = self.s;
        let capture = s.limits.capture.unwrap_or(PIVOT_CAPTURE);
        initial_states(self.motor, &s.start, s.model, &s.axis, capture)
    }

    fn no_initial_state(&self) -> String {
        "no initial commutation state: no second pair within the maximum attraction \
         distance of the start orientation settles with both pairs holding (each magnet \
         within the capture distance of its coil)"
            .into()
    }

    fn steps(&self, state: &CommutationState, wide: bool) -> Vec<Step> {
        let s = self.s;
        let limits = if wide {
            wide_limits(&s.limits)
        } else {
            s.limits
        };
        candidate_steps(self.motor, state, &s.axis, s.model, s.pairs, &limits)
    }

    fn expand(&self, at: &Frontier) -> (usize, Vec<Step>) {
        let s = self.s;
        let proposals = ranked_proposals(self.motor, s, at);
        let spent = proposals.len();
        let steps = evaluate_proposals(
            self.motor,
            at.state,
            &s.axis,
            StepModel::Dynamic,
            proposals,
            &s.limits,
        );
        (spent, steps)
    }

    fn step_to(&self, from: &CommutationState, row: &PlanRow) -> Option<Step> {
        let s = self.s;
        let held = |p: &Pair| from.active.contains(p);
        let new: Vec<Pair> = row.active.iter().filter(|p| !held(p)).copied().collect();
        if s.model != StepModel::Dynamic || !fits_supply(&from.active, &new, s.limits.max_coils_on)
        {
            return None;
        }
        // a row replayed after the same set keeps its pivot and new pairs
        let (pivot, new) = match row.pivot.filter(held) {
            Some(p) if row.new.iter().all(|n| !held(n)) => (Some(p), row.new.clone()),
            _ => (row.active.iter().copied().find(held), new),
        };
        let switch = Switch {
            set: row.active.clone(),
            pivot,
            new,
        };
        // held as the landing's steps are (every magnet within its coil's reach)
        let capture = self.motor.torques.well.max_attraction();
        held_steps(
            self.motor,
            &from.q,
            vec![switch],
            &s.axis,
            &s.limits,
            capture,
        )
        .pop()
    }

    fn bridges(
        &self,
        from: &CommutationState,
        next: &PlanRow,
        aim: &Orientation,
    ) -> (usize, Vec<Step>) {
        let s = self.s;
        if s.model != StepModel::Dynamic {
            return (0, Vec::new());
        }
        let t = &self.motor.torques;
        let capture = s.limits.capture_for(s.model, &t.well);
        let held = |p: &&Pair| from.active.contains(p);
        let switches: Vec<Switch> = bridge_sets(t, from, next, aim, capture, s)
            .into_iter()
            .map(|set| Switch {
                pivot: set.iter().find(held).copied(),
                new: set.iter().filter(|p| !held(p)).copied().collect(),
                set,
            })
            .collect();
        let spent = switches.len();
        let steps = held_steps(self.motor, &from.q, switches, &s.axis, &s.limits, capture);
        (spent, steps)
    }

    fn expand_towards(&self, at: &Frontier, goal: &Orientation) -> (usize, Vec<Step>) {
        let s = self.s;
        let Some(towards) = rotation_axis(&(goal * at.state.q.inverse())) else {
            return (0, Vec::new());
        };
        let (found, finals) = self.finals.of(self.motor, s, goal);
        let on = (at.state.active.as_slice(), &at.state.q);
        let switches: Vec<Switch> = landing_proposals(self.motor, s, on, goal, &finals, at.tired)
            .into_iter()
            .map(|(kept, new)| Switch {
                set: kept.iter().chain(&new).copied().collect(),
                pivot: kept.first().copied(),
                new,
            })
            .collect();
        let spent = found + switches.len();
        // held where the settle says so: every magnet within its coil's reach (see `landing`)
        let capture = self.motor.torques.well.max_attraction();
        let steps = held_steps(
            self.motor,
            &at.state.q,
            switches,
            &towards,
            &s.limits,
            capture,
        );
        (spent, steps)
    }
}

/// A switch a landing, a bridge or a replayed row weighs: the set on after it, and the pair it
/// keeps as its pivot (if any) and the pairs it switches on, as the plan's row names them.
struct Switch {
    set: Vec<Pair>,
    pivot: Option<Pair>,
    new: Vec<Pair>,
}

/// The steps `switches` make from `from`, settled in parallel, that hold every active pair
/// within `capture`: any way the ball turns, by any angle ([`StepLimits::landing`]), measured
/// about `about`; in the switches' order.
fn held_steps(
    motor: &Motor,
    from: &Orientation,
    switches: Vec<Switch>,
    about: &UnitVec,
    limits: &StepLimits,
    capture: Radians,
) -> Vec<Step> {
    let sets = switches.iter().map(|w| w.set.clone()).collect();
    let outcomes = settled_states(motor, sets, from);
    let landing = limits.landing();
    switches
        .into_iter()
        .zip(outcomes)
        .filter_map(|(w, to)| {
            let (to, angle, axis_error) =
                admissible(&motor.torques, from, to?, about, &landing, capture)?;
            Some(Step {
                pivot: w.pivot,
                new: w.new,
                to,
                angle,
                axis_error,
            })
        })
        .collect()
}

/// The sets a step from `from` may switch on so that the set of `next` can be switched on
/// after it (the supply powering both switches, make before break): the coils of `next`, each
/// with at most one magnet within `capture` of it at `aim`, `s.pairs` pairs at a time, in a
/// deterministic order; neither `from`'s set nor `next`'s.
fn bridge_sets(
    t: &MagnetTorques,
    from: &CommutationState,
    next: &PlanRow,
    aim: &Orientation,
    capture: Radians,
    s: &PlanSettings,
) -> Vec<Vec<Pair>> {
    let r = aim.to_rotation_matrix();
    let mut coils: Vec<CoilId> = next.active.iter().map(|p| p.coil).collect();
    coils.sort();
    coils.dedup();
    let per_coil: Vec<Vec<Pair>> = coils
        .iter()
        .map(|&coil| {
            (0..t.rotor.len())
                .map(|m| Pair {
                    coil,
                    magnet: MagnetId(m),
                })
                .filter(|p| pair_gap(t, &r, *p).0 <= capture.0)
                .collect()
        })
        .collect();
    let mut sets = Vec::new();
    let mut set = Vec::new();
    choose_per_coil(&per_coil, &mut set, &mut sets);
    let max = s.limits.max_coils_on;
    let (same_from, same_next) = (sorted(&from.active), sorted(&next.active));
    sets.retain(|set: &Vec<Pair>| {
        let key = sorted(set);
        let new: Vec<Pair> = set
            .iter()
            .filter(|p| !from.active.contains(p))
            .copied()
            .collect();
        let then: Vec<Pair> = (next.active.iter())
            .filter(|p| !set.contains(p))
            .copied()
            .collect();
        (s.pairs.min..=s.pairs.max).contains(&set.len())
            && key != same_from
            && key != same_next
            && fits_supply(&from.active, &new, max)
            && fits_supply(set, &then, max)
    });
    sets
}

/// Every choice of at most one pair from each of `per_coil`, appended to `out` (`set`: the
/// choice so far).
fn choose_per_coil(per_coil: &[Vec<Pair>], set: &mut Vec<Pair>, out: &mut Vec<Vec<Pair>>) {
    let Some((first, rest)) = per_coil.split_first() else {
        if !set.is_empty() {
            out.push(set.clone());
        }
        return;
    };
    choose_per_coil(rest, set, out);
    for p in first {
        set.push(*p);
        choose_per_coil(rest, set, out);
        set.pop();
    }
}

/// The proposals from a partial plan's state that the search settles: all that pass the filter
/// within the search bound, ranked by the rank their cheap prediction
/// ([`predicted_orientation`]) would give the plan, the `settles_per_state` best. The
/// predictions run in parallel and are collected in order: the same on any number of threads.
fn ranked_proposals(motor: &Motor, s: &PlanSettings, at: &Frontier) -> Vec<Proposal> {
    let bound = wide_limits(&s.limits).bound_start;
    let ranked: Vec<(f64, Proposal)> =
        proposals_within(motor, at.state, &s.axis, s.pairs, bound, &s.limits)
            .into_par_iter()
            .filter_map(|(pivot, new)| {
                let mut set = vec![pivot];
                set.extend_from_slice(&new);
                let qp = predicted_orientation(&motor.torques, &at.state.q, &set);
                predicted_rank(at, &qp, s).map(|r| (r, (pivot, new)))
            })
            .collect();
    // The smallest sets are all weighed (few, and the physics least like the springs of the
    // prediction); the larger ones only where the prediction ranks them among the best.
    weighed(
        ranked,
        |(_, new)| new.len(),
        s.pairs.min - 1,
        s.settles_per_state,
    )
}
