//! Straightening a complete plan: the row that strays furthest from the straight way is
//! replaced by a step nearer it (or left out) where the plan's next state is still reached
//! from there, the rest of the plan replayed unchanged; again while that helps, within a share
//! of the settle budget. The search's own measure of a partial plan is its worst, a maximum,
//! so once a plan is found its worst row is what a better plan must beat: the straightening
//! looks for exactly that, locally, where the search spent its budget going on.

use super::{
    departure, land, node_of, tired_after_last, Node, StepSource, CENTRED, SAME_STATE_RAD,
};
use crate::model::geometry::nearest_on_geodesic;
use crate::planning::commutation::{Step, StepModel};
use crate::planning::plan::{PlanRow, PlanSettings};

/// The straightening may spend this fraction of the search's settle budget (a tenth).
const STRAIGHTEN_SHARE: usize = 10;

/// A replacement must bring the plan this much nearer its path (rad; 0.01 degree).
const MIN_GAIN: f64 = 0.01 * std::f64::consts::PI / 180.0;

/// `plan` straightened (see the module's text), and the settles spent. The pivot model's plans
/// are left as they are (their measure is the paper's axis error), and so are the plans of a
/// step model that cannot replay a step ([`StepSource::step_to`]).
pub(super) fn straighten(src: &dyn StepSource, s: &PlanSettings, plan: Node) -> (Node, usize) {
    if s.model == StepModel::Pivot {
        return (plan, 0);
    }
    let budget = s.settle_budget / STRAIGHTEN_SHARE;
    let mut best = plan;
    let mut spent = 0usize;
    while spent < budget {
        let devs = departures(&best.rows, s);
        let Some(k) = worst_interior(&devs) else {
            break;
        };
        let (better, used) = better_way(src, s, &best, k, devs[k] - MIN_GAIN, budget - spent);
        spent += used;
        match better {
            Some(n) => best = n,
            None => break,
        }
    }
    (best, spent)
}

/// Each row's departure from the straight way of the plan (rad).
pub(super) fn departures(rows: &[PlanRow], s: &PlanSettings) -> Vec<f64> {
    let q0 = rows[0].q;
    rows.iter().map(|r| departure(&r.q, &q0, s)).collect()
}

/// The row furthest from the straight way (the first of equals), when it is neither row 0 nor
/// the last row (which the landing chose for where it ends).
fn worst_interior(devs: &[f64]) -> Option<usize> {
    let k = (0..devs.len()).fold(0, |m, i| if devs[i] > devs[m] { i } else { m });
    (k > 0 && k + 1 < devs.len()).then_some(k)
}

/// A plan like `plan` whose row `k` is replaced (or left out) and whose rows all lie within
/// `limit` (rad) of the straight way, with the settles spent (at most about `budget`).
/// Candidates for row `k`: the steps from row `k - 1` towards the point of the path nearest
/// row `k`, and the search's own expansion there, nearest the path first; leaving row `k` out
/// is tried first.
fn better_way(
    src: &dyn StepSource,
    s: &PlanSettings,
    plan: &Node,
    k: usize,
    limit: f64,
    budget: usize,
) -> (Option<Node>, usize) {
    // the rows before row k stay: none may already lie as far out as the limit
    if departures(&plan.rows[..k], s)
        .into_iter()
        .any(|d| d >= limit)
    {
        return (None, 0);
    }
    let before = src.initial_on_times();
    let parent = node_of(&plan.rows[..k], s, before.as_ref());
    let rest = &plan.rows[k + 1..];
    let (skip, mut spent) = rejoin(src, s, parent.clone(), rest, limit);
    if skip.is_some() {
        return (skip, spent);
    }
    let q0 = plan.rows[0].q;
    let goal = land::goal_of_node(plan, s);
    let aim = nearest_on_geodesic(&plan.rows[k].q, &q0, &goal);
    let tired = tired_after_last(&parent, s);
    let at = parent.frontier(&tired, CENTRED, s);
    let (a, mut steps) = src.bridges(&parent.state, &plan.rows[k + 1], &aim);
    let (b, more) = src.expand_towards(&at, &aim);
    spent += a + b;
    steps.extend(more);
    let mut near: Vec<(f64, Step)> = steps
        .into_iter()
        .map(|st| (departure(&st.to.q, &q0, s), st))
        .filter(|(d, _)| *d < limit)
        .collect();
    near.sort_by(|x, y| x.0.total_cmp(&y.0));
    for (_, st) in near {
        if spent >= budget {
            break;
        }
        let Ok(c) = parent.extend(&st, &q0, s) else {
            continue;
        };
        let (n, used) = rejoin(src, s, c, rest, limit);
        spent += used;
        if n.is_some() {
            return (n, spent);
        }
    }
    (None, spent)
}

/// `node` (whose rows lie within `limit`, rad, of the straight way) carried on by the sets of
/// `rest` (a plan's later rows), each step replayed from the state before it: the plan, when
/// every step is admissible and ends in the state its row had (the same key, within
/// [`SAME_STATE_RAD`]) and lies within `limit` of the straight way too; and the settles spent
/// (one a step, until one fails).
fn rejoin(
    src: &dyn StepSource,
    s: &PlanSettings,
    node: Node,
    rest: &[PlanRow],
    limit: f64,
) -> (Option<Node>, usize) {
    let q0 = node.rows[0].q;
    let mut n = node;
    for (j, r) in rest.iter().enumerate() {
        let Some(st) = src.step_to(&n.state, r) else {
            return (None, j + 1);
        };
        let same =
            src.key(&st.to) == src.key(&r.state()) && st.to.q.angle_to(&r.q) < SAME_STATE_RAD;
        let near = departure(&st.to.q, &q0, s) < limit;
        match n.extend(&st, &q0, s) {
            Ok(next) if same && near => n = next,
            _ => return (None, j + 1),
        }
    }
    (Some(n), rest.len())
}
