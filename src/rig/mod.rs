//! The rig: the hardware closed loop, above the relay boards (`relay`), the orientation
//! sensors (`sensor`) and the planners' closed loop (`planning::closed_loop`). Its
//! [`execute_closed`] plays a prepared replay on the boards as the closed loop's
//! [`Plant`](crate::planning::closed_loop::Plant): after each step's dwell the sensor is read
//! and the controller decides, under the runner's watch of every coil deadline and of signals.
//! The relay layer below knows boards, links, the schedule and the open-loop replay only; the
//! loop's own errors and the sensor's arrive as [`RigError`].

mod closed;
mod error;

pub use closed::{execute_closed, refuse_options, ClosedSummary, Sensing};
pub use error::RigError;
