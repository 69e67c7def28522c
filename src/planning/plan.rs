//! A plan: the sequence of commutation steps a planner chose, one row per step, with the
//! orientation each step is predicted to settle to. Written and read by `io::planfile`.

use crate::model::geometry::{Orientation, Pair};

/// One step of a plan.
#[derive(Debug, Clone, PartialEq)]
pub struct PlanRow {
    pub step: usize,
    /// The held pair that stays on through the step (none for step 0).
    pub pivot: Option<Pair>,
    /// The pairs switched on by this step.
    pub new: Vec<Pair>,
    /// Everything energised after the step.
    pub active: Vec<Pair>,
    /// Predicted orientation after the step (body to world).
    pub q: Orientation,
    pub step_angle_deg: f64,
    pub step_axis_error_deg: f64,
    pub cum_angle_deg: f64,
    pub cum_axis_error_deg: f64,
    /// Predicted settle time of the step, s.
    pub settle_time_s: f64,
}
