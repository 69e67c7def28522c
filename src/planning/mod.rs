//! From settled equilibria to plans: which coil:magnet pairs to switch (`commutation`), the
//! planners that chain steps towards a target rotation (`planner`) into a `plan`, and the replay of a plan
//! through the dynamics (`simulate`).

pub mod commutation;
pub mod plan;
pub mod planner;
pub mod simulate;
