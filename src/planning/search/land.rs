//! The landing: the complete plans a search found, carried on from where they end towards
//! their goal orientation (the target rotation applied to row 0, or the target itself) with the
//! steps a step model proposes towards it, within a share of the settle budget and a leeway on
//! the path; the plan that ends nearest its goal is kept.

use super::*;

/// The search's best plan carried on by the landing (with the other complete plans it found,
/// `solutions`), and the settles the landing spent. A landing that ends further than the plan's
/// tolerance from the target orientation is tried again wider ([`WIDE`]: a worse path allowed
/// for an end within reach), and the nearer-ending of the two is kept. `most`: how far (rad)
/// a landed plan may stray at most, when less than the leeway allows.
pub(super) fn land_best(
    src: &dyn StepSource,
    s: &PlanSettings,
    best: Option<Node>,
    solutions: Vec<Node>,
    most: Option<f64>,
) -> (Option<Node>, usize) {
    let Some(b) = best else {
        return (None, 0);
    };
    let mut plans = vec![b];
    plans.extend(solutions);
    let budget = s.settle_budget / LANDING_SHARE;
    let (landed, settles) = land(src, s, plans.clone(), budget, NARROW, most);
    let off = |n: &Node| n.state.q.angle_to(&goal_of_node(n, s));
    if off(&landed) <= s.tolerance.0 {
        return (Some(landed), settles);
    }
    let (wide, more) = land(src, s, plans, budget, WIDE, most);
    let kept = match off(&wide) < off(&landed) - 1e-12 {
        true => wide,
        false => landed,
    };
    (Some(kept), settles + more)
}

/// The landing may spend this fraction of the search's settle budget (a fifth) on top of it,
/// twice when it lands wide.
const LANDING_SHARE: usize = 5;

/// How far a landing may stray: past the plan's end (`detour`, rad: a step away that opens the
/// way to a nearer one) and past the search's best plan's [`score`] (`slack`, rad: a plan that
/// ends nearer its goal may be this much worse on the way).
#[derive(Debug, Clone, Copy)]
struct Leeway {
    detour: f64,
    slack: f64,
}

/// The landing's leeway: 2 degrees of detour, 1 degree of slack.
const NARROW: Leeway = Leeway {
    detour: 2.0 * std::f64::consts::PI / 180.0,
    slack: std::f64::consts::PI / 180.0,
};

/// The leeway of a landing tried again: 5 degrees of detour, 3 degrees of slack.
const WIDE: Leeway = Leeway {
    detour: 5.0 * std::f64::consts::PI / 180.0,
    slack: 3.0 * std::f64::consts::PI / 180.0,
};

/// Where a complete plan was sent: the target orientation when the settings give one, else
/// the target rotation applied to its row 0.
pub(super) fn goal_of_node(p: &Node, s: &PlanSettings) -> Orientation {
    // a node always has its row 0
    crate::planning::plan::goal_of(s, &p.rows).unwrap_or(p.state.q)
}

/// The landing: the complete plans a search found that end further than the angle tolerance
/// from their goal orientation ([`goal_of_node`]) are carried on, best-first by the distance
/// to the goal, with the steps that turn the ball from their ends towards it
/// ([`StepSource::expand_towards`]), until a plan ends within the angle tolerance, `budget`
/// settles are spent or nothing is left to expand. Plans that end in one state are carried on
/// once (the first). A landing may pass through states up to the leeway's detour further from
/// the goal than the plan it carries on, and keeps every plan's [`score`] (worst axis error,
/// overshoot) within the leeway's slack of the best plan's, and every coil within the on-time
/// limit. The plan that ends nearest its goal orientation (a complete plan, or any plan the
/// landing made: what the ball is sent to is the goal, not the angle turned about the axis),
/// and the settles spent. The cumulative rotation's figures stay those about the plan's axis.
/// `plans` is best first; the first is the search's best.
fn land(
    src: &dyn StepSource,
    s: &PlanSettings,
    plans: Vec<Node>,
    budget: usize,
    leeway: Leeway,
    most: Option<f64>,
) -> (Node, usize) {
    let bound = plans.first().map_or(0.0, |b| path_score(b, s)) + leeway.slack + 1e-9;
    let bound = most.map_or(bound, |m| bound.min(m));
    // each node: the plan, its goal, the farthest from it a landing may go
    let mut nodes: Vec<(Node, Orientation, f64)> = Vec::new();
    let mut open = std::collections::BinaryHeap::new();
    let mut seen: Vec<(Vec<Pair>, Orientation)> = Vec::new();
    // and each plan without its last step, whose landing may take another way to the goal
    let parents = parents_of(&plans, s, src.initial_on_times().as_ref());
    for p in plans.into_iter().chain(parents) {
        let goal = goal_of_node(&p, s);
        let d = p.state.q.angle_to(&goal);
        if path_score(&p, s) > bound {
            continue;
        }
        // plans that end in one state are landed once (the first, the best)
        let key = src.key(&p.state);
        if seen_before(&seen, &key, &p.state.q) {
            continue;
        }
        seen.push((key, p.state.q));
        open.push(Open {
            rank: d,
            node: nodes.len(),
        });
        nodes.push((p, goal, d + leeway.detour));
    }
    let dist = |n: &(Node, Orientation, f64)| n.0.state.q.angle_to(&n.1);
    let mut nearest = 0usize;
    for (k, n) in nodes.iter().enumerate() {
        if reached(&n.0, s) && dist(n) < dist(&nodes[nearest]) - 1e-12 {
            nearest = k;
        }
    }
    let mut spent = 0usize;
    while spent < budget && dist(&nodes[nearest]) > s.angle_tolerance.0 {
        let Some(Open { node, .. }) = open.pop() else {
            break;
        };
        let (at, goal, limit) = nodes[node].clone();
        let (settles, steps) = expand_rested(src, &at, &goal, s, budget.saturating_sub(spent));
        spent += settles;
        let q0 = at.rows[0].q;
        for st in steps {
            let (angle, axis_error) = step_measure(&at.state.q, &st.to.q, &s.axis);
            let st = Step {
                angle,
                axis_error,
                ..st
            };
            let Ok(c) = at.extend(&st, &q0, s) else {
                continue;
            };
            let d = c.state.q.angle_to(&goal);
            if d > limit || path_score(&c, s) > bound {
                continue;
            }
            let key = src.key(&c.state);
            if seen_before(&seen, &key, &c.state.q) {
                continue;
            }
            seen.push((key, c.state.q));
            let id = nodes.len();
            nodes.push((c, goal, limit));
            if d < dist(&nodes[nearest]) {
                nearest = id;
            }
            open.push(Open { rank: d, node: id });
        }
    }
    (nodes.swap_remove(nearest).0, spent)
}

/// Whether a state with the key `key` at `q` is one of `seen` (the same key, within
/// [`SAME_STATE_RAD`]).
fn seen_before(seen: &[(Vec<Pair>, Orientation)], key: &[Pair], q: &Orientation) -> bool {
    seen.iter()
        .any(|(k, o)| k.as_slice() == key && o.angle_to(q) < SAME_STATE_RAD)
}

/// Each plan of `plans` without its last step (a one-step plan's parent is its row 0 alone,
/// from which the landing may take another first step; `before`: the on-times of row 0's
/// coils, when the plans go on where another left off).
fn parents_of(plans: &[Node], s: &PlanSettings, before: Option<&OnTimes<CoilId>>) -> Vec<Node> {
    plans
        .iter()
        .filter(|p| p.rows.len() >= 2)
        .map(|p| node_of(&p.rows[..p.rows.len() - 1], s, before))
        .collect()
}

/// A partial plan's [`score`] as far as it goes: its worst axis error, or how far it has
/// turned past the target (beyond the angle tolerance) if that is more; falling short is not
/// counted (a landing may pass through states short of the target on its way to the goal).
fn path_score(p: &Node, s: &PlanSettings) -> f64 {
    let over = (p.cum - s.angle.0 - s.angle_tolerance.0).max(0.0);
    p.worst.max(over)
}

/// The landing's expansion of `at` towards `goal`, the coils kept off that could not stay on
/// for another step ([`tired_coils`], a step as long as the last); when some of the steps
/// found would still keep a coil on too long (their settles are longer), expanded again (within
/// `budget` settles) with the coils kept off that could not stay on for the shortest of those:
/// the settles spent and every step found.
fn expand_rested(
    src: &dyn StepSource,
    at: &Node,
    goal: &Orientation,
    s: &PlanSettings,
    budget: usize,
) -> (usize, Vec<Step>) {
    let mut avoid = tired_after_last(at, s);
    let (mut spent, mut steps) = (0usize, Vec::new());
    loop {
        let (settles, found) = src.expand_towards(&at.frontier(&avoid, ONWARD, s), goal);
        spent += settles;
        // the on-time check of `Node::extend`, without building the plan
        let over = |st: &Step| {
            let (to, step) = (&st.to, at.rows.len());
            held_after(&at.on, s.limits.on_time, &to.active, step, to.settle_time_s).is_err()
        };
        let shortest_over = found
            .iter()
            .filter(|st| over(st))
            .map(|st| st.to.settle_time_s)
            .min_by(f64::total_cmp);
        steps.extend(found);
        let Some(t) = shortest_over else {
            break;
        };
        let more = tired_coils(at, s.limits.on_time, t);
        if more.len() <= avoid.len() || spent >= budget {
            break;
        }
        avoid = more;
    }
    (spent, steps)
}
