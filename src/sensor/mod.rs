//! Orientation sensors read over a serial port, to close the loop on the hardware: after each
//! step of a replay the ball's orientation is read back. One driver per sensor protocol behind
//! one trait ([`OrientationSensor`]):
//!
//! - [`quat_csv`]: a microcontroller printing one line `w,x,y,z` per reading (an Arduino with
//!   an IMU library);
//! - [`bno055`]: the Bosch BNO055 in UART mode, polled through its register protocol.
//!
//! [`frame`] maps any sensor's readings to the ball's orientation: its mounting in the ball and
//! the offset of its reference, found by a tare at the plan's start.
//!
//! Every reading is an [`Orientation`] (body to world, normalised) together with the raw bytes
//! received, for the replay's log. Every error names the sensor format and the port.
//! A driver sits on the serial layer's [`Port`] (anything `Read + Write + Send`: a serial port,
//! or a pseudo-terminal in the tests).
//!
//! Entry points: `open` (with the `hardware` feature: a device path, a [`SensorFormat`] and a
//! baud rate) and [`from_port`] (any open [`Port`]) start a driver ([`QuatCsv`], [`Bno055`] in
//! a [`FusionMode`]) as a boxed [`OrientationSensor`]; [`Tared`] maps its readings to the ball
//! through a [`Frame`]; every failure is a [`SensorError`].

pub mod bno055;
pub mod frame;
pub mod quat_csv;

pub use bno055::{Bno055, Calibration, FusionMode};
pub use frame::{Frame, Tared};
pub use quat_csv::QuatCsv;

use crate::model::geometry::Orientation;
pub use crate::planning::cancel::Cancel;
pub use crate::serial::Port;
use crate::text::printable;
use std::fmt;
use std::io::ErrorKind;
use std::str::FromStr;
use std::time::Duration;

/// How long one blocking read of a serial port opened by [`open`] waits at most (less when the
/// sensor timeout is shorter, but at least 5 ms, so that no thread spins): the drivers loop on
/// it up to their own deadline, and the quat-csv reader thread checks between reads whether it
/// should stop.
pub const POLL_INTERVAL: Duration = Duration::from_millis(50);

/// The default time to wait for a reading.
pub const DEFAULT_TIMEOUT: Duration = Duration::from_millis(500);

/// A norm of the received quaternion further than this from 1 marks the data as garbage.
pub const NORM_TOLERANCE: f64 = 0.1;

/// The supported sensor protocols.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum SensorFormat {
    /// One text line `w,x,y,z` per reading.
    QuatCsv,
    /// Bosch BNO055, UART register protocol.
    Bno055,
}

impl SensorFormat {
    /// Every supported format, in the order messages list them.
    pub const ALL: [SensorFormat; 2] = [SensorFormat::QuatCsv, SensorFormat::Bno055];

    /// The name used on the command line and in messages.
    pub fn name(self) -> &'static str {
        match self {
            SensorFormat::QuatCsv => "quat-csv",
            SensorFormat::Bno055 => "bno055",
        }
    }

    /// The usual baud rate: 115200 for both (the BNO055's fixed UART rate, datasheet 4.7; the
    /// common rate of IMU sketches).
    pub fn default_baud(self) -> u32 {
        115_200
    }
}

impl fmt::Display for SensorFormat {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

/// A sensor format name that is none of the supported ones.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("unknown sensor format '{0}': expected quat-csv or bno055")]
pub struct UnknownFormat(pub String);

impl FromStr for SensorFormat {
    type Err = UnknownFormat;
    fn from_str(s: &str) -> Result<Self, UnknownFormat> {
        SensorFormat::ALL
            .into_iter()
            .find(|k| k.name().eq_ignore_ascii_case(s.trim()))
            .ok_or_else(|| UnknownFormat(s.to_string()))
    }
}

/// What was received for one reading, as it came.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Raw {
    /// A text line, without its line end.
    Line(String),
    /// A binary reply frame, complete (header included).
    Frame(Vec<u8>),
}

impl fmt::Display for Raw {
    /// The line as text, a frame as hex pairs (`BB 08 ...`).
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Raw::Line(l) => f.write_str(l),
            Raw::Frame(b) => f.write_str(&hex(b)),
        }
    }
}

/// One orientation reading.
#[derive(Debug, Clone, PartialEq)]
pub struct Reading {
    /// Body to world, normalised; the sign is kept as the sensor sent it (q and -q are the
    /// same rotation).
    pub orientation: Orientation,
    /// The bytes it was decoded from.
    pub raw: Raw,
}

/// One orientation sensor: the interface every driver implements.
pub trait OrientationSensor: Send {
    /// A fresh reading (what "fresh" means is the driver's: see its module comment).
    fn read(&mut self) -> Result<Reading, SensorError>;
    /// The sensor and its port, for messages and the log: `quat-csv sensor on /dev/ttyACM0`.
    fn describe(&self) -> String;
    /// Whether the sensor can measure, before the closed loop starts: its calibration status,
    /// for those that report one (the BNO055: [`SensorError::Uncalibrated`] while the
    /// gyroscope is not calibrated); `None` for the others.
    fn ready(&mut self) -> Result<Option<bno055::Calibration>, SensorError> {
        Ok(None)
    }
    /// From now on a [`read`](Self::read) (and a BNO055's reply) gives up within one
    /// [`POLL_INTERVAL`] of `cancel` being set, with [`SensorError::Abandoned`].
    fn set_cancel(&mut self, cancel: Cancel);
}

/// Errors of the sensor drivers; every message starts `sensor <port> (<format>):`.
#[derive(Debug, thiserror::Error)]
pub enum SensorError {
    /// The serial port could not be opened.
    #[error("sensor {port} ({sensor}): cannot open the serial port: {message} (is the sensor plugged in, and are you in the `dialout` group?)")]
    Open {
        /// The sensor's protocol.
        sensor: SensorFormat,
        /// The port the sensor is on, as given (`/dev/ttyACM0`).
        port: String,
        /// serialport's reason.
        message: String,
    },
    /// Reading or writing the port failed.
    #[error("sensor {port} ({sensor}): {op} failed: {source}")]
    Io {
        /// The sensor's protocol.
        sensor: SensorFormat,
        /// The port the sensor is on, as given (`/dev/ttyACM0`).
        port: String,
        /// What was being done: "reading", "writing a request".
        op: &'static str,
        /// The operating system's error.
        #[source]
        source: std::io::Error,
    },
    /// The other end went away (unplugged sensor, closed pseudo-terminal).
    #[error("sensor {port} ({sensor}): the sensor end closed the connection while {op}")]
    Closed {
        /// The sensor's protocol.
        sensor: SensorFormat,
        /// The port the sensor is on, as given (`/dev/ttyACM0`).
        port: String,
        /// What was being done when it closed: "reading", "waiting for a reply".
        op: &'static str,
    },
    /// Nothing complete arrived in time.
    #[error("sensor {port} ({sensor}): no {what} within {} ms{}", timeout.as_millis(), got_suffix(got))]
    Timeout {
        /// The sensor's protocol.
        sensor: SensorFormat,
        /// The port the sensor is on, as given (`/dev/ttyACM0`).
        port: String,
        /// What was awaited: "reading", "reply to ...".
        what: String,
        /// How long it waited.
        timeout: Duration,
        /// What had arrived of it (empty: nothing).
        got: String,
    },
    /// A text line that is not a reading.
    /// (`line` is kept as it came; the message escapes its control characters.)
    #[error(
        "sensor {port} ({sensor}): garbage line '{}': {}",
        printable(line),
        printable(reason)
    )]
    Garbage {
        /// The sensor's protocol.
        sensor: SensorFormat,
        /// The port the sensor is on, as given (`/dev/ttyACM0`).
        port: String,
        /// The line, without its line end.
        line: String,
        /// Why it is not a reading.
        reason: String,
    },
    /// A binary reply the protocol does not allow, or a quaternion that is not one.
    #[error(
        "sensor {port} ({sensor}): unexpected reply {}: expected {expected}",
        hex(got)
    )]
    BadReply {
        /// The sensor's protocol.
        sensor: SensorFormat,
        /// The port the sensor is on, as given (`/dev/ttyACM0`).
        port: String,
        /// What the protocol allows there.
        expected: String,
        /// The bytes received.
        got: Vec<u8>,
    },
    /// The BNO055 answered a request with an error status (`0xEE <status>`).
    #[error("sensor {port} ({sensor}): {request} answered EE {status:02X} {} ({}){}", bno055::status_name(*status), bno055::status_meaning(*status), attempts_suffix(*attempts))]
    Status {
        /// The sensor's protocol.
        sensor: SensorFormat,
        /// The port the sensor is on, as given (`/dev/ttyACM0`).
        port: String,
        /// The request: "write OPR_MODE (0x3D) = 0x0C (NDOF)".
        request: String,
        /// The status byte after `0xEE` (datasheet 4.7: `0x07` BUS_OVER_RUN_ERROR, ...;
        /// [`bno055::status_name`]).
        status: u8,
        /// How many times the request was sent.
        attempts: u32,
    },
    /// The gyroscope is not calibrated: the orientation would drift.
    #[error("sensor {port} ({sensor}): the gyroscope is not calibrated ({calibration}): keep the ball still for a few seconds with every coil off, then start again")]
    Uncalibrated {
        /// The sensor's protocol.
        sensor: SensorFormat,
        /// The port the sensor is on, as given (`/dev/ttyACM0`).
        port: String,
        /// The calibration levels the sensor reported.
        calibration: bno055::Calibration,
    },
    /// The wait for a reading was given up from outside (the replay is switching off).
    #[error("sensor {port} ({sensor}): the wait for a reading was abandoned (everything is being switched off)")]
    Abandoned {
        /// The sensor's protocol.
        sensor: SensorFormat,
        /// The port the sensor is on, as given (`/dev/ttyACM0`).
        port: String,
    },
    /// The tare reading, taken before any coil is switched, failed.
    #[error("{cause}; it was the tare reading (the ball at rest at the plan's start), taken before any coil is switched: no coil was switched")]
    Tare {
        /// The reading's own error.
        cause: Box<SensorError>,
    },
    /// The BNO055 reports the zero quaternion: its fusion is not running (yet).
    #[error("sensor {port} ({sensor}): the quaternion is all zero: sensor fusion is not running yet (it starts shortly after a fusion mode is set; a reset returns the sensor to CONFIG mode)")]
    NotFused {
        /// The sensor's protocol.
        sensor: SensorFormat,
        /// The port the sensor is on, as given (`/dev/ttyACM0`).
        port: String,
    },
}

fn got_suffix(got: &str) -> String {
    if got.is_empty() {
        " (nothing received)".into()
    } else {
        format!(" (got {got})")
    }
}

fn attempts_suffix(attempts: u32) -> String {
    if attempts > 1 {
        format!(" after {attempts} attempts")
    } else {
        String::new()
    }
}

/// Bytes as upper-case hex pairs separated by spaces: `AA 01 20 08`.
pub use crate::serial::hex;

/// The sensor and port a driver reports its errors with.
#[derive(Debug, Clone)]
pub(crate) struct Ident {
    pub sensor: SensorFormat,
    pub port: String,
}

impl Ident {
    /// Classifies a failed read or write: the far end gone (`Closed`) or another failure.
    pub fn io_err(&self, op: &'static str, e: std::io::Error) -> SensorError {
        let closed = matches!(
            e.kind(),
            ErrorKind::BrokenPipe | ErrorKind::UnexpectedEof | ErrorKind::ConnectionReset
        ) || e.raw_os_error() == Some(5); // EIO: unplugged device, pty whose far end closed
        if closed {
            self.closed(op)
        } else {
            SensorError::Io {
                sensor: self.sensor,
                port: self.port.clone(),
                op,
                source: e,
            }
        }
    }

    pub fn closed(&self, op: &'static str) -> SensorError {
        SensorError::Closed {
            sensor: self.sensor,
            port: self.port.clone(),
            op,
        }
    }

    pub fn abandoned(&self) -> SensorError {
        SensorError::Abandoned {
            sensor: self.sensor,
            port: self.port.clone(),
        }
    }

    pub fn timeout(&self, what: impl Into<String>, timeout: Duration, got: String) -> SensorError {
        SensorError::Timeout {
            sensor: self.sensor,
            port: self.port.clone(),
            what: what.into(),
            timeout,
            got,
        }
    }
}

/// Whether a read error only means "nothing arrived yet".
pub(crate) fn is_idle(e: &std::io::Error) -> bool {
    matches!(
        e.kind(),
        ErrorKind::TimedOut | ErrorKind::WouldBlock | ErrorKind::Interrupted
    )
}

/// A quaternion whose norm is within this of 1 is a unit quaternion already, to the rounding
/// of the normalisation that made it (a few units in the last place): it is taken as it is,
/// since normalising it again would move it by that rounding (one normalised quaternion in
/// three does not have a norm of exactly 1.0 in `f64`).
pub const UNIT_ROUNDING: f64 = 4.0 * f64::EPSILON;

/// The unit quaternion from `w, x, y, z`, or why it is not one: every component finite, the
/// norm within [`NORM_TOLERANCE`] of 1. It is normalised, unless it is unit to the rounding
/// of a normalisation already ([`UNIT_ROUNDING`]): then it is kept to the bit (a reading of
/// full precision passes through unchanged).
pub fn unit_quaternion(w: f64, x: f64, y: f64, z: f64) -> Result<Orientation, String> {
    if ![w, x, y, z].iter().all(|c| c.is_finite()) {
        return Err("a component is not finite".into());
    }
    let q = nalgebra::Quaternion::new(w, x, y, z);
    let norm = q.norm();
    if (norm - 1.0).abs() > NORM_TOLERANCE {
        return Err(format!(
            "the norm {norm:.4} is not within {NORM_TOLERANCE} of 1"
        ));
    }
    if (norm - 1.0).abs() <= UNIT_ROUNDING {
        return Ok(Orientation::new_unchecked(q));
    }
    Ok(Orientation::from_quaternion(q))
}

/// Opens a serial port (8N1, no flow control) and starts the driver for `format` on it;
/// `timeout` bounds every reading (and, for the BNO055, every reply).
///
/// # Errors
///
/// [`SensorError::Open`] when the port cannot be opened; the driver's start errors (the
/// BNO055's mode setting).
#[cfg(feature = "hardware")]
pub fn open(
    format: SensorFormat,
    mode: bno055::FusionMode,
    path: &str,
    baud: u32,
    timeout: Duration,
) -> Result<Box<dyn OrientationSensor>, SensorError> {
    let poll = POLL_INTERVAL.min(timeout).max(Duration::from_millis(5));
    let port = crate::serial::open_8n1(path, baud, poll).map_err(|e| SensorError::Open {
        sensor: format,
        port: path.to_string(),
        message: e.to_string(),
    })?;
    from_port_in(format, mode, Box::new(port), path, timeout)
}

/// Starts the driver for `format` on an already open port named `name` (the BNO055's mode
/// setting happens here). With a `serialport` port, set its timeout before: a read must not
/// block for ever, and dropping a quat-csv sensor waits for one read of its thread to end.
pub fn from_port(
    format: SensorFormat,
    port: Box<dyn Port>,
    name: &str,
    timeout: Duration,
) -> Result<Box<dyn OrientationSensor>, SensorError> {
    from_port_in(format, bno055::FusionMode::Imu, port, name, timeout)
}

/// [`from_port`] with the BNO055 in fusion mode `mode` (ignored by quat-csv).
pub fn from_port_in(
    format: SensorFormat,
    mode: bno055::FusionMode,
    port: Box<dyn Port>,
    name: &str,
    timeout: Duration,
) -> Result<Box<dyn OrientationSensor>, SensorError> {
    Ok(match format {
        SensorFormat::QuatCsv => Box::new(quat_csv::QuatCsv::start(port, name, timeout)?),
        SensorFormat::Bno055 => Box::new(bno055::Bno055::start_in(port, name, timeout, mode)?),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sensor_formats_parse_and_name_the_choices() {
        assert_eq!(
            "quat-csv".parse::<SensorFormat>(),
            Ok(SensorFormat::QuatCsv)
        );
        assert_eq!(" BNO055 ".parse::<SensorFormat>(), Ok(SensorFormat::Bno055));
        let e = "mpu6050".parse::<SensorFormat>().unwrap_err();
        assert_eq!(
            e.to_string(),
            "unknown sensor format 'mpu6050': expected quat-csv or bno055"
        );
        for f in SensorFormat::ALL {
            assert_eq!(f.name().parse::<SensorFormat>(), Ok(f));
        }
    }

    #[test]
    fn sensor_unit_quaternion_normalises_and_refuses() {
        let q = unit_quaternion(1.05, 0.0, 0.0, 0.0).unwrap();
        assert!((q.w - 1.0).abs() < 1e-15);
        assert!(unit_quaternion(1.2, 0.0, 0.0, 0.0)
            .unwrap_err()
            .contains("norm 1.2000"));
        assert!(unit_quaternion(f64::NAN, 0.0, 0.0, 1.0).is_err());
        assert!(unit_quaternion(f64::INFINITY, 0.0, 0.0, 1.0).is_err());
    }

    #[test]
    fn sensor_unit_quaternion_keeps_a_normalised_one_to_the_bit() {
        // normalised quaternions, a third of which have no norm of exactly 1.0 in f64: read
        // back from their full text, each is itself (normalising again would move some)
        let mut moved = 0;
        for k in 0..300 {
            let t = f64::from(k);
            let raw = nalgebra::Quaternion::new(
                (0.7 * t).sin() + 0.1,
                (1.3 * t).cos(),
                (0.37 * t + 1.0).sin(),
                (2.1 * t).cos() * 0.5,
            );
            let q = Orientation::from_quaternion(raw);
            let text = format!("{},{},{},{}", q.w, q.i, q.j, q.k);
            let back = quat_csv::parse_line(&text).unwrap();
            assert_eq!(back, q, "{text}");
            if Orientation::from_quaternion(*q.quaternion()) != q {
                moved += 1;
            }
        }
        assert!(moved > 0, "no quaternion here that a normalisation moves");
    }

    #[test]
    fn sensor_error_messages_name_sensor_and_port() {
        let id = Ident {
            sensor: SensorFormat::QuatCsv,
            port: "/dev/ttyACM0".into(),
        };
        let e = id.timeout("reading", Duration::from_millis(500), String::new());
        assert_eq!(
            e.to_string(),
            "sensor /dev/ttyACM0 (quat-csv): no reading within 500 ms (nothing received)"
        );
        let e = id.io_err(
            "reading",
            std::io::Error::new(ErrorKind::BrokenPipe, "gone"),
        );
        assert!(matches!(e, SensorError::Closed { .. }), "{e:?}");
        assert_eq!(Raw::Frame(vec![0xBB, 0x08, 0x0A]).to_string(), "BB 08 0A");
    }
}
