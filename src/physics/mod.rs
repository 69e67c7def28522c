//! The physics of the ball: torques of the magnet wells (`torque`), the adaptive stepper
//! (`integrator`) and the rotor's quaternion equations of motion and settle (`dynamics`).

pub mod dynamics;
pub mod integrator;
pub mod torque;
