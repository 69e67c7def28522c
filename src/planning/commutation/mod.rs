//! Commutation (paper sections 3.2 and 4.1, MODEL.md "Commutation"): the initial commutation
//! state, the distance array of candidate pairs, the two filter tests of the paper's Figure 4
//! with their widening error bound, and the two step models that say where a candidate step
//! leaves the ball: `pivot` (geometric, the held pair as stationary point) and `dynamic` (the
//! candidate set settled by the engine). The planner chooses among the steps made here.

use crate::model::geometry::{
    angular_distance, axis_error, rot_q, signed_angle_about, CoilId, MagnetId, Orientation, Pair,
    Radians, SurelyBeyond, UnitVec,
};
use crate::physics::dynamics::{settle_many, Body, SettleParams};
use crate::physics::torque::{MagnetTorques, Well};
use crate::planning::cancel::Cancel;
use crate::planning::on_time::OnTimeLimit;
use nalgebra::{Rotation3, UnitQuaternion, Vector3};
use rayon::prelude::*;
use serde::{Deserialize, Serialize};

mod predict;

pub use predict::{predicted_in_wells, predicted_orientation, FirstWeighing};

/// How a candidate step's outcome is predicted.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum StepModel {
    /// Paper 3.2: two pairs; the pivot stays put and the rotor turns about the pivot coil's axis
    /// until the candidate magnet is as close to its coil as it gets.
    Pivot,
    /// Paper 3.4: the pivot and the new pairs settled by the dynamics engine.
    Dynamic,
    /// The hardware's view (docs/model.md, item 5): a step switches a set of 2..=K coils;
    /// every energised coil pulls what the interaction says it pulls, and where the ball
    /// settles is the step's result (`planning::coilsets`).
    Coils,
}

impl StepModel {
    /// Every step model, in the order their names are listed to users.
    pub const ALL: [StepModel; 3] = [StepModel::Pivot, StepModel::Dynamic, StepModel::Coils];

    /// The model's name in scenarios, on the command line and in result files.
    pub fn name(self) -> &'static str {
        match self {
            StepModel::Pivot => "pivot",
            StepModel::Dynamic => "dynamic",
            StepModel::Coils => "coils",
        }
    }

    /// The model of a name written by [`StepModel::name`].
    pub fn from_name(name: &str) -> Option<StepModel> {
        StepModel::ALL.into_iter().find(|m| m.name() == name)
    }

    /// What a step of the model switches: "pairs" or "coils" (for messages).
    pub fn unit(self) -> &'static str {
        match self {
            StepModel::Coils => "coils",
            _ => "pairs",
        }
    }
}

/// The pull, relative to the well's peak pull, above which a coil holding one magnet aligned
/// also pulls its nearest neighbour as a second magnet (see [`pair_model_describes`]).
pub const SECOND_MAGNET_PULL: f64 = 0.5;

/// Whether the pair model describes a motor's physics: not when every energised coil pulls
/// every magnet in reach (`interaction = "coils"`), nor when the wells are broad enough that
/// one coil reaches two magnets, i.e. a coil holding a magnet aligned pulls the magnet's
/// nearest neighbour (at the rotor's smallest separation) with at least [`SECOND_MAGNET_PULL`]
/// of the well's peak pull. The prototype's gaussian wells (sigma 10 degrees, magnets 23.1
/// degrees apart) pull the neighbour with 0.26 of the peak: pairs; sigma 14 gives 0.70 and a
/// cosine well reaching 40 degrees 0.61: coil sets.
pub fn pair_model_describes(torques: &MagnetTorques) -> bool {
    if torques.interaction == crate::physics::torque::Interaction::Coils {
        return false;
    }
    let well = &torques.well;
    let peak = well.g(peak_pull_distance(well).0);
    let separation = rotor_separation(&torques.rotor);
    !(peak > 0.0 && well.g(separation.0) >= SECOND_MAGNET_PULL * peak)
}

/// The step model a scenario plans with when none is asked for: the dynamic pair model where
/// the pair model describes the physics ([`pair_model_describes`]), coil sets elsewhere.
pub fn default_step_model(torques: &MagnetTorques) -> StepModel {
    if pair_model_describes(torques) {
        StepModel::Dynamic
    } else {
        StepModel::Coils
    }
}

/// The smallest angular distance between two magnets of a rotor (pi for fewer than two), in
/// about n log n ([`crate::model::packing::min_separation`]).
fn rotor_separation(rotor: &[Vector3<f64>]) -> Radians {
    let points: Vec<UnitVec> = rotor.iter().map(|a| UnitVec::new_normalize(*a)).collect();
    crate::model::packing::min_separation(&points)
}

/// How many pairs are on after a step: the pivot kept from the held set plus `min - 1` to
/// `max - 1` new pairs. The pivot model takes exactly two; the dynamic model any of 2..=8.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct PairsPerStep {
    /// The fewest pairs on after a step, the pivot included.
    pub min: usize,
    /// The most pairs on after a step, the pivot included.
    pub max: usize,
}

impl PairsPerStep {
    /// The most pairs a scenario may ask for.
    pub const LIMIT: usize = 8;

    /// Exactly `k` pairs after every step.
    pub fn exactly(k: usize) -> Self {
        PairsPerStep { min: k, max: k }
    }

    /// Any of 2..=k pairs, chosen per step.
    pub fn up_to(k: usize) -> Self {
        PairsPerStep {
            min: 2.min(k),
            max: k,
        }
    }

    /// Whether every step has the same number of pairs.
    pub fn is_exact(self) -> bool {
        self.min == self.max
    }
}

impl std::fmt::Display for PairsPerStep {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        if self.is_exact() {
            write!(f, "{}", self.max)
        } else {
            write!(f, "{}-{}", self.min, self.max)
        }
    }
}

/// Everything a commutation step needs to know about the motor: its own copy of a scenario's
/// torques, body and settle parameters ([`crate::Scenario::motor`]), so that it outlives the
/// scenario and moves between threads.
#[derive(Debug, Clone)]
pub struct Motor {
    /// The torque model: magnets, coils, the pair well and the interaction.
    pub torques: MagnetTorques,
    /// The rotor's inertia and damping.
    pub body: Body,
    /// How a settle is integrated and when it counts as settled.
    pub settle: SettleParams,
    /// Set from another thread to abandon the planning in progress (see
    /// [`crate::planning::cancel`]); [`Cancel::never`] everywhere but the hardware loop.
    pub cancel: Cancel,
}

impl Motor {
    /// The settle that weighs candidate sets: the motor's, except that a set that does not hold
    /// the ball is not followed to where it would stop ([`Stop::Unheld`]): it is no candidate
    /// anyway, and a set that holds settles exactly as `simulate` settles it.
    ///
    /// [`Stop::Unheld`]: crate::physics::dynamics::Stop::Unheld
    pub fn weighing(&self) -> SettleParams {
        SettleParams {
            follow_unheld: false,
            ..self.settle
        }
    }
}

/// The ball's commutation state: its orientation and what holds it there.
#[derive(Debug, Clone, PartialEq)]
pub struct CommutationState {
    /// The ball's orientation (body to world).
    pub q: Orientation,
    /// The coil:magnet pairs energised.
    pub active: Vec<Pair>,
    /// Predicted settle time of the move into this state (the settle's arrival time), s (0
    /// for the geometric model).
    pub settle_time_s: f64,
}

/// Weighs candidate sets from `from` in parallel: the state each settles to, `None` for a set
/// that does not hold the ball (see [`Motor::weighing`]).
pub fn settled_states(
    motor: &Motor,
    sets: Vec<Vec<Pair>>,
    from: &Orientation,
) -> Vec<Option<CommutationState>> {
    if motor.cancel.is_cancelled() {
        return vec![None; sets.len()];
    }
    settle_many(&motor.torques, &sets, from, motor.body, motor.weighing())
        .into_iter()
        .zip(sets)
        .map(|(r, active)| {
            r.settled.then_some(CommutationState {
                q: r.q,
                active,
                settle_time_s: r.arrival_time_s,
            })
        })
        .collect()
}

/// A candidate pair from the distance array.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Candidate {
    /// The coil and the magnet.
    pub pair: Pair,
    /// D_ij, the angular distance of the magnet from the coil.
    pub distance: Radians,
    /// How far the pair is from passing the two filter tests exactly (the larger deviation).
    pub deviation: Radians,
}

/// A step: from a state, keep `pivot` (a pair step; a coil-set step keeps no pair in
/// particular), switch `new` on, and end at `to`.
#[derive(Debug, Clone, PartialEq)]
pub struct Step {
    /// The pair held through the step (`None`: a coil-set step).
    pub pivot: Option<Pair>,
    /// The pairs switched on.
    pub new: Vec<Pair>,
    /// The state the step ends in: the set on and where it leaves the ball.
    pub to: CommutationState,
    /// Rotation of the step about the desired axis (signed), rad.
    pub angle: Radians,
    /// Angle between the step's rotation axis and the desired axis, rad.
    pub axis_error: Radians,
}

/// The starting error bound of the filter: pi/24.
pub const ERROR_BOUND_START: Radians = Radians(std::f64::consts::PI / 24.0);

/// Step 1: the distance array. Every (coil, magnet) with the magnet in the bottom hemisphere
/// (world z < 0) and within the maximum attraction distance, in (coil, magnet) order.
pub fn distance_array(torques: &MagnetTorques, q: &Orientation) -> Vec<(Pair, Radians)> {
    let r = q.to_rotation_matrix();
    let dmax = torques.well.max_attraction().0;
    let mut out = Vec::new();
    let world: Vec<Vector3<f64>> = torques.rotor.iter().map(|m| r * m).collect();
    let far = SurelyBeyond::new(Radians(dmax));
    for (i, s) in torques.stator.iter().enumerate() {
        let s = UnitVec::new_unchecked(*s);
        for (j, p) in world.iter().enumerate() {
            if p.z >= 0.0 || far.apart(p, &s) {
                continue;
            }
            let d = angular_distance(&UnitVec::new_unchecked(*p), &s);
            if d.0 <= dmax {
                out.push((Pair::new(i, j), d));
            }
        }
    }
    out
}

/// The deviations of a pair from the two tests of the paper's Figure 4, for desired axis `n`:
/// (1) the angle between the torque direction r x s and n; (2) how far the attraction vector
/// s - r is from perpendicular to the torque arm r - (r . n) n.
pub fn filter_deviations(r: &Vector3<f64>, s: &Vector3<f64>, n: &UnitVec) -> (Radians, Radians) {
    let t = r.cross(s);
    let dev1 = if t.norm() < 1e-12 {
        std::f64::consts::PI
    } else {
        angular_distance(&UnitVec::new_normalize(t), n).0
    };
    let arm = r - n.into_inner() * r.dot(n);
    let pull = s - r;
    let dev2 = if arm.norm() < 1e-12 || pull.norm() < 1e-12 {
        std::f64::consts::PI
    } else {
        let c = (pull.dot(&arm) / (pull.norm() * arm.norm())).clamp(-1.0, 1.0);
        (c.acos() - std::f64::consts::FRAC_PI_2).abs()
    };
    (Radians(dev1), Radians(dev2))
}

/// Step 2: the pairs that pass both filter tests within the error bound, the bound starting at
/// `start` and doubling until something is left (or it exceeds pi). Pairs on a coil or magnet
/// in `exclude` are no candidates. Returns the candidates and the bound that let them through.
pub fn filter_candidates(
    torques: &MagnetTorques,
    q: &Orientation,
    n: &UnitVec,
    exclude: &[Pair],
    start: Radians,
) -> (Vec<Candidate>, Radians) {
    let all = scored_candidates(torques, q, n, exclude);
    let mut bound = start.0;
    loop {
        let kept: Vec<Candidate> = all
            .iter()
            .filter(|c| c.deviation.0 <= bound)
            .copied()
            .collect();
        if !kept.is_empty() || bound > std::f64::consts::PI {
            return (kept, Radians(bound));
        }
        bound *= 2.0;
    }
}

/// Every pair of the distance array not on an excluded coil or magnet, with its filter
/// deviation, sorted by deviation (then by pair).
pub fn scored_candidates(
    torques: &MagnetTorques,
    q: &Orientation,
    n: &UnitVec,
    exclude: &[Pair],
) -> Vec<Candidate> {
    let r = q.to_rotation_matrix();
    let mut all: Vec<Candidate> = distance_array(torques, q)
        .into_iter()
        .filter(|(p, _)| {
            !exclude
                .iter()
                .any(|e| e.coil == p.coil || e.magnet == p.magnet)
        })
        .map(|(p, d)| {
            let rv = r * torques.rotor[p.magnet.0];
            let (d1, d2) = filter_deviations(&rv, &torques.stator[p.coil.0], n);
            Candidate {
                pair: p,
                distance: d,
                deviation: Radians(d1.0.max(d2.0)),
            }
        })
        .collect();
    all.sort_by(|a, b| {
        a.deviation
            .0
            .total_cmp(&b.deviation.0)
            .then(a.pair.cmp(&b.pair))
    });
    all
}

/// The pivot model: the rotation about the pivot coil's axis `a` that brings the magnet at
/// world position `p` as close as it gets to the coil at `s`.
pub fn pivot_rotation(a: &UnitVec, p: &Vector3<f64>, s: &Vector3<f64>) -> Orientation {
    let av = a.into_inner();
    let par = av * p.dot(&av);
    let perp = p - par;
    // s . p(phi) = const + cos(phi) s.perp + sin(phi) s.(a x p)
    let phi = s.dot(&av.cross(p)).atan2(s.dot(&perp));
    rot_q(a, Radians(phi))
}

/// Rotation of a step, ΔR = R_new R^T, as its signed angle about `n` and its axis error.
pub fn step_measure(from: &Orientation, to: &Orientation, n: &UnitVec) -> (Radians, Radians) {
    let d = to * from.inverse();
    (signed_angle_about(&d, n), axis_error(&d, n))
}

/// Limits on what counts as a step.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct StepLimits {
    /// Steps turning less than this about the desired axis do not advance.
    pub min_angle: Radians,
    /// Steps whose axis is further than this from the desired axis are discarded.
    pub max_axis_error: Radians,
    /// The filter's starting error bound.
    pub bound_start: Radians,
    /// With k >= 3 pairs per step, combinations are drawn from this many best candidates.
    pub max_candidates: usize,
    /// The search planner weighs every candidate within this bound (the greedy schemes use
    /// the paper's bound, starting at `bound_start`): it can afford to look at more.
    pub search_bound: Radians,
    /// A pair counts as holding only when its magnet ends within this distance of its coil:
    /// steps that leave an active pair further out are discarded (the "certain error" of the
    /// paper's section 2.1, within the peak of the coil's attraction). `None`: the model's own,
    /// see [`StepLimits::capture_for`].
    pub capture: Option<Radians>,
    /// The most coils on at once, while a step switches (the held and the new set together):
    /// what the supply can power.
    pub max_coils_on: usize,
    /// How long a coil may stay on when the plan is replayed, with the replay's dwells: a step
    /// that would keep a coil on past it is not taken. `None`: no limit.
    pub on_time: Option<OnTimeLimit>,
}

/// The prototype's supply (24 V, 100 W) powers four coils at once (about 1 A, 25 W each).
pub const DEFAULT_MAX_COILS_ON: usize = 4;

/// The pivot model's capture distance: its geometric prediction holds only while the magnets
/// stay near their coils.
pub const PIVOT_CAPTURE: Radians = Radians(6.0 * std::f64::consts::PI / 180.0);

impl StepLimits {
    /// These limits for a landing step (towards a goal orientation, after the turn): it may
    /// turn any way towards the goal, by any angle.
    pub fn landing(&self) -> StepLimits {
        StepLimits {
            max_axis_error: Radians(std::f64::consts::PI),
            min_angle: Radians(0.0),
            ..*self
        }
    }

    /// The capture distance in force: the one given; else [`PIVOT_CAPTURE`] for the pivot
    /// model, and for the dynamic model the distance at which the well's pull peaks
    /// ([`peak_pull_distance`]): nearer in, the pull grows as the magnet is pushed out, so the
    /// pair holds; further out it weakens, and a push takes the magnet away. For the coil-set
    /// model, the maximum attraction distance: every coil on pulls the magnet nearest it (what
    /// holds the ball is the settle's own finding, a strict minimum of every coil's pull
    /// together, not one magnet near one coil).
    pub fn capture_for(&self, model: StepModel, well: &Well) -> Radians {
        match (self.capture, model) {
            (Some(c), _) => c,
            (None, StepModel::Pivot) => PIVOT_CAPTURE,
            (None, StepModel::Dynamic) => peak_pull_distance(well),
            (None, StepModel::Coils) => well.max_attraction(),
        }
    }
}

/// The distance from its coil at which a well pulls a magnet hardest (the largest g(d) up to
/// the maximum attraction distance, on a grid of 0.01 degrees; the nearest such distance):
/// sigma for a gaussian well, the cut-off for a cosine well of less than 90 degrees.
pub fn peak_pull_distance(well: &Well) -> Radians {
    let step = 0.01f64.to_radians();
    let n = (well.max_attraction().0 / step).floor() as usize;
    let (mut best_d, mut best_g) = (0.0, well.g(0.0));
    for k in 1..=n {
        let d = k as f64 * step;
        let g = well.g(d);
        if g > best_g {
            (best_d, best_g) = (d, g);
        }
    }
    Radians(best_d)
}

impl Default for StepLimits {
    fn default() -> Self {
        StepLimits {
            min_angle: Radians(0.2f64.to_radians()),
            max_axis_error: Radians(75f64.to_radians()),
            bound_start: ERROR_BOUND_START,
            max_candidates: 16,
            search_bound: Radians(70f64.to_radians()),
            capture: None,
            max_coils_on: DEFAULT_MAX_COILS_ON,
            on_time: Some(OnTimeLimit::default()),
        }
    }
}

/// Step 3: every admissible step from `state` towards rotation about `n`: each held pair as the
/// pivot with each candidate (pivot model), or with each combination of `pairs - 1` candidates
/// (dynamic model, settled in parallel). Steps that do not advance, whose axis error is too
/// large, or that do not settle are discarded. Deterministic order.
pub fn candidate_steps(
    motor: &Motor,
    state: &CommutationState,
    n: &UnitVec,
    model: StepModel,
    pairs: PairsPerStep,
    limits: &StepLimits,
) -> Vec<Step> {
    let scored = scored_by_pivot(motor, state, n);
    // The paper's step 3, carried through the evaluation: while no candidate gives an
    // admissible step, widen the bound (doubling) and weigh the pairs it lets in.
    let mut low = -1.0;
    let mut bound = limits.bound_start.0;
    loop {
        let proposals = proposals_between(&scored, low, bound, pairs, state, limits);
        let steps = evaluate_proposals(motor, state, n, model, proposals, limits);
        if !steps.is_empty() || bound > std::f64::consts::PI {
            return steps;
        }
        low = bound;
        bound *= 2.0;
    }
}

/// For each held pair as the pivot, the scored candidates that could join it.
fn scored_by_pivot(
    motor: &Motor,
    state: &CommutationState,
    n: &UnitVec,
) -> Vec<(Pair, Vec<Candidate>)> {
    // every pair scored once, each pivot's candidates then those on neither its coil nor its
    // magnet: what scored_candidates gives with the pivot excluded, in the same order (the
    // sort's key, deviation then pair, is a total order), where scoring every pair again for
    // each pivot took 2.6% of a plan's instructions
    let all = scored_candidates(&motor.torques, &state.q, n, &[]);
    state
        .active
        .iter()
        .map(|pivot| {
            let joins = |c: &&Candidate| c.pair.coil != pivot.coil && c.pair.magnet != pivot.magnet;
            (*pivot, all.iter().filter(joins).copied().collect())
        })
        .collect()
}

/// A proposal: keep `pivot`, switch `new` on (and every other held pair off).
pub type Proposal = (Pair, Vec<Pair>);

/// Every proposal from `state` whose candidates pass the filter within `bound` (with the
/// dynamic model's combinations of up to `pairs.max - 1` of the `limits.max_candidates` best
/// candidates of each pivot) and that the supply can switch ([`fits_supply`]), in a
/// deterministic order.
pub fn proposals_within(
    motor: &Motor,
    state: &CommutationState,
    n: &UnitVec,
    pairs: PairsPerStep,
    bound: Radians,
    limits: &StepLimits,
) -> Vec<Proposal> {
    let scored = scored_by_pivot(motor, state, n);
    proposals_between(&scored, -1.0, bound.0, pairs, state, limits)
}

/// Whether switching `new` on while `held` is on (make before break) keeps at most
/// `max_coils_on` coils on: a step switches its new coils on before the held ones go off, so
/// for a moment the coils of both sets are on together.
pub fn fits_supply(held: &[Pair], new: &[Pair], max_coils_on: usize) -> bool {
    // The distinct coils counted without allocating (a coil counts where it first appears):
    // the sets are a few pairs, and the planners ask this of every proposal and every
    // combination the landing weighs (on the stack up to 16 pairs, by plain loops: the
    // chained iterators this replaced took 3% of a plan's instructions)
    const INLINE: usize = 16;
    let n = held.len() + new.len();
    if n > INLINE {
        let all = || held.iter().chain(new).map(|p| p.coil);
        let distinct = all()
            .enumerate()
            .filter(|&(i, c)| all().take(i).all(|d| d != c))
            .count();
        return distinct <= max_coils_on;
    }
    let mut coils = [CoilId(0); INLINE];
    for (slot, p) in coils.iter_mut().zip(held.iter().chain(new)) {
        *slot = p.coil;
    }
    let coils = &coils[..n];
    let mut distinct = 0;
    for i in 0..n {
        if !coils[..i].contains(&coils[i]) {
            distinct += 1;
        }
    }
    distinct <= max_coils_on
}

/// The (pivot, new pairs) proposals whose candidates lie within `bound`, leaving out those
/// already weighed at `low` (all their candidates within it), and those whose step the supply
/// cannot switch from `state` ([`fits_supply`] with `limits.max_coils_on`; the dynamic model's
/// combinations of up to `pairs.max - 1` of the `limits.max_candidates` best candidates of each
/// pivot), in a deterministic order. The combinations are visited in one index buffer and a
/// proposal is allocated only where it is kept (a `Vec` for every combination, most of them
/// then dropped, took 7% of a plan's instructions).
fn proposals_between(
    scored: &[(Pair, Vec<Candidate>)],
    low: f64,
    bound: f64,
    pairs: PairsPerStep,
    state: &CommutationState,
    limits: &StepLimits,
) -> Vec<Proposal> {
    // fits_supply with the held coils counted once: they and the new coils not among them
    let mut held: Vec<CoilId> = Vec::new();
    for p in &state.active {
        if !held.contains(&p.coil) {
            held.push(p.coil);
        }
    }
    let fits = |new: &[Pair]| {
        let fresh = new.iter().enumerate().filter(|&(i, p)| {
            !held.contains(&p.coil) && !new[..i].iter().any(|o| o.coil == p.coil)
        });
        held.len() + fresh.count() <= limits.max_coils_on
    };
    // each pivot's proposals in parallel, collected in order: the same on any number of threads
    scored
        .par_iter()
        .flat_map_iter(|(pivot, all)| {
            let mut proposals = Vec::new();
            let mut set: Vec<Pair> = Vec::new();
            let cands: Vec<&Candidate> = all.iter().filter(|c| c.deviation.0 <= bound).collect();
            for extra in pairs.min.saturating_sub(1).max(1)..=pairs.max.saturating_sub(1).max(1) {
                if extra == 1 {
                    for c in cands.iter().filter(|c| c.deviation.0 > low) {
                        if fits(&[c.pair]) {
                            proposals.push((*pivot, vec![c.pair]));
                        }
                    }
                    continue;
                }
                let cands = &cands[..cands.len().min(limits.max_candidates)];
                each_subset(cands.len(), extra, |combo| {
                    if combo.iter().all(|&k| cands[k].deviation.0 <= low) {
                        return;
                    }
                    set.clear();
                    set.extend(combo.iter().map(|&k| cands[k].pair));
                    let distinct = set.iter().enumerate().all(|(k, p)| {
                        set[..k]
                            .iter()
                            .all(|o| o.coil != p.coil && o.magnet != p.magnet)
                    });
                    if distinct && fits(&set) {
                        proposals.push((*pivot, set.clone()));
                    }
                });
            }
            proposals
        })
        .collect()
}

/// Step 3's evaluation: where each proposal leaves the ball, keeping the admissible steps
/// (public for planners that rank proposals before they weigh them).
pub fn evaluate_proposals(
    motor: &Motor,
    state: &CommutationState,
    n: &UnitVec,
    model: StepModel,
    proposals: Vec<Proposal>,
    limits: &StepLimits,
) -> Vec<Step> {
    let outcomes: Vec<Option<CommutationState>> = match model {
        StepModel::Pivot => proposals
            .iter()
            .map(|(pivot, new)| Some(pivot_step(&motor.torques, &state.q, *pivot, new[0])))
            .collect(),
        StepModel::Dynamic | StepModel::Coils => {
            let sets: Vec<Vec<Pair>> = proposals
                .iter()
                .map(|(p, new)| {
                    let mut s = vec![*p];
                    s.extend_from_slice(new);
                    s
                })
                .collect();
            settled_states(motor, sets, &state.q)
        }
    };
    let capture = limits.capture_for(model, &motor.torques.well);
    proposals
        .into_iter()
        .zip(outcomes)
        .filter_map(|((pivot, new), to)| {
            admissible(&motor.torques, &state.q, to?, n, limits, capture).map(|(to, angle, err)| {
                Step {
                    pivot: Some(pivot),
                    new,
                    to,
                    angle,
                    axis_error: err,
                }
            })
        })
        .collect()
}

/// Whether the state a step from `from` settles to is admissible: every active pair holding
/// (within `capture`), the step advancing about `n` by at least the limits' minimum angle and
/// its axis within their largest error. Gives the state back with the step's angle and axis
/// error.
pub fn admissible(
    torques: &MagnetTorques,
    from: &Orientation,
    to: CommutationState,
    n: &UnitVec,
    limits: &StepLimits,
    capture: Radians,
) -> Option<(CommutationState, Radians, Radians)> {
    if !holds(torques, &to, capture) {
        return None;
    }
    let (angle, err) = step_measure(from, &to.q, n);
    (angle.0 >= limits.min_angle.0 && err.0 <= limits.max_axis_error.0).then_some((to, angle, err))
}

/// The angle between a pair's magnet, turned by `r` (an orientation's rotation matrix), and its
/// coil.
pub fn pair_gap(torques: &MagnetTorques, r: &Rotation3<f64>, p: Pair) -> Radians {
    let m = UnitVec::new_normalize(r * torques.rotor[p.magnet.0]);
    let s = UnitVec::new_normalize(torques.stator[p.coil.0]);
    angular_distance(&m, &s)
}

/// Whether every active pair of a state has its magnet within `capture` of its coil.
pub fn holds(torques: &MagnetTorques, state: &CommutationState, capture: Radians) -> bool {
    let r = state.q.to_rotation_matrix();
    state
        .active
        .iter()
        .all(|&p| pair_gap(torques, &r, p).0 <= capture.0)
}

/// The pivot model's step: turn about the pivot coil's axis until the candidate magnet is as
/// close to its coil as it gets.
pub fn pivot_step(
    torques: &MagnetTorques,
    q: &Orientation,
    pivot: Pair,
    cand: Pair,
) -> CommutationState {
    let a = UnitVec::new_normalize(torques.stator[pivot.coil.0]);
    let p = q * torques.rotor[cand.magnet.0];
    let d = pivot_rotation(&a, &p, &torques.stator[cand.coil.0]);
    CommutationState {
        q: d * q,
        active: vec![pivot, cand],
        settle_time_s: 0.0,
    }
}

/// Visits every k-subset of 0..n in lexicographic order (the order of [`combinations`]), in
/// one buffer.
pub(crate) fn each_subset(n: usize, k: usize, mut visit: impl FnMut(&[usize])) {
    if k == 0 || k > n {
        return;
    }
    let mut idx: Vec<usize> = (0..k).collect();
    loop {
        visit(&idx);
        let mut i = k;
        while i > 0 && idx[i - 1] == n - k + i - 1 {
            i -= 1;
        }
        if i == 0 {
            return;
        }
        idx[i - 1] += 1;
        for j in i..k {
            idx[j] = idx[j - 1] + 1;
        }
    }
}

/// All k-subsets of 0..n in lexicographic order.
pub(crate) fn combinations(n: usize, k: usize) -> Vec<Vec<usize>> {
    let mut out = Vec::new();
    each_subset(n, k, |c| out.push(c.to_vec()));
    out
}

/// The coil nearest to -Z (the paper's coil on the axis).
pub fn bottom_coil(torques: &MagnetTorques) -> CoilId {
    let k = torques
        .stator
        .iter()
        .enumerate()
        .min_by(|a, b| a.1.z.total_cmp(&b.1.z).then(a.0.cmp(&b.0)))
        .map(|(k, _)| k)
        .unwrap_or(0);
    CoilId(k)
}

/// The magnet nearest to a coil at orientation `q`.
pub fn nearest_magnet(
    torques: &MagnetTorques,
    coil: CoilId,
    q: &Orientation,
) -> (MagnetId, Radians) {
    let r = q.to_rotation_matrix();
    let s = UnitVec::new_normalize(torques.stator[coil.0]);
    torques
        .rotor
        .iter()
        .enumerate()
        .map(|(j, m)| (j, angular_distance(&UnitVec::new_normalize(r * m), &s)))
        .min_by(|a, b| a.1 .0.total_cmp(&b.1 .0).then(a.0.cmp(&b.0)))
        .map(|(j, d)| (MagnetId(j), d))
        .unwrap_or((MagnetId(0), Radians(std::f64::consts::PI)))
}

/// How well a coil serves as a pivot for rotation about `n`: the angle between the coil's
/// axis line and `n` (a pivot step turns the ball about the pivot coil's axis).
pub fn pivot_error(torques: &MagnetTorques, coil: CoilId, n: &UnitVec) -> Radians {
    let s = torques.stator[coil.0];
    let c = s.dot(n).abs() / s.norm();
    Radians(c.clamp(-1.0, 1.0).acos())
}

/// The pivot model's floor for rotation about `n` (MODEL.md, "Figures of merit"): a pivot step
/// turns the ball about its pivot coil's axis, so a move's worst cumulative axis error is at
/// least the smallest angle between `n` and a coil's axis line (either sign).
pub fn pivot_floor(torques: &MagnetTorques, n: &UnitVec) -> Radians {
    (0..torques.stator.len())
        .map(|i| pivot_error(torques, CoilId(i), n))
        .min_by(|a, b| a.0.total_cmp(&b.0))
        .unwrap_or(Radians(std::f64::consts::FRAC_PI_2))
}

/// The initial commutation states (paper Figure 5), best first: the coil on -Z and its nearest
/// magnet, aligned, plus a second pair (a magnet in the bottom hemisphere within the maximum
/// attraction distance of another coil), settled by the step model. The best second pair is
/// the one whose coil is the better pivot for rotation about `n` (the coil on -Z already is the
/// pivot for axes near Z; then the pair nearest to alignment comes first). Empty when no second
/// pair is in reach. States whose pairs do not hold (see [`holds`]) are left out.
pub fn initial_states(
    motor: &Motor,
    start: &Orientation,
    model: StepModel,
    n: &UnitVec,
    capture: Radians,
) -> Vec<CommutationState> {
    let coil = bottom_coil(&motor.torques);
    let (magnet, _) = nearest_magnet(&motor.torques, coil, start);
    let first = Pair { coil, magnet };
    // Align the first pair exactly (the minimal rotation), as the ball does when it is the
    // only pair on.
    let p = start * motor.torques.rotor[magnet.0];
    let s = motor.torques.stator[coil.0];
    let align = UnitQuaternion::rotation_between(&p, &s).unwrap_or_else(UnitQuaternion::identity);
    let q1 = align * start;
    let base = pivot_error(&motor.torques, coil, n).0;
    let mut seconds: Vec<(f64, f64, Pair)> = distance_array(&motor.torques, &q1)
        .into_iter()
        .filter(|(p, _)| p.coil != coil && p.magnet != magnet)
        .map(|(p, d)| {
            let pe = pivot_error(&motor.torques, p.coil, n).0;
            // only a better pivot than the first pair counts; otherwise least motion first
            let key = if pe < base - 1e-9 { pe } else { base };
            (key, d.0, p)
        })
        .collect();
    seconds.sort_by(|a, b| {
        a.0.total_cmp(&b.0)
            .then(a.1.total_cmp(&b.1))
            .then(a.2.cmp(&b.2))
    });
    let states: Vec<Option<CommutationState>> = match model {
        StepModel::Pivot => seconds
            .iter()
            .map(|(_, _, second)| Some(pivot_step(&motor.torques, &q1, first, *second)))
            .collect(),
        StepModel::Dynamic | StepModel::Coils => {
            let sets: Vec<Vec<Pair>> = seconds.iter().map(|(_, _, p)| vec![first, *p]).collect();
            settled_states(motor, sets, start)
        }
    };
    states
        .into_iter()
        .flatten()
        .filter(|st| holds(&motor.torques, st, capture))
        .collect()
}

/// Angle of the cumulative rotation R_k R_0^T (signed about `n`, in (-pi, pi]) and its axis
/// error.
pub fn cumulative(q0: &Orientation, qk: &Orientation, n: &UnitVec) -> (Radians, Radians) {
    step_measure(q0, qk, n)
}

/// The cumulative rotation R_k R_0^T of a motion whose cumulative angle about `n` was `before`
/// (rad) one step earlier, tracked continuously along the steps: its angle is the one of the
/// rotation's angles about `n` (the signed angle of [`cumulative`] plus a multiple of 2 pi)
/// nearest `before`, so that a motion turning on past 180 degrees reads 185, not -175 (a step
/// turns the cumulative angle by at most its own angle, under 180 degrees). Its axis error is
/// measured against the axis the rotation turns positively about at that angle: unchanged
/// where the angle is [`cumulative`]'s, else, when the sign changes, pi minus it (a turn of 185
/// degrees about n is one of 175 about -n).
pub fn cumulative_from(
    q0: &Orientation,
    qk: &Orientation,
    n: &UnitVec,
    before: f64,
) -> (Radians, Radians) {
    let (a, e) = cumulative(q0, qk, n);
    let tau = std::f64::consts::TAU;
    let m = ((before - a.0) / tau).round();
    if m == 0.0 || !m.is_finite() {
        return (a, e);
    }
    let c = a.0 + tau * m;
    let e = if (a.0 >= 0.0) == (c >= 0.0) {
        e.0
    } else {
        std::f64::consts::PI - e.0
    };
    (Radians(c), Radians(e))
}

/// The rotation axis of a step's rotation ΔR (`None` for no rotation).
pub fn rotation_axis_of_step(d: &Orientation) -> Option<UnitVec> {
    crate::model::geometry::rotation_axis(d)
}

#[cfg(test)]
mod tests {
    use super::predict::{wahba_closed_form, wahba_svd};
    use super::*;
    use crate::model::geometry::{rotation_angle, unit};

    fn well(shape: crate::physics::torque::WellShape, max_deg: f64) -> Well {
        Well::new(shape, Radians(max_deg.to_radians()))
    }

    #[test]
    fn the_pull_peaks_at_sigma_for_a_gaussian_well_and_at_the_cut_off_for_a_cosine_one() {
        use crate::physics::torque::WellShape;
        let g = well(
            WellShape::Gaussian {
                strength_j: 0.25,
                width: Radians(10f64.to_radians()),
            },
            30.0,
        );
        assert!((peak_pull_distance(&g).0.to_degrees() - 10.0).abs() < 0.011);
        let c = well(WellShape::Cosine { strength_j: 0.25 }, 40.0);
        assert!((peak_pull_distance(&c).0.to_degrees() - 40.0).abs() < 0.011);
        // the capture in force: given, else the model's
        let mut l = StepLimits::default();
        assert_eq!(l.capture_for(StepModel::Pivot, &g), PIVOT_CAPTURE);
        assert_eq!(
            l.capture_for(StepModel::Dynamic, &g),
            peak_pull_distance(&g)
        );
        l.capture = Some(Radians(0.1));
        assert_eq!(l.capture_for(StepModel::Dynamic, &g), Radians(0.1));
    }

    #[test]
    fn the_first_weighing_from_cached_terms_has_the_bits_of_the_prediction_in_the_wells() {
        let sc = crate::io::scenario::Scenario::prototype();
        let t = &sc.torques;
        let q = rot_q(&unit(Vector3::new(0.3, -0.5, 0.8)).unwrap(), Radians(0.7));
        let r = q.to_rotation_matrix();
        // the pairs within 30 degrees at q, and a few beyond every well's reach (no pull)
        let reach = t.well.max_attraction().0;
        let all: Vec<Pair> = (0..t.stator.len())
            .flat_map(|c| (0..t.rotor.len()).map(move |m| (c, m)))
            .map(|(c, m)| Pair {
                coil: CoilId(c),
                magnet: MagnetId(m),
            })
            .collect();
        let mut pairs: Vec<Pair> = (all.iter().copied())
            .filter(|p| pair_gap(t, &r, *p).0 < 30f64.to_radians())
            .collect();
        let near = pairs.len();
        pairs.extend(
            (all.iter().copied())
                .filter(|p| pair_gap(t, &r, *p).0 > reach + 0.1)
                .take(4),
        );
        assert!(
            near >= 6 && pairs.len() == near + 4,
            "{near} {}",
            pairs.len()
        );
        let first = FirstWeighing::new(t, &q, &pairs);
        let bits = |o: &Orientation| o.coords.map(f64::to_bits);
        let mut checked = 0;
        for i in 0..pairs.len() {
            for j in 0..pairs.len() {
                for k in [i, (i + j + 1) % pairs.len()] {
                    let idx = [i, j, k];
                    let set: Vec<Pair> = idx.iter().map(|&x| pairs[x]).collect();
                    let want = predicted_in_wells(t, &q, &set, &q, 1);
                    assert_eq!(bits(&first.predicted(&idx)), bits(&want), "{set:?}");
                    checked += 1;
                }
            }
        }
        // the sets of far pairs alone pull nowhere: the unweighted springs decide
        let far: Vec<usize> = (near..pairs.len()).collect();
        let set: Vec<Pair> = far.iter().map(|&x| pairs[x]).collect();
        let springs = predicted_orientation(t, &q, &set);
        assert_eq!(bits(&first.predicted(&far)), bits(&springs));
        assert!(springs.angle_to(&q) > 1e-6);
        assert!(checked > 100);
    }

    #[test]
    fn the_prediction_finds_the_rotation_that_puts_every_magnet_on_its_coil() {
        use crate::physics::torque::{Interaction, WellShape};
        // three coils, and magnets placed so that one rotation puts each on its coil
        let stator = vec![
            Vector3::new(0.0, 0.0, -1.0),
            Vector3::new(0.3, 0.1, -0.9).normalize(),
            Vector3::new(-0.2, 0.35, -0.9).normalize(),
        ];
        let truth = rot_q(&unit(Vector3::new(0.3, -1.0, 0.2)).unwrap(), Radians(0.25));
        let rotor: Vec<Vector3<f64>> = stator.iter().map(|s| truth.inverse() * s).collect();
        let torques = MagnetTorques {
            rotor,
            stator,
            well: well(WellShape::Cosine { strength_j: 0.1 }, 40.0),
            interaction: Interaction::Pairs,
        };
        let q = UnitQuaternion::identity();
        for set in [
            vec![Pair::new(0, 0), Pair::new(1, 1)],
            vec![Pair::new(0, 0), Pair::new(1, 1), Pair::new(2, 2)],
        ] {
            let p = predicted_orientation(&torques, &q, &set);
            assert!(
                p.angle_to(&truth) < 1e-12,
                "{set:?}: {}",
                p.angle_to(&truth)
            );
        }
        // from a start that is itself turned, the prediction composes with it
        let start = rot_q(&unit(Vector3::z()).unwrap(), Radians(0.1));
        let p = predicted_orientation(
            &torques,
            &start,
            &[Pair::new(0, 0), Pair::new(1, 1), Pair::new(2, 2)],
        );
        assert!(p.angle_to(&truth) < 1e-12);
    }

    #[test]
    fn the_closed_form_agrees_with_the_svd_and_leaves_it_the_double_roots() {
        // a fixed pseudo-random sequence in [-1, 1)
        let mut seed = 0x2545_f491_4f6c_dd1d_u64;
        let mut next = || {
            seed ^= seed << 13;
            seed ^= seed >> 7;
            seed ^= seed << 17;
            (seed >> 11) as f64 / (1u64 << 52) as f64 - 1.0
        };
        let (mut worst, mut compared): (f64, usize) = (0.0, 0);
        for case in 0..2000 {
            let n = 2 + case % 4;
            let turn = rot_q(
                &unit(Vector3::new(next(), next(), next())).unwrap(),
                Radians(std::f64::consts::PI * (next() + 1.0) / 2.0),
            );
            let mut b = nalgebra::Matrix3::zeros();
            let mut total = 0.0;
            for _ in 0..n {
                let a = Vector3::new(next(), next(), next()).normalize();
                let noise = 0.3 * (case % 3) as f64;
                let c = (turn * a + noise * Vector3::new(next(), next(), next())).normalize();
                let w = next() + 1.5;
                b += w * c * a.transpose();
                total += w;
            }
            let (Some(fast), Some(svd)) = (wahba_closed_form(&b, total), wahba_svd(&b)) else {
                continue;
            };
            worst = worst.max(fast.angle_to(&svd));
            compared += 1;
        }
        assert!(
            compared > 1900,
            "the closed form answered {compared} of 2000"
        );
        assert!(worst < 1e-8, "closed form against SVD: {worst} rad");
        // one pair: every turn about the coil leaves the magnet on it, a double root
        let a = Vector3::new(0.0, 0.6, 0.8);
        let c = Vector3::new(0.0, 0.0, 1.0);
        assert!(wahba_closed_form(&(c * a.transpose()), 1.0).is_none());
    }

    #[test]
    fn the_supply_counts_each_coil_once_however_many_pairs() {
        let pair = |c: usize, m: usize| Pair::new(c, m);
        let held = [pair(0, 1), pair(1, 2), pair(2, 3)];
        // one new coil, one coil already held (another magnet): 4 coils on at once
        let new = [pair(3, 4), pair(1, 5)];
        assert!(fits_supply(&held, &new, 4));
        assert!(!fits_supply(&held, &new, 3));
        // beyond the stack buffer: 20 pairs on 10 coils
        let many: Vec<Pair> = (0..20).map(|i| pair(i % 10, i)).collect();
        assert!(fits_supply(&many[..10], &many[10..], 10));
        assert!(!fits_supply(&many[..10], &many[10..], 9));
        assert!(fits_supply(&[], &[], 0));
    }

    #[test]
    fn combinations_are_complete_and_ordered() {
        let c = combinations(4, 2);
        assert_eq!(
            c,
            vec![
                vec![0, 1],
                vec![0, 2],
                vec![0, 3],
                vec![1, 2],
                vec![1, 3],
                vec![2, 3]
            ]
        );
        assert_eq!(combinations(5, 3).len(), 10);
        assert!(combinations(2, 3).is_empty());
    }

    #[test]
    fn pivot_rotation_brings_the_magnet_closest() {
        let a = unit(Vector3::new(0.0, 0.0, -1.0)).unwrap();
        let p = Vector3::new(0.5f64.sin(), 0.0, -0.5f64.cos());
        let s = Vector3::new(0.0, 0.4f64.sin(), -0.4f64.cos());
        let q = pivot_rotation(&a, &p, &s);
        let best = (q * p).dot(&s);
        for k in -50..50 {
            let other = rot_q(&a, Radians(k as f64 * 0.05)) * p;
            assert!(other.dot(&s) <= best + 1e-12);
        }
        // p turns about -Z by 90 degrees (from the X-Z plane into the Y-Z plane)
        assert!((rotation_angle(&q).0 - std::f64::consts::FRAC_PI_2).abs() < 1e-12);
    }
}
