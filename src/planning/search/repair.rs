//! Repairing a complete plan where it strays most from its path: the search is run again from
//! the rows before its worst row (the rows before kept), measuring partial plans by their path
//! alone and pruning every one that strays as far as the plan does, so that the repair's share
//! of the budget goes into the part of the plan that decides how far it strays. A plan it
//! finds is landed (no further from its path than that) and straightened as the first was, and
//! kept when it keeps nearer its path, strays no further by the search's own measure and still
//! ends near its goal. Again from the new plan's worst row while that helps; when the search
//! from the worst row's own state finds nothing, from one and two rows before it.
//!
//! The first search ranks partial plans by how far they have strayed so far, so its budget
//! goes mostly into the early rows of many plans (they have strayed least), while the row that
//! decides a complete plan's measure often lies later. The repair spends where that row is.

use super::{explore, land, node_of, score, straighten, strayed, Node, StepSource, SAME_STATE_RAD};
use crate::planning::plan::PlanSettings;
use straighten::departures;

/// The repair's share of the settle budget: one part in this many (the first search spends
/// the rest).
pub(super) const REPAIR_SHARE: usize = 5;

/// The repair's searches stall after this part of the first search's stall
/// ([`PlanSettings::stall_settles`]: a quarter; on the 500-axis sweep with a stall of 2,000
/// the repair spent 1,580 settles a plan instead of 2,047, the worst and median axis errors
/// 5.87 and 2.89 degrees instead of 5.87 and 2.88).
const REPAIR_STALL: usize = 4;

/// A repaired plan must stray this much less (rad; 0.01 degree).
const MIN_GAIN: f64 = 0.01 * std::f64::consts::PI / 180.0;

/// `plan` repaired (see the module's text) within `budget` settles, and the settles spent.
pub(super) fn repair(
    src: &dyn StepSource,
    s: &PlanSettings,
    plan: Node,
    budget: usize,
) -> (Node, usize) {
    let before = src.initial_on_times();
    let mut best = plan;
    let mut spent = 0usize;
    'better: while spent < budget {
        // the path alone is weighed: the settings of a plan sent to its goal orientation
        let sp = PlanSettings {
            target: Some(land::goal_of_node(&best, s)),
            stall_settles: (s.stall_settles / REPAIR_STALL).max(1),
            ..s.clone()
        };
        let Some(k) = worst_row(&best, &sp) else {
            break;
        };
        let by_path = node_of(&best.rows, &sp, before.as_ref());
        for from in (1..=k).rev().take(MAX_BACK) {
            if spent >= budget {
                break;
            }
            let prefix = node_of(&best.rows[..from], &sp, before.as_ref());
            let (found, used) = search_from(src, &sp, prefix, &by_path, budget - spent);
            spent += used;
            if let Some(c) = found.map(|c| node_of(&c.rows, s, before.as_ref())) {
                if better(&c, &best, s) {
                    best = c;
                    continue 'better;
                }
            }
        }
        break;
    }
    (best, spent)
}

/// The search from `prefix` for a plan that strays less than `current` (both measured by
/// `sp`'s path alone), landed and straightened, and the settles spent.
fn search_from(
    src: &dyn StepSource,
    sp: &PlanSettings,
    prefix: Node,
    current: &Node,
    budget: usize,
) -> (Option<Node>, usize) {
    let found = explore(src, sp, vec![prefix], Some(current.clone()), budget, true);
    let mut spent = found.spent;
    // the plans that stray less than the current one (it is the search's best until beaten)
    let gain = |n: &Node| score(n, sp) < score(current, sp) - MIN_GAIN;
    let Some(b) = found.best.filter(gain) else {
        return (None, spent);
    };
    let others: Vec<Node> = found.solutions.into_iter().filter(gain).collect();
    let (landed, landing) = land::land_best(
        src,
        sp,
        Some(b),
        others,
        Some(score(current, sp) - MIN_GAIN),
    );
    spent += landing;
    let Some(landed) = landed else {
        return (None, spent);
    };
    let (landed, straightening) = straighten::straighten(src, sp, landed);
    (Some(landed), spent + straightening)
}

/// The repair starts again from at most this many rows before a plan's worst row (the worst
/// row's own state first, then earlier ones, where a step more is free).
const MAX_BACK: usize = 3;

/// The row where `plan` strays most (the first of equals), when it is not row 0: the search
/// is run again from the rows before it.
fn worst_row(plan: &Node, s: &PlanSettings) -> Option<usize> {
    let q0 = plan.rows[0].q;
    let strays: Vec<f64> = (plan.rows.iter())
        .map(|r| strayed(&r.q, &q0, r.cum_axis_error_deg.to_radians(), s))
        .collect();
    let k = (0..strays.len()).fold(0, |m, i| if strays[i] > strays[m] { i } else { m });
    (k > 0).then_some(k)
}

/// A repaired plan may end this fraction of the plan's tolerance from its goal (or no further
/// than the plan it replaces): a straighter way is not bought with an end near the tolerance
/// (on the first 100 random motions, accepting any end within the tolerance left 15 plans more
/// than 0.8 degrees from their goals, against 8 before the repair and 7 with this share).
const END_SHARE: f64 = 0.75;

/// Whether the repaired plan `c` is better than `b`: it keeps nearer its path (by at least
/// [`MIN_GAIN`]), strays no further by the search's own measure (the axis error too, for a
/// turn about an axis), and ends within [`END_SHARE`] of the tolerance from its goal
/// orientation (or no further from it than `b`).
fn better(c: &Node, b: &Node, s: &PlanSettings) -> bool {
    let off = |n: &Node| n.state.q.angle_to(&land::goal_of_node(n, s));
    let path = |n: &Node| departures(&n.rows, s).into_iter().fold(0.0, f64::max);
    let near = off(c) <= (END_SHARE * s.tolerance.0).max(off(b) + SAME_STATE_RAD);
    near && path(c) < path(b) - MIN_GAIN && score(c, s) <= score(b, s) + 1e-9
}
