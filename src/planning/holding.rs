//! Which pairs of a settled set hold the ball (their magnet within its coil's reach where the
//! ball came to rest) and what the settle came to: what `settle` reports on the command line
//! and in Python.

use crate::model::geometry::{Orientation, Pair};
use crate::physics::torque::MagnetTorques;
use crate::planning::commutation::pair_gap;

/// The pairs of a set that hold the ball, and those out of reach.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Holding {
    /// The pairs whose magnet is within the well's reach of its coil, in the set's order.
    pub held: Vec<Pair>,
    /// The pairs whose magnet is beyond that reach, in the set's order.
    pub not_held: Vec<Pair>,
}

impl Holding {
    /// The pairs of `active` that hold the ball at `q` (their magnet within the well's reach of
    /// its coil) under `torques`.
    pub fn of(torques: &MagnetTorques, active: &[Pair], q: &Orientation) -> Holding {
        let reach = torques.well.max_attraction().0;
        let r = q.to_rotation_matrix();
        let (held, not_held) = active
            .iter()
            .partition(|&&p| pair_gap(torques, &r, p).0 <= reach);
        Holding { held, not_held }
    }

    /// What a settle that `settled` (or not) came to: `held` (every pair holding), `partly
    /// held` (some pairs out of reach), `unheld` (no pair holding: the ball was left alone) or
    /// `not settled`.
    pub fn outcome(&self, settled: bool) -> &'static str {
        match (settled, self.held.is_empty(), self.not_held.is_empty()) {
            (false, _, _) => "not settled",
            (true, _, true) => "held",
            (true, true, false) => "unheld",
            (true, false, false) => "partly held",
        }
    }
}
