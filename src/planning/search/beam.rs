//! The beam search (the pivot model's): the best partial plans of each depth expanded together,
//! in parallel, the paper's greedy plans as the solutions to beat.

use super::*;

/// How many parents the beam search expands at once (in parallel).
const EXPAND_CHUNK: usize = 64;

/// Beam search: keeps the `beam_width` best partial plans at each depth (best = smallest worst
/// cumulative axis error, with a credit for progress), expanding them all in parallel; a plan
/// that reaches the target is a solution, and partial plans already as bad as the best solution
/// are pruned (the worst error never falls along a path). The paper's greedy plans are
/// candidates too, so the search is never worse than them.
pub(super) fn search(src: &dyn StepSource, s: &PlanSettings, roots: Vec<Node>) -> Plan {
    let Some(root) = roots.first().cloned() else {
        return no_initial_state();
    };
    let mut best = greedy_best(src, s, &root, better_solution);
    let mut beam = roots;
    let mut deepest = root;
    for _depth in 0..s.max_steps {
        if beam.is_empty() {
            break;
        }
        // Expanded a chunk of parents at a time, the running beam cut back to its width
        // after each: the same beam as expanding all at once (children meet the best in the
        // same order, and a node outside the best `width` of a part is outside them in the
        // whole), in memory bounded by the chunk, not by the parents (the pivot model's initial
        // states, all of them parents: 5268 on a rotor of 20,000 magnets, 11 million children).
        let mut next: Vec<Node> = Vec::new();
        for chunk in beam.chunks(EXPAND_CHUNK) {
            let children: Vec<Vec<Node>> = chunk
                .par_iter()
                .map(|p| {
                    let q0 = p.rows[0].q;
                    src.steps(&p.state, true)
                        .iter()
                        .filter_map(|st| p.extend(st, &q0, s).ok())
                        .collect()
                })
                .collect();
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
            if next.len() > s.beam_width {
                next = beam_of(next, s.beam_width);
            }
        }
        let kept = beam_of(next, s.beam_width);
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

/// The beam's next generation: the partial plans in rank order (worst error less a credit for
/// progress, ties by what is on and then by the whole sequence), one per end state, at most
/// `width`.
fn beam_of(mut next: Vec<Node>, width: usize) -> Vec<Node> {
    let credit = PROGRESS_CREDIT;
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
    let mut kept: Vec<Node> = Vec::new();
    for c in next {
        let dup = kept
            .iter()
            .any(|k| k.state.active == c.state.active && k.state.q.angle_to(&c.state.q) < 1e-6);
        if !dup {
            kept.push(c);
            if kept.len() == width {
                break;
            }
        }
    }
    kept
}
