//! Open-loop check of a plan (paper section 4.2's "slop", made measurable): replays the plan's
//! coil sequence through the dynamic model of a scenario (any well shape, "coils" interaction
//! allowed) and reports, per step, how far the simulated ball is from the plan's prediction.

use crate::model::geometry::Orientation;
use crate::physics::dynamics::settle;
use crate::planning::commutation::Motor;
use crate::planning::plan::PlanRow;
use serde::Serialize;

/// One replayed step.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct SimRow {
    /// The plan row's step.
    pub step: usize,
    /// Where the ball settled (body to world).
    #[serde(skip)]
    pub q: Orientation,
    /// Angle between the simulated and the predicted orientation, degrees.
    pub deviation_deg: f64,
    /// Whether the ball settled within the settle's time limit.
    pub settled: bool,
    /// How long the settle took, s.
    pub settle_time_s: f64,
}

/// Summary of a replay.
#[derive(Debug, Clone, Serialize)]
pub struct SimSummary {
    /// The plan's steps replayed after row 0 (the rows less one).
    pub steps: usize,
    /// The largest angle between a simulated and a predicted orientation, degrees.
    pub max_deviation_deg: f64,
    /// That angle after the last step, degrees.
    pub final_deviation_deg: f64,
    /// The rows whose settle did not come to rest within the settle's time limit (row 0 included).
    pub unsettled_steps: usize,
}

/// Replays `rows` on `motor`: starts at rest at row 0's predicted orientation, settles under
/// each row's active set in turn from where the previous one left the ball. The rows' indices
/// must be the motor's (the caller checks them against its scenario).
pub fn simulate(motor: &Motor, rows: &[PlanRow]) -> Vec<SimRow> {
    let mut q = match rows.first() {
        Some(r) => r.q,
        None => return Vec::new(),
    };
    let mut out = Vec::with_capacity(rows.len());
    for r in rows {
        let res = settle(&motor.torques, &r.active, &q, motor.body, motor.settle);
        q = res.q;
        out.push(SimRow {
            step: r.step,
            q,
            deviation_deg: q.angle_to(&r.q).to_degrees(),
            settled: res.settled,
            settle_time_s: res.arrival_time_s,
        });
    }
    out
}

/// Summarises a replay.
pub fn summary(rows: &[SimRow]) -> SimSummary {
    SimSummary {
        steps: rows.len().saturating_sub(1),
        max_deviation_deg: rows.iter().map(|r| r.deviation_deg).fold(0.0, f64::max),
        final_deviation_deg: rows.last().map(|r| r.deviation_deg).unwrap_or(0.0),
        unsettled_steps: rows.iter().filter(|r| !r.settled).count(),
    }
}
