//! The deterministic integration tests, one binary: each former file of `tests/` is a module
//! here (`cargo test --release --test it planner::`). Their results do not depend on the
//! machine's timing; the real-time tests on pseudo-terminals are `tests/rig/`, the book's and
//! the README's checks `tests/docs.rs` (see TESTING.md).

#[path = "../../research/basins_common.rs"]
mod basins_common;
#[path = "../common/mod.rs"]
mod common;

mod any_axis;
mod basins;
mod batch;
mod batch_files;
mod cli_errors;
mod closed_loop;
mod coilsets;
#[cfg(feature = "design")]
mod design;
mod excite;
mod fit;
mod front_door;
mod identify;
mod input_checks;
mod layers;
mod memory;
mod path_deviation;
mod physical;
mod planner;
mod plans_replay;
mod plots;
mod seek;
mod settle;
mod settle_limits;
mod settle_outcome;
mod view;
mod view_browser;
mod view_text;
mod waypoints;
mod wells;
