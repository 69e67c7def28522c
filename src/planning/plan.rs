//! What to plan and what a plan is: the settings (axis, angle, scheme, step model, limits,
//! budgets), the sequence of commutation steps a planner chose (one row per step, with the
//! orientation each step is predicted to settle to; written and read by `io::planfile`) and its
//! summary.

use crate::model::geometry::{
    distance_to_geodesic, rotation_angle, rotation_axis, CoilId, Degrees, Orientation, Pair,
    Radians, UnitVec,
};
use crate::planning::commutation::{CommutationState, PairsPerStep, StepLimits, StepModel};
use crate::planning::on_time::{self, OnTimeLimit, OnTimes};
use serde::{Deserialize, Serialize};

/// One step of a plan.
#[derive(Debug, Clone, PartialEq)]
pub struct PlanRow {
    /// The step's number: 0 for the initial commutation, then 1, 2, ...
    pub step: usize,
    /// The held pair that stays on through the step (none for step 0).
    pub pivot: Option<Pair>,
    /// The pairs switched on by this step.
    pub new: Vec<Pair>,
    /// Everything energised after the step.
    pub active: Vec<Pair>,
    /// Predicted orientation after the step (body to world).
    pub q: Orientation,
    /// The step's rotation angle about the target axis, degrees (signed).
    pub step_angle_deg: f64,
    /// The angle between the step's rotation axis and the target axis, degrees.
    pub step_axis_error_deg: f64,
    /// The rotation from row 0 to this row, its angle about the target axis, degrees
    /// (tracked continuously past 180).
    pub cum_angle_deg: f64,
    /// The axis error of the rotation from row 0 to this row, degrees.
    pub cum_axis_error_deg: f64,
    /// Predicted settle time of the step, s: the time until the ball stays within
    /// `settle.arrival_deg` of where it comes to rest (the settle's arrival time; t_max where it
    /// does not settle). A step's dwell is this times `relay.dwell_factor`.
    pub settle_time_s: f64,
    /// Whether the step settles in the dynamics within t_max: a pivot plan's steps are the
    /// geometry's, and one of them may not settle (its settle time is then t_max, not a settle
    /// time). Plan files written before the column read as settled.
    pub settled: bool,
}

impl PlanRow {
    /// This row replayed: its coils held for its dwell under `limit`, added to `on` (see
    /// [`on_time::hold`]).
    pub fn hold(&self, on: &mut OnTimes<CoilId>, limit: &OnTimeLimit) {
        on_time::hold(
            on,
            self.active.iter().map(|p| p.coil),
            self.step,
            limit.dwell(self.settle_time_s),
        );
    }

    /// The commutation state the row leaves the ball in: its orientation, what is on and the
    /// settle time of the move into it.
    pub fn state(&self) -> CommutationState {
        CommutationState {
            q: self.q,
            active: self.active.clone(),
            settle_time_s: self.settle_time_s,
        }
    }
}

/// The dynamic search's default budget, in settles.
pub const DEFAULT_SETTLE_BUDGET: usize = 10_000;

/// The dynamic search's default stall ([`PlanSettings::stall_settles`]): never (a search runs
/// to its budget). A stall of 3,000 settles spends a fifth fewer settles on the 500-axis sweep
/// for a worst axis error 5% worse (docs/speed.md, "Tenth round"): the default keeps the
/// plans' quality, and a scenario that wants the speed says so.
pub const DEFAULT_STALL_SETTLES: usize = usize::MAX;

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
    /// Every scheme, in the order the messages list them.
    pub const ALL: [Scheme; 4] = [
        Scheme::MinAxisError,
        Scheme::MaxAngle,
        Scheme::Weighted,
        Scheme::Search,
    ];

    /// The scheme's name as a scenario and `--scheme` write it (`min-axis-error`, `max-angle`,
    /// `weighted`, `search`).
    pub fn name(self) -> &'static str {
        match self {
            Scheme::MinAxisError => "min-axis-error",
            Scheme::MaxAngle => "max-angle",
            Scheme::Weighted => "weighted",
            Scheme::Search => "search",
        }
    }

    /// The scheme named exactly `s` (see [`Scheme::name`]), or `None`.
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
/// A plan's progress is the angle of the cumulative rotation R_k R_0^T about the axis, tracked
/// continuously along the steps (a plan that turns on past 180 degrees reads 185, not -175:
/// [`crate::planning::commutation::cumulative_from`]); but a turn of more than 180 degrees
/// about an axis ends where one of less than 180 about the opposite axis does, and at 360 the
/// cumulative rotation has no axis to measure an error against.
pub const MAX_TARGET_DEG: f64 = 180.0;

/// A target angle given in degrees, checked to lie in (0, [`MAX_TARGET_DEG`]], or what was
/// expected instead (with the reason, and how to plan a longer turn: moves, each starting where
/// the last one ended, `start` naming where a move's start is given).
pub fn target_angle(deg: f64, start: &str) -> std::result::Result<Radians, String> {
    if deg.is_finite() && deg > 0.0 && deg <= MAX_TARGET_DEG {
        Ok(Degrees(deg).to_radians())
    } else {
        let longer = match deg.is_finite() && deg > MAX_TARGET_DEG {
            true => format!(
                "; a turn of more than 180 degrees ends where a shorter one about the opposite \
                 axis does and cannot be measured as one rotation: plan it as moves of at most \
                 180 degrees, each starting ({start}) where the last one ended"
            ),
            false => String::new(),
        };
        Err(format!(
            "a target angle in (0, {MAX_TARGET_DEG}] degrees, got {}{longer}",
            crate::text::shown(deg)
        ))
    }
}

/// The axis and angle of the shortest rotation (world frame) from `start` to `to`, or what was
/// expected instead (`start` is named in the message as `start_name`).
pub fn turn_to(
    start: &Orientation,
    to: &Orientation,
    start_name: &str,
) -> Result<(UnitVec, Radians), String> {
    let turn = to * start.inverse();
    let shown = |q: &Orientation| format!("{},{},{},{}", q.i, q.j, q.k, q.w);
    let Some(axis) = rotation_axis(&turn) else {
        return Err(format!(
            "an orientation other than the start, got {} (the start is {})",
            shown(to),
            shown(start)
        ));
    };
    let angle = target_angle(rotation_angle(&turn).0.to_degrees(), start_name)?;
    Ok((axis, angle))
}

/// What to plan.
#[derive(Debug, Clone, PartialEq)]
pub struct PlanSettings {
    /// The target rotation's axis (world frame).
    pub axis: UnitVec,
    /// The target rotation's angle about `axis`.
    pub angle: Radians,
    /// How the next step is chosen.
    pub scheme: Scheme,
    /// How a step is predicted: the geometry of a pivot, or the dynamics.
    pub model: StepModel,
    /// Pairs on after each step (pivot + new ones): exactly 2 for the paper's model.
    pub pairs: PairsPerStep,
    /// Start orientation, before the initial commutation.
    pub start: Orientation,
    /// What counts as a step (smallest angle, largest axis error, ...).
    pub limits: StepLimits,
    /// Give up after this many steps.
    pub max_steps: usize,
    /// Beam width of the search planner (pivot model).
    pub beam_width: usize,
    /// The search's budget (dynamic model): settles, counted, never time.
    pub settle_budget: usize,
    /// The search settles this many of each state's best-ranked proposals (dynamic model).
    pub settles_per_state: usize,
    /// The best-first search stops once it has a plan of its own and has spent this many
    /// settles since its best plan last improved (by more than 0.01 degree); its repair's
    /// searches after a quarter as many, counted from their start. Settles, counted, never time: the plan
    /// is the same on any machine. A stall of `settle_budget` or more never stops a search.
    pub stall_settles: usize,
    /// The search counts the target angle as turned within this angle of it.
    pub angle_tolerance: Radians,
    /// The plan is reached when it ends within this angle of the target orientation
    /// ([`goal_of`]; `plan.tolerance_deg`, `--tolerance-deg`; [`DEFAULT_TOLERANCE_DEG`]).
    pub tolerance: Radians,
    /// The orientation the ball is sent to, when it was given as one (`plan --to`): `axis` and
    /// `angle` are then the shortest turn from `start` to it, the plan's final error is measured
    /// against it, and the planner plans again from where the initial commutation leaves the
    /// ball, aimed at it. `None`: the goal is the turn applied to row 0 (see [`goal_of`]).
    pub target: Option<Orientation>,
}

/// The default of [`PlanSettings::tolerance`], degrees.
pub const DEFAULT_TOLERANCE_DEG: f64 = 1.0;

/// A plan and how it ended.
#[derive(Debug, Clone)]
pub struct Plan {
    /// The steps, row 0 the initial commutation.
    pub rows: Vec<PlanRow>,
    /// Whether the plan ends within its tolerance ([`PlanSettings::tolerance`]) of the target
    /// orientation ([`goal_of`]).
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
    /// The steps after the initial commutation.
    pub steps: usize,
    /// The last row's cumulative angle, degrees.
    pub final_angle_deg: f64,
    /// The worst cumulative axis error along the plan, degrees.
    pub max_axis_error_deg: f64,
    /// Where the ball ends against where it was sent: the angle (degrees) from the last row's
    /// orientation to the plan's goal ([`goal_of`]: the target orientation when one was given,
    /// else the target rotation applied to row 0's; the goal the closed loop aims at).
    pub final_orientation_error_deg: f64,
    /// How far the plan strays from the direct way: the worst over its rows of the angle
    /// (degrees) from the row's orientation to the nearest point of the geodesic (the slerp)
    /// from row 0's orientation to the plan's goal ([`max_path_deviation_deg`]).
    pub max_path_deviation_deg: f64,
    /// See [`Plan::reached`].
    pub reached: bool,
    /// The tolerance `reached` is judged with, degrees ([`PlanSettings::tolerance`]).
    pub tolerance_deg: f64,
    /// The steps' predicted settle times added up, s.
    pub total_settle_time_s: f64,
    /// The scheme's name, as a scenario writes it.
    pub scheme: String,
    /// The step model's name, as a scenario writes it.
    pub model: String,
    /// The most pairs on after a step (see [`PlanSettings::pairs`]).
    pub pairs_per_step: usize,
    /// See [`Plan::message`].
    pub message: Option<String>,
    /// See [`Plan::settles`].
    pub settles: usize,
    /// The steps that do not settle within t_max (their settle time is t_max).
    pub unsettled_steps: Vec<usize>,
}

impl Plan {
    /// The plan's summary, with the names of the settings `s` it was planned with.
    pub fn summary(&self, s: &PlanSettings) -> PlanSummary {
        PlanSummary {
            steps: self.rows.len().saturating_sub(1),
            final_angle_deg: self.rows.last().map(|r| r.cum_angle_deg).unwrap_or(0.0),
            max_axis_error_deg: max_axis_error_deg(&self.rows),
            final_orientation_error_deg: final_orientation_error_deg(s, &self.rows),
            max_path_deviation_deg: max_path_deviation_deg(s, &self.rows),
            reached: self.reached,
            tolerance_deg: s.tolerance.0.to_degrees(),
            total_settle_time_s: total_settle_time(&self.rows),
            scheme: s.scheme.name().to_string(),
            model: s.model.name().into(),
            pairs_per_step: s.pairs.max,
            message: self.message.clone(),
            settles: self.settles,
            unsettled_steps: unsettled_steps(&self.rows),
        }
    }
}

/// The goal of a plan made for `settings`: its target orientation when it has one, else
/// ROT[axis, angle] applied to its start (row 0; `None` without rows).
pub fn goal_of(settings: &PlanSettings, rows: &[PlanRow]) -> Option<Orientation> {
    settings.target.or_else(|| {
        rows.first()
            .map(|r| crate::model::geometry::rot_q(&settings.axis, settings.angle) * r.q)
    })
}

/// The angle (degrees) from a plan's last row to its goal ([`goal_of`]; 0 for no rows).
pub fn final_orientation_error_deg(s: &PlanSettings, rows: &[PlanRow]) -> f64 {
    match (goal_of(s, rows), rows.last()) {
        (Some(goal), Some(last)) => last.q.angle_to(&goal).to_degrees(),
        _ => 0.0,
    }
}

/// The worst path deviation of a plan made for `s`, degrees (0 for no rows): over its rows, the
/// angle from the row's orientation to the nearest point of the geodesic (the slerp) from row
/// 0's orientation to the plan's goal ([`goal_of`]); see [`path_deviation_deg`].
pub fn max_path_deviation_deg(s: &PlanSettings, rows: &[PlanRow]) -> f64 {
    match (rows.first(), goal_of(s, rows)) {
        (Some(first), Some(goal)) => path_deviation_deg(rows.iter().map(|r| &r.q), &first.q, &goal),
        _ => 0.0,
    }
}

/// The worst angle (degrees) from any of the orientations `qs` to the nearest point of the
/// geodesic from `start` to `goal` (0 for none).
pub fn path_deviation_deg<'a>(
    qs: impl IntoIterator<Item = &'a Orientation>,
    start: &Orientation,
    goal: &Orientation,
) -> f64 {
    qs.into_iter()
        .map(|q| distance_to_geodesic(q, start, goal).to_degrees().0)
        .fold(0.0, f64::max)
}

/// `p` (a plan made for `s`) judged at its end: reached only when its search completed the
/// turn and it ends within `s.tolerance` of the target orientation; otherwise its message
/// says how far it ended.
pub fn judged(mut p: Plan, s: &PlanSettings) -> Plan {
    if !p.reached || p.rows.is_empty() {
        return p;
    }
    let off = final_orientation_error_deg(s, &p.rows);
    let tolerance = s.tolerance.0.to_degrees();
    if off > tolerance {
        p.reached = false;
        let before = p
            .message
            .take()
            .map(|m| format!("; {m}"))
            .unwrap_or_default();
        p.message = Some(format!(
            "target not reached: the plan ends {off:.2} deg from the target orientation, over \
             its tolerance of {tolerance:.2} deg (plan.tolerance_deg){before}"
        ));
    }
    p
}

/// The steps of a plan that do not settle within t_max.
pub fn unsettled_steps(rows: &[PlanRow]) -> Vec<usize> {
    rows.iter().filter(|r| !r.settled).map(|r| r.step).collect()
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
