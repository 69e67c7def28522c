//! A virtual motor to rehearse the hardware path without hardware (`spherestep virtual`):
//! relay boards and an orientation sensor played on pseudo-terminals, byte for byte as the
//! real devices answer, driving a ball that moves under the plant's equations of motion in
//! real time, with the hardware limits watched and faults injected on request. The entry point
//! is `live::run` (with the `hardware` feature, on Unix), given the [`Options`] and returning
//! a [`Summary`]; the emulators below it can be fed bytes directly.
//!
//! - [`boards`]: the four relay protocols' far end (frames parsed, replies, relays held);
//! - [`sensor`]: the quat-csv lines and the BNO055's register protocol;
//! - [`plant`]: the ball, integrated as the coils switch;
//! - `live` (with the `hardware` feature, on Unix): the pseudo-terminals, their threads, the
//!   clock, the limits, the log and the summary.
//!
//! A layer above `relay` and `sensor` (whose frames and constants it answers) and below the
//! files: it reads nothing; the command gives it the plant's parts.

pub mod boards;
#[cfg(all(feature = "hardware", unix))]
pub mod live;
pub mod plant;
pub mod sensor;

use crate::model::geometry::{CoilId, Orientation, Radians};
use crate::relay::{BoardKind, Slot};
use crate::sensor::SensorFormat;
use serde::Serialize;
use std::collections::BTreeMap;
use std::path::PathBuf;
use std::time::Duration;

/// At most this many violations are kept (each with its time); the rest are counted.
pub const MAX_VIOLATIONS: usize = 100;

/// One board of the virtual motor.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct BoardSetup {
    /// The board's type: the protocol it answers.
    pub kind: BoardKind,
    /// Its relay count.
    pub channels: u16,
    /// Its Modbus slave address (the other types ignore it).
    pub slave_address: u8,
}

/// The faults to inject.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Faults {
    /// The board the board faults act on (`drop_after_frames`, `silent_after_frames`).
    pub board: usize,
    /// That board's port vanishes after this many frames (its relays lose power).
    pub drop_after_frames: Option<usize>,
    /// That board stops answering after this many frames, its port open: it reads and drops
    /// every later frame, its relays hold as they were (a hung board).
    pub silent_after_frames: Option<usize>,
    /// The sensor goes silent after this many readings.
    pub sensor_stall_after: Option<usize>,
    /// This fraction of the sensor's readings are corrupted (seeded), 0 to 1.
    pub sensor_garble: f64,
    /// This relay never closes (stuck open): commanded on, it reads back off.
    pub stuck_relay: Option<Slot>,
}

/// Everything the virtual motor needs.
#[derive(Debug, Clone)]
pub struct Options {
    /// The boards, in `[[relay.boards]]` order (one with the single-board form).
    pub boards: Vec<BoardSetup>,
    /// Board and channel of each coil (the plant's coil map, inverted).
    pub coil_of: BTreeMap<Slot, CoilId>,
    /// The most coils on at once before a violation is recorded (the supply).
    pub max_coils_on: usize,
    /// One coil's longest continuous on-time before a violation is recorded (heat).
    pub max_on_time: Duration,
    /// The ball at its start.
    pub ball: plant::Ball,
    /// The sensor's protocol, quat-csv lines or the BNO055's registers (`None`: no sensor port).
    pub sensor: Option<SensorFormat>,
    /// The standard deviation of the sensor's noise, radians.
    pub sensor_noise: Radians,
    /// The seed of the sensor's noise and of its garbled readings.
    pub seed: u64,
    /// The virtual clock runs this many times as fast as the wall clock.
    pub speed: f64,
    /// The sensor's mounting: it reports the ball's orientation times this.
    pub mount: Orientation,
    /// A directory where each pseudo-terminal gets a stable link (`board0`, ..., `sensor`).
    pub link_dir: Option<PathBuf>,
    /// A CSV log of every frame, reading and violation, by virtual time.
    pub log: Option<PathBuf>,
    /// The faults to inject.
    pub faults: Faults,
    /// Stop after this long (wall clock) whatever happens.
    pub max_seconds: Option<Duration>,
}

/// What a rehearsal saw.
#[derive(Debug, Clone, Serialize)]
pub struct Summary {
    /// The pseudo-terminals made, boards first, then the sensor.
    #[cfg(all(feature = "hardware", unix))]
    pub ports: Vec<live::PortInfo>,
    /// What ended the rehearsal, in words (a signal, its time limit, the replaying side closing its
    /// ports).
    pub ended_by: String,
    /// The virtual clock at the end, s.
    pub virtual_time_s: f64,
    /// Frames received, per board.
    pub frames: Vec<usize>,
    /// Frames not understood, all boards together.
    pub unknown_frames: usize,
    /// Sensor readings sent.
    pub sensor_readings: usize,
    /// Of them, the ones garbled on purpose (`Faults::sensor_garble`).
    pub garbled_readings: usize,
    /// The most relays closed at once, all boards together.
    pub most_relays_on: usize,
    /// Relays closed at the end (`board:channel`) and the coils they drive.
    pub relays_on_at_end: Vec<String>,
    /// The coils those relays drive.
    pub coils_on_at_end: Vec<usize>,
    /// The ball at the end: qx, qy, qz, qw.
    pub final_orientation: [f64; 4],
    /// The first violations of the limits (coils on at once, on-time, relays on at the end), each
    /// with its virtual time (at most [`MAX_VIOLATIONS`]).
    pub violations: Vec<String>,
    /// All violations, counted.
    pub violations_total: usize,
    /// The log written, if any.
    pub log: Option<PathBuf>,
    /// Writing the log failed (it was given up): why.
    pub log_error: Option<String>,
}

impl Summary {
    /// The summary as text, a line each.
    pub fn text(&self) -> String {
        let mut s = format!(
            "virtual motor ended by {} after {:.3} s (virtual clock)\n",
            self.ended_by, self.virtual_time_s
        );
        let frames: Vec<String> = (self.frames.iter().enumerate())
            .map(|(k, n)| format!("board {k}: {n}"))
            .collect();
        // both sensors send the quaternion w first, as the devices do; the ball below is x,y,z,w
        let order = match self.sensor_readings {
            0 => "",
            _ => "; each w,x,y,z, as the device sends it",
        };
        s.push_str(&format!(
            "frames received: {}; not understood: {}; sensor readings: {} ({} garbled{order}); most relays on at once: {}\n",
            frames.join(", "),
            self.unknown_frames,
            self.sensor_readings,
            self.garbled_readings,
            self.most_relays_on
        ));
        let [x, y, z, w] = self.final_orientation;
        s.push_str(&format!(
            "ball at the end: qx,qy,qz,qw = {x:.6},{y:.6},{z:.6},{w:.6}\n"
        ));
        match self.relays_on_at_end.is_empty() {
            true => s.push_str("every relay off at the end\n"),
            false => s.push_str(&format!(
                "RELAYS STILL ON at the end: {}\n",
                self.relays_on_at_end.join(", ")
            )),
        }
        match self.violations_total {
            0 => s.push_str("no violation\n"),
            n => {
                s.push_str(&format!("{n} violation(s):\n"));
                for v in &self.violations {
                    s.push_str(&format!("  {v}\n"));
                }
                if n > self.violations.len() {
                    s.push_str(&format!("  ... and {} more\n", n - self.violations.len()));
                }
            }
        }
        if let Some(e) = &self.log_error {
            s.push_str(&format!("writing the log failed: {e}\n"));
        }
        s
    }
}

/// Why the virtual motor could not run.
#[derive(Debug, thiserror::Error)]
pub enum RehearseError {
    /// A pseudo-terminal could not be made: the operating system's reason.
    #[error("cannot open a pseudo-terminal: {0}")]
    Pty(String),
    /// The link directory (`Options::link_dir`), or a link in it, could not be made.
    #[error("the link directory {}: {reason}", path.display())]
    LinkDir {
        /// The directory, or the link.
        path: PathBuf,
        /// The operating system's reason.
        reason: String,
    },
    /// The log (`Options::log`) could not be opened or written.
    #[error("the virtual motor's log {}: {reason}", path.display())]
    Log {
        /// The log file.
        path: PathBuf,
        /// The operating system's reason.
        reason: String,
    },
}

#[cfg(test)]
mod tests {
    use super::*;

    fn summary(readings: usize) -> Summary {
        Summary {
            #[cfg(all(feature = "hardware", unix))]
            ports: Vec::new(),
            ended_by: "a test".into(),
            virtual_time_s: 1.5,
            frames: vec![3],
            unknown_frames: 0,
            sensor_readings: readings,
            garbled_readings: 0,
            most_relays_on: 2,
            relays_on_at_end: Vec::new(),
            coils_on_at_end: Vec::new(),
            final_orientation: [0.1, 0.2, 0.3, 0.9],
            violations: Vec::new(),
            violations_total: 0,
            log: None,
            log_error: None,
        }
    }

    #[test]
    fn the_summary_says_the_sensors_order_and_writes_the_ball_x_first() {
        let with = summary(12).text();
        assert!(
            with.contains("sensor readings: 12 (0 garbled; each w,x,y,z, as the device sends it)"),
            "{with}"
        );
        assert!(with.contains("ball at the end: qx,qy,qz,qw = 0.100000,0.200000,0.300000,0.900000"));
        let without = summary(0).text();
        assert!(
            without.contains("sensor readings: 0 (0 garbled);"),
            "{without}"
        );
    }
}
