//! Motion planning (paper section 3.2 and 4.1): sequences of commutation steps that turn the
//! ball by a target angle about a desired axis. A consumer of settled equilibria: it chooses
//! among the steps that `commutation` predicts and never integrates anything itself. The
//! paper's three greedy schemes, and a beam search that looks ahead for the smallest worst
//! cumulative axis error.

use crate::model::geometry::{Degrees, Orientation, Pair, Radians, UnitVec};
use crate::planning::commutation::Proposal;
use crate::planning::commutation::{
    candidate_steps, cumulative, evaluate_proposals, initial_states, predicted_orientation,
    proposals_within, CommutationState, Motor, PairsPerStep, Step, StepLimits, StepModel,
};
use crate::planning::plan::PlanRow;
use rayon::prelude::*;
use serde::{Deserialize, Serialize};

/// The dynamic search's default budget, in settles.
pub const DEFAULT_SETTLE_BUDGET: usize = 10_000;

/// How many of each state's best-ranked proposals the dynamic search settles by default.
pub const DEFAULT_SETTLES_PER_STATE: usize = 24;

/// How the next step is chosen.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum Scheme {
    /// Greedy: the step with the smallest axis error.
    MinAxisError,
    /// Greedy: the step with the largest rotation angle.
    MaxAngle,
    /// Greedy: the largest angle minus axis error (the paper's choice, section 4.1).
    Weighted,
    /// Beam search over sequences for the smallest worst cumulative axis error.
    Search,
}

impl Scheme {
    pub const ALL: [Scheme; 4] = [
        Scheme::MinAxisError,
        Scheme::MaxAngle,
        Scheme::Weighted,
        Scheme::Search,
    ];

    pub fn name(self) -> &'static str {
        match self {
            Scheme::MinAxisError => "min-axis-error",
            Scheme::MaxAngle => "max-angle",
            Scheme::Weighted => "weighted",
            Scheme::Search => "search",
        }
    }

    pub fn from_name(s: &str) -> Option<Scheme> {
        Scheme::ALL.into_iter().find(|x| x.name() == s)
    }

    /// The scheme named `s`, or what was expected instead.
    pub fn parse(s: &str) -> std::result::Result<Scheme, String> {
        Scheme::from_name(s).ok_or_else(|| {
            let names: Vec<&str> = Scheme::ALL.iter().map(|x| x.name()).collect();
            format!("one of {}, got \"{s}\"", names.join(", "))
        })
    }
}

/// The largest target angle a plan may ask for, degrees.
pub const MAX_TARGET_DEG: f64 = 3600.0;

/// A target angle given in degrees, checked to lie in (0, [`MAX_TARGET_DEG`]], or what was
/// expected instead.
pub fn target_angle(deg: f64) -> std::result::Result<Radians, String> {
    if deg.is_finite() && deg > 0.0 && deg <= MAX_TARGET_DEG {
        Ok(Degrees(deg).to_radians())
    } else {
        Err(format!(
            "a target angle in (0, {MAX_TARGET_DEG}] degrees, got {deg}"
        ))
    }
}

/// What to plan.
#[derive(Debug, Clone, PartialEq)]
pub struct PlanSettings {
    pub axis: UnitVec,
    pub angle: Radians,
    pub scheme: Scheme,
    pub model: StepModel,
    /// Pairs on after each step (pivot + new ones): exactly 2 for the paper's model.
    pub pairs: PairsPerStep,
    /// Start orientation, before the initial commutation.
    pub start: Orientation,
    pub limits: StepLimits,
    /// Give up after this many steps.
    pub max_steps: usize,
    /// Beam width of the search planner (pivot model).
    pub beam_width: usize,
    /// The search's budget (dynamic model): settles, counted, never time.
    pub settle_budget: usize,
    /// The search settles this many of each state's best-ranked proposals (dynamic model).
    pub settles_per_state: usize,
    /// The target counts as reached within this angle of it.
    pub angle_tolerance: Radians,
}

/// A plan and how it ended.
#[derive(Debug, Clone)]
pub struct Plan {
    pub rows: Vec<PlanRow>,
    pub reached: bool,
    /// Why the plan stopped short, when it did.
    pub message: Option<String>,
}

/// The summary printed by `plan --json`.
#[derive(Debug, Clone, Serialize)]
pub struct PlanSummary {
    pub steps: usize,
    pub final_angle_deg: f64,
    pub max_axis_error_deg: f64,
    pub reached: bool,
    pub total_settle_time_s: f64,
    pub scheme: String,
    pub model: String,
    pub pairs_per_step: usize,
    pub message: Option<String>,
}

impl Plan {
    pub fn summary(&self, s: &PlanSettings) -> PlanSummary {
        PlanSummary {
            steps: self.rows.len().saturating_sub(1),
            final_angle_deg: self.rows.last().map(|r| r.cum_angle_deg).unwrap_or(0.0),
            max_axis_error_deg: max_axis_error_deg(&self.rows),
            reached: self.reached,
            total_settle_time_s: total_settle_time(&self.rows),
            scheme: s.scheme.name().to_string(),
            model: s.model.name().into(),
            pairs_per_step: s.pairs.max,
            message: self.message.clone(),
        }
    }
}

/// Sum of a plan's predicted settle times, s (0, not -0, for no rows).
pub fn total_settle_time(rows: &[PlanRow]) -> f64 {
    rows.iter().fold(0.0, |a, r| a + r.settle_time_s)
}

/// Worst cumulative axis error over a plan's rows, degrees.
pub fn max_axis_error_deg(rows: &[PlanRow]) -> f64 {
    rows.iter()
        .map(|r| r.cum_axis_error_deg)
        .fold(0.0, f64::max)
}

/// A partial plan: the states so far and their running figures.
#[derive(Debug, Clone)]
struct Path {
    rows: Vec<PlanRow>,
    state: CommutationState,
    worst: f64,
    cum: f64,
}

impl Path {
    fn extend(&self, step: &Step, q0: &Orientation, n: &UnitVec) -> Path {
        let (ca, ce) = cumulative(q0, &step.to.q, n);
        let row = PlanRow {
            step: self.rows.len(),
            pivot: Some(step.pivot),
            new: step.new.clone(),
            active: step.to.active.clone(),
            q: step.to.q,
            step_angle_deg: step.angle.0.to_degrees(),
            step_axis_error_deg: step.axis_error.0.to_degrees(),
            cum_angle_deg: ca.0.to_degrees(),
            cum_axis_error_deg: ce.0.to_degrees(),
            settle_time_s: step.to.settle_time_s,
        };
        let mut rows = self.rows.clone();
        rows.push(row);
        Path {
            rows,
            state: step.to.clone(),
            worst: self.worst.max(ce.0),
            cum: ca.0,
        }
    }
}

/// Plans a motion.
pub fn plan(motor: &Motor, s: &PlanSettings) -> Plan {
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
    let inits = initial_states(motor, &s.start, s.model, &s.axis, capture);
    let Some(first) = inits.first() else {
        return Plan {
            rows: Vec::new(),
            reached: false,
            message: Some(
                "no initial commutation state: no second pair within the maximum attraction \
                 distance of the start orientation settles with both pairs holding (each magnet \
                 within the capture distance of its coil)"
                    .into(),
            ),
        };
    };
    match s.scheme {
        Scheme::Search => {
            let roots: Vec<Path> = inits.iter().map(root_path).collect();
            match s.model {
                StepModel::Pivot => search(motor, s, roots),
                StepModel::Dynamic => best_first(motor, s, roots),
            }
        }
        g => greedy(motor, s, root_path(first), g),
    }
}

/// A plan's start: row 0, the initial commutation state.
fn root_path(init: &CommutationState) -> Path {
    let row0 = PlanRow {
        step: 0,
        pivot: None,
        new: init.active.clone(),
        active: init.active.clone(),
        q: init.q,
        step_angle_deg: 0.0,
        step_axis_error_deg: 0.0,
        cum_angle_deg: 0.0,
        cum_axis_error_deg: 0.0,
        settle_time_s: init.settle_time_s,
    };
    Path {
        rows: vec![row0],
        state: init.clone(),
        worst: 0.0,
        cum: 0.0,
    }
}

fn reached(p: &Path, s: &PlanSettings) -> bool {
    p.cum >= s.angle.0 - s.angle_tolerance.0
}

fn steps_from(motor: &Motor, s: &PlanSettings, state: &CommutationState) -> Vec<Step> {
    candidate_steps(motor, state, &s.axis, s.model, s.pairs, &s.limits)
}

/// The greedy key of a step (larger is better), ties broken by the step's pairs. Progress
/// past the target counts against a step, so that the last step lands near the target.
fn greedy_key(scheme: Scheme, st: &Step, remaining: f64) -> f64 {
    let progress = st.angle.0 - 2.0 * (st.angle.0 - remaining).max(0.0);
    match scheme {
        Scheme::MinAxisError => -st.axis_error.0,
        Scheme::MaxAngle => progress,
        _ => progress - st.axis_error.0,
    }
}

fn greedy(motor: &Motor, s: &PlanSettings, mut path: Path, scheme: Scheme) -> Plan {
    let q0 = path.state.q;
    let mut seen: Vec<Vec<Pair>> = vec![path.state.active.clone()];
    loop {
        if reached(&path, s) {
            return Plan {
                rows: path.rows,
                reached: true,
                message: None,
            };
        }
        if path.rows.len() > s.max_steps {
            return stopped(path, format!("gave up after {} steps", s.max_steps));
        }
        let steps = steps_from(motor, s, &path.state);
        let remaining = s.angle.0 - path.cum;
        let best = steps
            .iter()
            .filter(|st| !revisits(&seen, st))
            .max_by(|a, b| {
                greedy_key(scheme, a, remaining)
                    .total_cmp(&greedy_key(scheme, b, remaining))
                    .then_with(|| b.to.active.cmp(&a.to.active))
            });
        let Some(best) = best else {
            return stopped(
                path,
                "no candidate step advances about the axis within the axis error limit".into(),
            );
        };
        path = path.extend(best, &q0, &s.axis);
        seen.push(path.state.active.clone());
    }
}

/// A greedy plan must not cycle between the same active sets.
fn revisits(seen: &[Vec<Pair>], st: &Step) -> bool {
    let a = sorted(&st.to.active);
    seen.iter().any(|v| sorted(v) == a)
}

fn stopped(path: Path, why: String) -> Plan {
    let got = path.cum.to_degrees();
    Plan {
        rows: path.rows,
        reached: false,
        message: Some(format!(
            "target not reached: {why} (reached {got:.2} degrees)"
        )),
    }
}

/// A search's plan: its best solution, else the deepest partial plan and why it stopped.
fn outcome(best: Option<Path>, deepest: Path, why: String) -> Plan {
    match best {
        Some(b) => Plan {
            rows: b.rows,
            reached: true,
            message: None,
        },
        None => stopped(deepest, why),
    }
}

/// The plan of a search given no root.
fn no_initial_state() -> Plan {
    Plan {
        rows: Vec::new(),
        reached: false,
        message: Some("no initial commutation state".into()),
    }
}

/// Beam search: keeps the `beam_width` best partial plans at each depth (best = smallest worst
/// cumulative axis error, with a credit for progress), expanding them all in parallel; a plan
/// that reaches the target is a solution, and partial plans already as bad as the best solution
/// are pruned (the worst error never falls along a path). The paper's greedy plans are
/// candidates too, so the search is never worse than them.
fn search(motor: &Motor, s: &PlanSettings, roots: Vec<Path>) -> Plan {
    let Some(root) = roots.first().cloned() else {
        return no_initial_state();
    };
    let mut best = greedy_best(motor, s, &root, better_solution);
    let mut beam = roots;
    let mut deepest = root;
    let wide = PlanSettings {
        limits: StepLimits {
            bound_start: Radians(s.limits.bound_start.0.max(s.limits.search_bound.0)),
            ..s.limits
        },
        ..s.clone()
    };
    for _depth in 0..s.max_steps {
        if beam.is_empty() {
            break;
        }
        let children: Vec<Vec<Path>> = beam
            .par_iter()
            .map(|p| {
                let q0 = p.rows[0].q;
                steps_from(motor, &wide, &p.state)
                    .iter()
                    .map(|st| p.extend(st, &q0, &s.axis))
                    .collect()
            })
            .collect();
        let mut next: Vec<Path> = Vec::new();
        for c in children.into_iter().flatten() {
            if best.as_ref().is_some_and(|b| c.worst > b.worst + 1e-9) {
                continue;
            }
            if reached(&c, s) {
                if better_solution(&c, best.as_ref(), s) {
                    best = Some(c);
                }
            } else {
                next.push(c);
            }
        }
        let credit = 0.25;
        next.sort_by(|a, b| {
            let sa = a.worst - credit * a.cum;
            let sb = b.worst - credit * b.cum;
            sa.total_cmp(&sb)
                .then_with(|| a.state.active.cmp(&b.state.active))
                .then_with(|| {
                    let ka: Vec<_> = a.rows.iter().map(|r| r.active.clone()).collect();
                    let kb: Vec<_> = b.rows.iter().map(|r| r.active.clone()).collect();
                    ka.cmp(&kb)
                })
        });
        // one partial plan per end state
        let mut kept: Vec<Path> = Vec::new();
        for c in next {
            let dup = kept
                .iter()
                .any(|k| k.state.active == c.state.active && k.state.q.angle_to(&c.state.q) < 1e-6);
            if !dup {
                kept.push(c);
                if kept.len() == s.beam_width {
                    break;
                }
            }
        }
        if let Some(front) = kept.first() {
            if front.cum > deepest.cum {
                deepest = front.clone();
            }
        }
        beam = kept;
    }
    outcome(
        best,
        deepest,
        "the search found no sequence that reaches the target".into(),
    )
}

/// The best of the paper's three greedy plans from `root` that reaches the target, as a
/// solution the searches must beat.
fn greedy_best(
    motor: &Motor,
    s: &PlanSettings,
    root: &Path,
    better: fn(&Path, Option<&Path>, &PlanSettings) -> bool,
) -> Option<Path> {
    let mut best: Option<Path> = None;
    for g in [Scheme::Weighted, Scheme::MinAxisError, Scheme::MaxAngle] {
        let q0 = root.state.q;
        let p = greedy(motor, s, root.clone(), g);
        if p.reached {
            let worst = max_axis_error_deg(&p.rows).to_radians();
            let cum = p
                .rows
                .last()
                .map(|r| r.cum_angle_deg.to_radians())
                .unwrap_or(0.0);
            let cand = Path {
                state: CommutationState {
                    q: p.rows.last().map(|r| r.q).unwrap_or(q0),
                    active: p.rows.last().map(|r| r.active.clone()).unwrap_or_default(),
                    settle_time_s: 0.0,
                },
                rows: p.rows,
                worst,
                cum,
            };
            if better(&cand, best.as_ref(), s) {
                best = Some(cand);
            }
        }
    }
    best
}

/// Progress counts in a partial plan's rank with this weight against its worst axis error
/// (both in radians): a plan 4 degrees further on may be 1 degree worse.
const PROGRESS_CREDIT: f64 = 0.25;

/// Two settled states with the same pairs on and orientations closer than this are one state.
const SAME_STATE_RAD: f64 = 1e-3;

/// A partial plan's rank in the best-first search (smaller first): its worst cumulative axis
/// error so far, less a credit for progress (none past the target).
fn rank(worst: f64, cum: f64, target: f64) -> f64 {
    worst - PROGRESS_CREDIT * cum.min(target)
}

/// An entry of the best-first search's open list: rank, then arrival order.
#[derive(Debug, Clone, Copy, PartialEq)]
struct Open {
    rank: f64,
    node: usize,
}

impl Eq for Open {}

impl Ord for Open {
    fn cmp(&self, o: &Self) -> std::cmp::Ordering {
        // BinaryHeap is a max-heap: the smallest rank, then the earliest node, on top
        o.rank
            .total_cmp(&self.rank)
            .then_with(|| o.node.cmp(&self.node))
    }
}

impl PartialOrd for Open {
    fn partial_cmp(&self, o: &Self) -> Option<std::cmp::Ordering> {
        Some(self.cmp(o))
    }
}

/// The proposals from a partial plan's state that the search settles: all that pass the filter
/// within the search bound, ranked by the rank their cheap prediction
/// ([`predicted_orientation`]) would give the plan, the `settles_per_state` best.
fn ranked_proposals(motor: &Motor, s: &PlanSettings, p: &Path) -> Vec<Proposal> {
    let bound = Radians(s.limits.bound_start.0.max(s.limits.search_bound.0));
    let q0 = p.rows[0].q;
    let mut ranked: Vec<(f64, Proposal)> =
        proposals_within(motor, &p.state, &s.axis, s.pairs, bound, &s.limits)
            .into_iter()
            .filter_map(|(pivot, new)| {
                let mut set = vec![pivot];
                set.extend_from_slice(&new);
                let qp = predicted_orientation(motor.torques, &p.state.q, &set);
                let (advance, _) = cumulative(&p.state.q, &qp, &s.axis);
                if advance.0 <= 0.0 {
                    return None;
                }
                let (ca, ce) = cumulative(&q0, &qp, &s.axis);
                Some((rank(p.worst.max(ce.0), ca.0, s.angle.0), (pivot, new)))
            })
            .collect();
    ranked.sort_by(|a, b| a.0.total_cmp(&b.0).then_with(|| a.1.cmp(&b.1)));
    // The smallest sets are all weighed (few, and the physics least like the springs of the
    // prediction); the larger ones only where the prediction ranks them among the best.
    let smallest = s.pairs.min - 1;
    let mut taken = [0usize; PairsPerStep::LIMIT + 1];
    ranked
        .into_iter()
        .filter(|(_, (_, new))| {
            if new.len() <= smallest {
                return true;
            }
            let k = new.len().min(PairsPerStep::LIMIT);
            taken[k] += 1;
            taken[k] <= s.settles_per_state
        })
        .map(|(_, p)| p)
        .collect()
}

/// The settled states the best-first search has reached: (root, pairs on, sorted) -> each
/// orientation reached with them and the node of the best partial plan that ends there.
type StateIndex = std::collections::HashMap<(usize, Vec<Pair>), Vec<(Orientation, usize)>>;

/// Best-first branch and bound over settled states (the dynamic model): the partial plan of
/// smallest rank is expanded next, its best-ranked proposals settled in parallel; a plan that
/// reaches the target is a solution, and partial plans already as bad as the best solution are
/// pruned (a plan's worst error never falls along it). Two partial plans from the same root
/// that end in the same state (same pairs on, orientation within [`SAME_STATE_RAD`]) are one:
/// only the better goes on. The greedy plans are solutions from the start, so the search is
/// never worse than them. The budget is counted in settles, so the plan is the same on any
/// machine and any number of threads.
fn best_first(motor: &Motor, s: &PlanSettings, roots: Vec<Path>) -> Plan {
    let Some(root) = roots.first().cloned() else {
        return no_initial_state();
    };
    let mut best = greedy_best(motor, s, &root, better_landing);
    let mut deepest = root;
    let mut nodes: Vec<(usize, Path)> = Vec::new();
    let mut open = std::collections::BinaryHeap::new();
    let mut states = StateIndex::new();
    for (k, r) in roots.into_iter().enumerate() {
        open.push(Open {
            rank: rank(r.worst, r.cum, s.angle.0),
            node: nodes.len(),
        });
        nodes.push((k, r));
    }
    let mut spent = 0usize;
    while spent < s.settle_budget {
        let Some(Open { node, .. }) = open.pop() else {
            break;
        };
        let (root_id, path) = nodes[node].clone();
        if best
            .as_ref()
            .is_some_and(|b| path.worst >= score(b, s) - 1e-9)
        {
            continue;
        }
        let key = (root_id, sorted(&path.state.active));
        let current = states.get(&key).and_then(|v| {
            v.iter()
                .find(|(q, _)| q.angle_to(&path.state.q) < SAME_STATE_RAD)
        });
        if current.is_some_and(|&(_, k)| k != node) {
            continue; // a better plan reached this state since
        }
        let proposals = ranked_proposals(motor, s, &path);
        spent += proposals.len();
        let q0 = path.rows[0].q;
        let steps = evaluate_proposals(
            motor,
            &path.state,
            &s.axis,
            StepModel::Dynamic,
            proposals,
            &s.limits,
        );
        for st in &steps {
            let c = path.extend(st, &q0, &s.axis);
            if best.as_ref().is_some_and(|b| c.worst > score(b, s) + 1e-9) {
                continue;
            }
            if reached(&c, s) {
                if better_landing(&c, best.as_ref(), s) {
                    best = Some(c);
                }
                continue;
            }
            let key = (root_id, sorted(&c.state.active));
            let list = states.entry(key).or_default();
            let id = nodes.len();
            match list
                .iter_mut()
                .find(|(q, _)| q.angle_to(&c.state.q) < SAME_STATE_RAD)
            {
                Some(entry) => {
                    if nodes[entry.1].1.worst <= c.worst + 1e-9 {
                        continue;
                    }
                    entry.1 = id;
                }
                None => list.push((c.state.q, id)),
            }
            if c.cum > deepest.cum {
                deepest = c.clone();
            }
            open.push(Open {
                rank: rank(c.worst, c.cum, s.angle.0),
                node: id,
            });
            nodes.push((root_id, c));
        }
    }
    outcome(
        best,
        deepest,
        format!(
            "the search found no sequence that reaches the target within its budget of {} settles",
            s.settle_budget
        ),
    )
}

fn sorted(v: &[Pair]) -> Vec<Pair> {
    let mut v = v.to_vec();
    v.sort();
    v
}

/// How far a complete plan departs from the motion asked for, rad: its worst cumulative axis
/// error, or how far it lands past the target (beyond the angle tolerance) if that is more.
/// Both are angles by which the ball's rotation misses the requested one.
fn score(p: &Path, s: &PlanSettings) -> f64 {
    let landing = ((p.cum - s.angle.0).abs() - s.angle_tolerance.0).max(0.0);
    p.worst.max(landing)
}

/// The best-first search's order of complete plans: the smaller [`score`] wins; on a tie
/// (within 1e-9 rad), as [`better_solution`].
fn better_landing(c: &Path, best: Option<&Path>, s: &PlanSettings) -> bool {
    match best {
        None => true,
        Some(b) => {
            let (sc, sb) = (score(c, s), score(b, s));
            if (sc - sb).abs() > 1e-9 {
                return sc < sb;
            }
            better_solution(c, Some(b), s)
        }
    }
}

/// Smaller worst axis error wins; on a tie (within 1e-9 rad), landing nearer the target, then
/// fewer steps.
fn better_solution(c: &Path, best: Option<&Path>, s: &PlanSettings) -> bool {
    let target = s.angle.0;
    match best {
        None => true,
        Some(b) => {
            if (c.worst - b.worst).abs() > 1e-9 {
                return c.worst < b.worst;
            }
            let (oc, ob) = ((c.cum - target).abs(), (b.cum - target).abs());
            if (oc - ob).abs() > 1e-9 {
                return oc < ob;
            }
            c.rows.len() < b.rows.len()
        }
    }
}
