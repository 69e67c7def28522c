//! spherestep: commutation, motion planning, settling and hardware replay for spherical stepper
//! motors (a ball rotor of permanent magnets turned by switching the electromagnets of a small
//! stator cap). Conventions (frames, quaternion order, units, well shapes, step models,
//! figures of merit): docs/model.md in the repository, summarised in the README.

pub mod app;
pub mod batch;
pub mod commutation;
pub mod dynamics;
pub mod error;
pub mod geometry;
pub mod integrator;
pub mod output;
pub mod packing;
pub mod planfile;
pub mod planner;
pub mod plots;
pub mod relay;
pub mod report;
pub mod scenario;
pub mod simulate;
pub mod symmetry;
pub mod torque;
pub mod view;

pub use error::{Error, Result};
