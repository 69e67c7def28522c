//! spherestep: commutation, motion planning, settling and hardware replay for spherical stepper
//! motors (a ball rotor of permanent magnets turned by switching the electromagnets of a small
//! stator cap). Conventions (frames, quaternion order, units, well shapes, step models,
//! figures of merit): docs/model.md in the repository, summarised in the README.
//!
//! The modules are layers; data flows one way and no module imports a layer above its own:
//!
//! 1. [`model`]: geometry, symmetry groups and the packings of magnets and coils;
//! 2. [`physics`]: magnet torques, the integrator and the rotor's dynamics (the settle);
//! 3. [`planning`]: commutation, the planners and the simulation of a plan;
//! 4. [`relay`]: relay boards, the serial link and the timed replay of a plan;
//! 5. [`io`]: the files: scenarios (TOML), plans and results (CSV), atomic writes;
//! 6. [`figures`]: the pictures, the 3-D page and the batch report;
//! 7. [`commands`]: one function per command of the binary, and batches of scenarios.
//!
//! [`error`] is shared by all layers.

pub mod commands;
pub mod error;
pub mod figures;
pub mod io;
pub mod model;
pub mod physics;
pub mod planning;
pub mod relay;

pub use error::{Error, Result};
