//! spherestep: commutation, motion planning, settling and hardware replay for spherical stepper
//! motors (a ball rotor of permanent magnets turned by switching the electromagnets of a small
//! stator cap). Conventions (frames, quaternion order, units, well shapes, step models,
//! figures of merit): docs/model.md in the repository; the manual is the book in docs/
//! (`mdbook build docs`).
//!
//! The modules are layers; data flows one way and no module imports a layer above its own:
//!
//! 1. `model`: geometry, symmetry groups and the packings of magnets and coils;
//! 2. `physics`: magnet torques, the integrator and the rotor's dynamics (the settle);
//! 3. `planning`: commutation, the planners, the simulation of a plan and the closed loop;
//! 4. `relay`: relay boards, the serial link and the timed replay of a plan;
//!    `sensor` (the same level): orientation sensors read over a port (quat-csv, BNO055);
//!    `rehearse` (above them): the virtual motor, their far ends on pseudo-terminals driving
//!    a simulated ball;
//!    `rig` (above them and `planning`): the closed loop on the hardware, the boards switched
//!    and the sensor read as the closed loop's plant;
//! 5. `io`: the files: scenarios (TOML), plans and results (CSV), atomic writes;
//! 6. `figures`: the pictures, the 3-D page and the batch report;
//! 7. `commands`: one function per command of the binary, and batches of scenarios.
//!
//! [`error`] gathers the layers' errors into the crate's one [`Error`]; [`text`] (how messages
//! show numbers and text) is shared by all layers and imports none.
//!
//! The few types most uses need are re-exported here; the layers' modules hold the rest.
//! Plan a motion on the built-in prototype (its `[plan]` defaults: 90 degrees about Z) and
//! replay the plan through the dynamics:
//!
//! ```
//! use spherestep::{max_axis_error_deg, Scenario};
//!
//! let sc = Scenario::prototype();
//! let motor = sc.motor();
//! let p = motor.plan(&sc.plan);
//! let s = p.summary(&sc.plan);
//! assert!(max_axis_error_deg(&p.rows) < 15.0 && s.final_orientation_error_deg < 2.0);
//! // reached: it ends within plan.tolerance_deg (1 degree) of the target orientation
//! assert_eq!(p.reached, s.final_orientation_error_deg <= 1.0);
//! let sim = motor.simulate(&p.rows);
//! assert!(sim.iter().all(|s| s.deviation_deg < 1e-6));
//! ```
//!
//! Settle the ball under one active set of coil:magnet pairs:
//!
//! ```
//! use spherestep::{parse_pairs, Orientation, Scenario};
//!
//! let sc = Scenario::prototype();
//! let pairs = parse_pairs("0:14,12:26", "pairs").unwrap();
//! let r = sc.motor().settle(&pairs, &Orientation::identity());
//! assert!(r.settled && r.residual_torque_nm < sc.settle.torque_tol);
//! ```
//!
//! Features (all on by default): `cli` (the `commands` layer and the binary), `hardware`
//! (opening serial devices), `figures` (the pictures). Without them the library is the
//! physics, the planners and the files.

#![warn(missing_docs)]

// The layers' modules are public and documented: each opens with what it holds and names its
// entry points, most of them re-exported at the layer's root (`spherestep::physics::settle`);
// the few types most uses need are re-exported here as well. What only the crate uses is
// `pub(crate)` or private.
#[cfg(feature = "cli")]
pub mod commands;
pub mod error;
#[cfg(feature = "figures")]
pub mod figures;
pub mod io;
pub mod model;
pub mod physics;
pub mod planning;
pub mod rehearse;
pub mod relay;
pub mod rig;
pub mod sensor;
pub mod serial;
pub mod text;

/// The Rust blocks of the README and the book, compiled and run as doc tests (`tests/docs.rs`
/// runs their shell blocks and checks their links).
#[cfg(doctest)]
mod book {
    macro_rules! chapters {
        ($($name:ident = $path:literal;)*) => {
            $(
                #[doc = include_str!($path)]
                #[allow(dead_code)]
                struct $name;
            )*
        };
    }
    chapters! {
        Readme = "../README.md";
        Introduction = "../docs/introduction.md";
        Scenarios = "../docs/scenarios.md";
        Wells = "../docs/wells.md";
        Fit = "../docs/fit.md";
        Settle = "../docs/settle.md";
        Plan = "../docs/plan.md";
        Motions = "../docs/motions.md";
        SimulateAndRun = "../docs/simulate-and-run.md";
        Batch = "../docs/batch.md";
        Figures = "../docs/figures.md";
        View = "../docs/view.md";
        Replay = "../docs/replay.md";
        CoilMap = "../docs/coil-map.md";
        Safety = "../docs/safety.md";
        Wiring = "../docs/wiring.md";
        Rehearse = "../docs/rehearse.md";
        ClosedLoopHardware = "../docs/closed-loop-hardware.md";
        Model = "../docs/model.md";
        ScenarioFormat = "../docs/scenario-format.md";
        Architecture = "../docs/architecture.md";
        PaperFigures = "../docs/paper-figures.md";
        Sweeps = "../docs/sweeps.md";
        Basins = "../docs/basins.md";
        ClosedLoop = "../docs/closed-loop.md";
        Speed = "../docs/speed.md";
    }
}

pub use error::{Error, Result};
pub use io::pairs::parse_pairs;
pub use io::scenario::Scenario;
pub use model::geometry::{CoilId, Degrees, MagnetId, Orientation, Pair, Radians, UnitVec};
pub use physics::dynamics::{Body, SettleParams, SettleResult, Stop};
pub use physics::torque::{MagnetTorques, Well, WellShape};
pub use physics::well_curve::{WellSummary, MAX_STEP_DEG, MIN_STEP_DEG};
pub use planning::cancel::Cancel;
pub use planning::closed_loop::{
    drive, goal_of, Controller, Decision, Ending, LoopRow, LoopRun, LoopSettings, LoopSummary,
    Noise, Plant,
};
pub use planning::commutation::{CommutationState, Motor, PairsPerStep, StepLimits, StepModel};
pub use planning::plan::{
    max_path_deviation_deg, Plan, PlanRow, PlanSettings, PlanSummary, Scheme,
};
pub use planning::planner::max_axis_error_deg;
pub use planning::simulate::SimRow;
pub use planning::waypoints::{
    WaypointPlan, WaypointReached, WaypointSummary, DEFAULT_WAYPOINT_TOLERANCE_DEG,
};
