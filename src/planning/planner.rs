//! Motion planning (paper section 3.2 and 4.1): sequences of commutation steps that turn the
//! ball by a target angle about a desired axis. A consumer of settled equilibria: it chooses
//! among the steps that `commutation` (pairs) and `coilsets` (coil sets) predict and never
//! integrates anything itself. The settings, the plan and its summary, and the pair models as a
//! step source for the searches of `search` (the paper's three greedy schemes, a beam search
//! and a best-first branch and bound).

use crate::model::geometry::{Degrees, Orientation, Radians, UnitVec};
use crate::planning::coilsets::CoilSets;
use crate::planning::commutation::{
    candidate_steps, evaluate_proposals, initial_states, predicted_orientation, proposals_within,
    CommutationState, Motor, PairsPerStep, Proposal, Step, StepLimits, StepModel, PIVOT_CAPTURE,
};
use crate::planning::plan::PlanRow;
use crate::planning::search::{self, predicted_rank, wide_limits, Frontier, StepSource};
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
    /// The settles the best-first search spent on its expansions (what its budget counts;
    /// the greedy seeds and the initial states are not counted); 0 for the other searches.
    pub settles: usize,
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
    /// See [`Plan::settles`].
    pub settles: usize,
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
            settles: self.settles,
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

/// Plans a motion, with the settings' step model.
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
    match s.model {
        StepModel::Coils => search::run(&CoilSets::new(motor, s), s),
        StepModel::Pivot | StepModel::Dynamic => search::run(&PairSteps { motor, s }, s),
    }
}

/// The pair models (pivot and dynamic) as a step source: each step keeps one held pair and
/// switches on new ones that pass the paper's filter.
struct PairSteps<'a> {
    motor: &'a Motor<'a>,
    /// The settings, with the capture resolved.
    s: &'a PlanSettings,
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
}

/// The proposals from a partial plan's state that the search settles: all that pass the filter
/// within the search bound, ranked by the rank their cheap prediction
/// ([`predicted_orientation`]) would give the plan, the `settles_per_state` best.
fn ranked_proposals(motor: &Motor, s: &PlanSettings, at: &Frontier) -> Vec<Proposal> {
    let bound = wide_limits(&s.limits).bound_start;
    let ranked: Vec<(f64, Proposal)> =
        proposals_within(motor, at.state, &s.axis, s.pairs, bound, &s.limits)
            .into_iter()
            .filter_map(|(pivot, new)| {
                let mut set = vec![pivot];
                set.extend_from_slice(&new);
                let qp = predicted_orientation(motor.torques, &at.state.q, &set);
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

/// Which of the ranked proposals (rank, proposal; smaller ranks first, ties by proposal) are
/// weighed, best first: every one of size `all_up_to` or less, and of each larger size the
/// `per_size` best.
pub fn weighed<T: Ord>(
    mut ranked: Vec<(f64, T)>,
    size: impl Fn(&T) -> usize,
    all_up_to: usize,
    per_size: usize,
) -> Vec<T> {
    ranked.sort_by(|a, b| a.0.total_cmp(&b.0).then_with(|| a.1.cmp(&b.1)));
    let mut taken = std::collections::BTreeMap::new();
    ranked
        .into_iter()
        .filter(|(_, p)| {
            let k = size(p);
            if k <= all_up_to {
                return true;
            }
            let t = taken.entry(k).or_insert(0usize);
            *t += 1;
            *t <= per_size
        })
        .map(|(_, p)| p)
        .collect()
}
