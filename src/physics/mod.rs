//! The physics of the ball: torques of the magnet wells (`torque`, evaluated through each
//! well's fitted profile where it has one), the adaptive stepper
//! (`integrator`), the rotor's quaternion equations of motion and settle (`dynamics`), and the
//! physical magnets (`magnetics`: coil-loop and dipole fields, the torque of a coil on a
//! magnet and its reduction to a well; `real_parts`: magnets of finite size, windings of
//! finite cross-section and the table their well is evaluated through), and a well's torque
//! curve as a bench would measure it (`well_curve`).
//!
//! Entry points: [`MagnetTorques`] (rotor magnets, stator coils, one [`Well`] of a
//! [`WellShape`] and an [`Interaction`]), the [`TorqueModel`] the dynamics integrate;
//! [`settle`] and [`settle_many`] (from rest under an active set, with a [`Body`] and
//! [`SettleParams`], to a [`SettleResult`] and its [`Stop`]); [`DipoleParts`] and
//! [`RealParts`], the physical parts a [`DipoleWell`] is made of; [`well_curve::well_curve`]
//! and [`WellSummary`], a well's torque against the angle.

pub mod dynamics;
pub mod integrator;
pub mod magnetics;
mod profile;
pub mod real_parts;
pub mod torque;
pub mod well_curve;

pub use dynamics::{settle, settle_many, Body, Method, SettleParams, SettleResult, Stop};
pub use magnetics::{DipoleParts, DipoleWell};
pub use real_parts::{MagnetShape, RealParts, Winding};
pub use torque::{Interaction, MagnetTorques, TorqueModel, Well, WellShape};
pub use well_curve::WellSummary;
