//! The physics of the ball: torques of the magnet wells (`torque`, evaluated through each
//! well's fitted `profile` where it has one), the adaptive stepper
//! (`integrator`), the rotor's quaternion equations of motion and settle (`dynamics`), and the
//! physical magnets (`magnetics`: coil-loop and dipole fields, the torque of a coil on a
//! magnet and its reduction to a well; `real_parts`: magnets of finite size, windings of
//! finite cross-section and the table their well is evaluated through), and a well's torque curve as a bench would measure it
//! (`well_curve`).

pub mod dynamics;
pub mod integrator;
pub mod magnetics;
pub mod profile;
pub mod real_parts;
pub mod torque;
pub mod well_curve;
