//! Hardware replay of a plan (`spherestep replay`): turns each step's active set into relay
//! switching, on one board or on several (`[[relay.boards]]`, one driver each, every coil on
//! its board and channel), in order (new coils on before released ones off, by default), waits
//! the dwell (realtime) or for Enter (step mode), and always ends with every channel of every
//! board off: at the end, on an error, on Ctrl-C/SIGTERM/SIGHUP (a flag the caller sets), and
//! when a port fails (the all-off is still sent to every other board, and every failure is
//! reported with its board and port). The limits (coils on at once, one coil's continuous
//! on-time) are checked on the whole schedule, counting the coils of all boards, before any
//! byte is sent. `--dry-run` runs the same code on links that only record, with a simulated
//! clock. `--log` writes what was sent when (and, with several boards, to which board).
//!
//! The runner owns every coil deadline (the one mechanism for the on-time guarantee): a coil
//! counts as on from the moment its frame is sent, and the runner's `Watch` holds the earliest
//! time a coil reaches its guard (its limit less [`on_time::guard_margin`]). Every wait (a dwell,
//! Enter in step mode, a board's reply or blocked write, and in a closed loop the sensor and the
//! decision) ends there: every coil is switched off (a board that did not answer last) and the
//! replay stops, saying how long the coil was on when its board's all-off went out.
//!
//! [`on_time::guard_margin`]: crate::planning::on_time::guard_margin

mod log;
mod ports;
mod runner;
mod schedule;
mod stdin;

pub use log::{check_log, LOG_HEADER, LOG_HEADER_BOARDS, LOG_SENSOR_COLUMNS};
#[cfg(feature = "hardware")]
pub use ports::open_ports;
pub use ports::{prepare, prepare_check, Drive, Prepared};
pub use runner::{execute, execute_on, Summary};
pub use schedule::{coil_check, dwell, schedule, schedule_on, Entry, Mode, Schedule, Switch};
pub use stdin::stdin_lines;

pub(crate) use log::LogKind;
pub(crate) use runner::{stdout_error, Runner, POLL};
pub(crate) use schedule::{check_on_time, entries_from, Resume};
