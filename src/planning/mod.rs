//! From settled equilibria to plans: which coil:magnet pairs to switch (`commutation`) or which
//! sets of coils (`coilsets`), the searches that chain steps towards a target rotation
//! (`search`, shared by every step model) and the planner that sets them going (`planner`) into
//! a `plan`, the replay of a plan through the dynamics (`simulate`), the closed loop that
//! replans from measured orientations (`closed_loop`), motions through waypoints (`waypoints`)
//! and how long a replay keeps each coil on (`on_time`, shared with the hardware replay's
//! check).

pub mod cancel;
pub mod closed_loop;
pub mod coilsets;
pub mod commutation;
pub mod fit;
pub mod holding;
pub mod identify;
mod landing;
mod motor;
pub mod on_time;
pub mod options;
pub mod plan;
pub mod planner;
pub mod search;
pub mod seek;
pub mod simulate;
pub mod waypoints;
