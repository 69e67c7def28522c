//! The Bosch BNO055 absolute orientation sensor in UART mode (PS1 high, PS0 low; 115200 bps
//! 8N1), polled through its register protocol. The sources are the Bosch Sensortec BNO055 data
//! sheet, BST-BNO055-DS000-14 (revision 1.4, June 2016), and for the meaning of the status
//! codes the application note BST-BNO055-AN012 ("UART interface"):
//!
//! - section 4.7 "UART Protocol": a register write is `AA 00 <reg> <len> <data...>`, answered
//!   `EE 01` (WRITE_SUCCESS) or `EE <status>`; a register read is `AA 01 <reg> <len>`, answered
//!   `BB <len> <data...>` or `EE <status>` (READ_FAIL and the others: [`status_name`]); at most
//!   128 bytes per request;
//! - section 3.3, tables 3-5 and 3-6: OPR_MODE (register 0x3D, page 0) selects the operating
//!   mode, CONFIGMODE = 0x00, IMU = 0x08 (accelerometer and gyroscope fusion: orientation
//!   relative to the start, no magnetometer) and NDOF = 0x0C (9 degrees of freedom fusion,
//!   the magnetometer included); switching into CONFIGMODE takes 19 ms, out of it 7 ms;
//! - section 3.10 and register 4.3.54: CALIB_STAT (0x35) holds the calibration status of the
//!   system, gyroscope, accelerometer and magnetometer, two bits each (bits 7-6, 5-4, 3-2,
//!   1-0; 0 uncalibrated, 3 fully calibrated);
//! - section 3.6.5.5, tables 3-30 and 3-31, and registers 4.3.33 to 4.3.40: the quaternion is
//!   QUA_Data_w/x/y/z at 0x20..=0x27, each a signed 16-bit value, LSB first, and
//!   1 (unit less) = 2^14 LSB.
//!
//! At start the driver sets CONFIGMODE, then the fusion mode ([`FusionMode`]: IMU unless NDOF
//! is asked for), each written once and acknowledged (the first write also makes sure the
//! sensor is there). IMU is the default because the magnetometer that NDOF fuses reads, inside
//! a ball of permanent magnets beside switching coils, the motor rather than the earth
//! (datasheet 3.3.3: the compass needs a stable field). A reading reads the 8 quaternion bytes.
//! BUS_OVER_RUN_ERROR (the sensor could not empty its receive buffer in time, usually busy with
//! the fusion) and RECEIVE_CHARACTER_TIMEOUT (a byte of the request was lost) are transient:
//! the request is sent again, [`ATTEMPTS`] times in all, [`RETRY_PAUSE`] apart; every other
//! status fails at once, by name. After a timeout or a malformed reply a late reply may still
//! arrive, so before the next request the input is drained until one read of the port finds
//! nothing (at most the sensor timeout); the same happens before the first request.
//! The quaternion all zero means the fusion is not running (yet): [`SensorError::NotFused`].

use super::{
    is_idle, unit_quaternion, Cancel, Ident, Port, Raw, Reading, SensorError, SensorFormat,
};
use std::io::{ErrorKind, Read, Write};
use std::time::{Duration, Instant};

/// Start byte of every request.
pub const START: u8 = 0xAA;
/// Request type: register write.
pub const WRITE: u8 = 0x00;
/// Request type: register read.
pub const READ: u8 = 0x01;
/// First byte of a successful read's reply.
pub const READ_SUCCESS: u8 = 0xBB;
/// First byte of an acknowledge or failure reply (followed by the status).
pub const STATUS: u8 = 0xEE;
/// The status of a successful write.
pub const WRITE_SUCCESS: u8 = 0x01;
/// The status byte of BUS_OVER_RUN_ERROR.
pub const BUS_OVER_RUN_ERROR: u8 = 0x07;
/// The status byte of RECEIVE_CHARACTER_TIMEOUT.
pub const RECEIVE_CHARACTER_TIMEOUT: u8 = 0x0A;

/// The operating mode register (page 0).
pub const OPR_MODE: u8 = 0x3D;
/// OPR_MODE value of CONFIGMODE.
pub const CONFIG_MODE: u8 = 0x00;
/// OPR_MODE value of NDOF (absolute orientation from accelerometer, gyroscope, magnetometer).
pub const NDOF_MODE: u8 = 0x0C;
/// OPR_MODE value of IMU (relative orientation from accelerometer and gyroscope).
pub const IMU_MODE: u8 = 0x08;
/// The calibration status register (page 0).
pub const CALIB_STAT: u8 = 0x35;

/// The fusion mode the sensor runs in.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum FusionMode {
    /// Accelerometer and gyroscope (OPR_MODE 0x08): no magnetometer, which the motor's own
    /// magnets and coils would disturb.
    #[default]
    Imu,
    /// Accelerometer, gyroscope and magnetometer (OPR_MODE 0x0C): absolute heading, only
    /// where the magnetic field is the earth's.
    Ndof,
}

impl FusionMode {
    /// The name on the command line and in messages.
    pub fn name(self) -> &'static str {
        match self {
            FusionMode::Imu => "imu",
            FusionMode::Ndof => "ndof",
        }
    }

    /// The OPR_MODE value.
    pub fn register_value(self) -> u8 {
        match self {
            FusionMode::Imu => IMU_MODE,
            FusionMode::Ndof => NDOF_MODE,
        }
    }
}

impl std::str::FromStr for FusionMode {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        match s.trim().to_ascii_lowercase().as_str() {
            "imu" => Ok(FusionMode::Imu),
            "ndof" => Ok(FusionMode::Ndof),
            _ => Err(format!("unknown BNO055 mode '{s}': expected imu or ndof")),
        }
    }
}

/// The calibration status CALIB_STAT reports: each 0 (uncalibrated) to 3 (fully calibrated).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Calibration {
    /// The fusion system's level (bits 7-6).
    pub system: u8,
    /// The gyroscope's level (bits 5-4): the closed loop needs it above 0.
    pub gyroscope: u8,
    /// The accelerometer's level (bits 3-2).
    pub accelerometer: u8,
    /// The magnetometer's level (bits 1-0; not used in the IMU mode).
    pub magnetometer: u8,
}

impl Calibration {
    /// From the CALIB_STAT byte.
    pub fn from_byte(b: u8) -> Calibration {
        Calibration {
            system: b >> 6,
            gyroscope: (b >> 4) & 3,
            accelerometer: (b >> 2) & 3,
            magnetometer: b & 3,
        }
    }
}

impl std::fmt::Display for Calibration {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "system {}, gyroscope {}, accelerometer {}, magnetometer {} (of 3)",
            self.system, self.gyroscope, self.accelerometer, self.magnetometer
        )
    }
}
/// The first of the 8 quaternion registers (w LSB).
pub const QUA_DATA_W_LSB: u8 = 0x20;
/// One unit of a quaternion component, in LSB (2^14).
pub const QUATERNION_LSB: f64 = 16384.0;

/// Switching time from any operating mode into CONFIGMODE (table 3-6).
pub(crate) const TO_CONFIG: Duration = Duration::from_millis(19);
/// Switching time from CONFIGMODE into any operating mode (table 3-6).
pub(crate) const FROM_CONFIG: Duration = Duration::from_millis(7);
/// How many times a request is sent at most when the sensor answers a transient status.
pub const ATTEMPTS: u32 = 4;
/// The pause before sending a request again.
pub const RETRY_PAUSE: Duration = Duration::from_millis(10);

/// The name of a status byte (section 4.7).
pub fn status_name(status: u8) -> &'static str {
    match status {
        0x01 => "WRITE_SUCCESS",
        0x02 => "READ_FAIL",
        0x03 => "WRITE_FAIL",
        0x04 => "REGMAP_INVALID_ADDRESS",
        0x05 => "REGMAP_WRITE_DISABLED",
        0x06 => "WRONG_START_BYTE",
        0x07 => "BUS_OVER_RUN_ERROR",
        0x08 => "MAX_LENGTH_ERROR",
        0x09 => "MIN_LENGTH_ERROR",
        0x0A => "RECEIVE_CHARACTER_TIMEOUT",
        _ => "an undocumented status",
    }
}

/// What a status means and what to do about it (after BST-BNO055-AN012, paraphrased).
pub fn status_meaning(status: u8) -> &'static str {
    match status {
        0x01 => "the write succeeded",
        0x02 | 0x03 => "check the wiring, the UART settings and the operating mode",
        0x04 => "the register address is not in the register map of the selected page",
        0x05 => "the register is read-only",
        0x06 => "the request did not start with 0xAA",
        0x07 => {
            "the sensor could not empty its receive buffer in time, usually busy with the fusion"
        }
        0x08 => "more than 128 bytes were asked for",
        0x09 => "a length of 0 was asked for",
        0x0A => "a byte of the request did not arrive in time",
        _ => "not in the data sheet's list",
    }
}

/// Whether sending the request again can help.
fn is_transient(status: u8) -> bool {
    status == BUS_OVER_RUN_ERROR || status == RECEIVE_CHARACTER_TIMEOUT
}

/// A register write request; `data` is at most 128 bytes (the sensor's limit, 4.7).
pub fn write_request(register: u8, data: &[u8]) -> Vec<u8> {
    debug_assert!(data.len() <= 128, "a BNO055 write takes at most 128 bytes");
    let mut r = vec![START, WRITE, register, data.len() as u8];
    r.extend_from_slice(data);
    r
}

/// A register read request for `len` bytes.
pub fn read_request(register: u8, len: u8) -> [u8; 4] {
    [START, READ, register, len]
}

/// The raw w, x, y, z of the 8 quaternion bytes (each LSB first, signed).
pub fn quaternion_raw(data: &[u8; 8]) -> [i16; 4] {
    let c = |k: usize| i16::from_le_bytes([data[2 * k], data[2 * k + 1]]);
    [c(0), c(1), c(2), c(3)]
}

/// What the reply to a request must be.
#[derive(Debug, Clone, Copy)]
enum Expect {
    /// `EE 01`.
    Ack,
    /// `BB <n>` and n data bytes.
    Data(u8),
}

impl Expect {
    fn describe(self) -> String {
        match self {
            Expect::Ack => "EE 01 (WRITE_SUCCESS) or EE <status>".into(),
            Expect::Data(n) => format!("BB {n:02X} and {n} data bytes, or EE <status>"),
        }
    }
}

/// A complete reply.
enum Reply {
    /// What was expected: the whole frame.
    Done(Vec<u8>),
    /// `EE <status>` other than the expected acknowledge.
    Status(u8),
}

/// A BNO055 on a port (see the module comment).
pub struct Bno055 {
    port: Box<dyn Port>,
    id: Ident,
    timeout: Duration,
    /// Bytes of an abandoned reply may still come: drain before the next request.
    drain: bool,
    cancel: Cancel,
    mode: FusionMode,
}

impl Bno055 {
    /// Sets CONFIGMODE then IMU on the sensor behind `port`; `timeout` bounds every reply.
    pub fn start(port: Box<dyn Port>, name: &str, timeout: Duration) -> Result<Self, SensorError> {
        Bno055::start_in(port, name, timeout, FusionMode::Imu)
    }

    /// Sets CONFIGMODE then `mode` on the sensor behind `port`.
    pub fn start_in(
        port: Box<dyn Port>,
        name: &str,
        timeout: Duration,
        mode: FusionMode,
    ) -> Result<Self, SensorError> {
        let mut s = Bno055 {
            port,
            id: Ident {
                sensor: SensorFormat::Bno055,
                port: name.to_string(),
            },
            timeout,
            drain: true,
            cancel: Cancel::never(),
            mode,
        };
        s.set_mode(CONFIG_MODE, "CONFIGMODE")?;
        std::thread::sleep(TO_CONFIG);
        let upper = mode.name().to_ascii_uppercase();
        s.set_mode(mode.register_value(), &upper)?;
        std::thread::sleep(FROM_CONFIG);
        Ok(s)
    }

    fn set_mode(&mut self, mode: u8, name: &str) -> Result<(), SensorError> {
        let what = format!("write OPR_MODE (0x{OPR_MODE:02X}) = 0x{mode:02X} ({name})");
        self.exchange(&write_request(OPR_MODE, &[mode]), &what, Expect::Ack)
            .map(drop)
    }

    /// Sends `request` until it is answered as expected, a non-transient status comes, or
    /// [`ATTEMPTS`] requests were answered with a transient one.
    fn exchange(
        &mut self,
        request: &[u8],
        what: &str,
        expect: Expect,
    ) -> Result<Vec<u8>, SensorError> {
        let mut attempt = 1;
        loop {
            self.drain_input()?;
            self.send(request)?;
            match self.reply(what, expect) {
                Ok(Reply::Done(frame)) => return Ok(frame),
                Ok(Reply::Status(s)) if is_transient(s) && attempt < ATTEMPTS => {
                    attempt += 1;
                    std::thread::sleep(RETRY_PAUSE);
                }
                Ok(Reply::Status(status)) => {
                    return Err(SensorError::Status {
                        sensor: self.id.sensor,
                        port: self.id.port.clone(),
                        request: what.to_string(),
                        status,
                        attempts: attempt,
                    })
                }
                Err(e) => {
                    self.drain = matches!(
                        e,
                        SensorError::Timeout { .. }
                            | SensorError::BadReply { .. }
                            | SensorError::Abandoned { .. }
                    );
                    return Err(e);
                }
            }
        }
    }

    /// Writes one request completely and waits until it has left.
    fn send(&mut self, request: &[u8]) -> Result<(), SensorError> {
        if let Err(e) = self.port.write_all(request) {
            return Err(self.id.io_err("writing a request", e));
        }
        self.port
            .flush()
            .map_err(|e| self.id.io_err("draining a written request", e))
    }

    /// Reads one reply: its first two bytes say what follows.
    fn reply(&mut self, what: &str, expect: Expect) -> Result<Reply, SensorError> {
        let deadline = Instant::now() + self.timeout;
        let mut got = Vec::new();
        self.fill(&mut got, 2, deadline, what)?;
        match (got[0], got[1], expect) {
            (STATUS, WRITE_SUCCESS, Expect::Ack) => Ok(Reply::Done(got)),
            (STATUS, s, _) if s != WRITE_SUCCESS => Ok(Reply::Status(s)),
            (READ_SUCCESS, len, Expect::Data(n)) if len == n => {
                self.fill(&mut got, 2 + usize::from(n), deadline, what)?;
                Ok(Reply::Done(got))
            }
            _ => Err(SensorError::BadReply {
                sensor: self.id.sensor,
                port: self.id.port.clone(),
                expected: expect.describe(),
                got,
            }),
        }
    }

    /// Reads into `got` until it holds `n` bytes (never more), or the deadline passes.
    fn fill(
        &mut self,
        got: &mut Vec<u8>,
        n: usize,
        deadline: Instant,
        what: &str,
    ) -> Result<(), SensorError> {
        let mut buf = [0u8; 64];
        while got.len() < n {
            if self.cancel.is_cancelled() {
                return Err(self.id.abandoned());
            }
            if Instant::now() >= deadline {
                let partial = match got.len() {
                    0 => String::new(),
                    k => format!("{k} byte(s): {}", super::hex(got)),
                };
                return Err(self.id.timeout(
                    format!("complete reply to {what}"),
                    self.timeout,
                    partial,
                ));
            }
            let want = (n - got.len()).min(buf.len());
            match self.port.read(&mut buf[..want]) {
                Ok(0) => return Err(self.id.closed("waiting for a reply")),
                Ok(k) => got.extend_from_slice(&buf[..k]),
                Err(e) if is_idle(&e) => {}
                Err(e) => return Err(self.id.io_err("waiting for a reply", e)),
            }
        }
        Ok(())
    }

    /// When a reply may still be on its way: reads and drops input until one read of the port
    /// finds nothing. A sensor that sends for the whole timeout unasked is a bad reply.
    fn drain_input(&mut self) -> Result<(), SensorError> {
        if !self.drain {
            return Ok(());
        }
        let deadline = Instant::now() + self.timeout;
        let mut buf = [0u8; 64];
        let mut seen = Vec::new();
        loop {
            match self.port.read(&mut buf) {
                Ok(0) => return Err(self.id.closed("draining stale input")),
                Ok(k) => {
                    seen.extend_from_slice(&buf[..k]);
                    seen.truncate(16);
                    if Instant::now() >= deadline {
                        return Err(SensorError::BadReply {
                            sensor: self.id.sensor,
                            port: self.id.port.clone(),
                            expected: "silence before a request (the sensor sends unasked: is it a BNO055 in UART mode?)".into(),
                            got: seen,
                        });
                    }
                }
                Err(e) if matches!(e.kind(), ErrorKind::TimedOut | ErrorKind::WouldBlock) => break,
                Err(e) if e.kind() == ErrorKind::Interrupted => {}
                Err(e) => return Err(self.id.io_err("draining stale input", e)),
            }
        }
        self.drain = false;
        Ok(())
    }

    /// Decodes the 8 quaternion bytes of a read's reply frame.
    fn decode(&self, frame: Vec<u8>) -> Result<Reading, SensorError> {
        let data: [u8; 8] = frame
            .get(2..10)
            .and_then(|d| d.try_into().ok())
            .ok_or_else(|| SensorError::BadReply {
                sensor: self.id.sensor,
                port: self.id.port.clone(),
                expected: Expect::Data(8).describe(),
                got: frame.clone(),
            })?;
        let raw = quaternion_raw(&data);
        if raw == [0; 4] {
            return Err(SensorError::NotFused {
                sensor: self.id.sensor,
                port: self.id.port.clone(),
            });
        }
        let [w, x, y, z] = raw.map(|v| f64::from(v) / QUATERNION_LSB);
        match unit_quaternion(w, x, y, z) {
            Ok(orientation) => Ok(Reading {
                orientation,
                raw: Raw::Frame(frame),
            }),
            Err(reason) => Err(SensorError::BadReply {
                sensor: self.id.sensor,
                port: self.id.port.clone(),
                expected: format!("a unit quaternion, but {reason}"),
                got: frame,
            }),
        }
    }
}

impl super::OrientationSensor for Bno055 {
    fn read(&mut self) -> Result<Reading, SensorError> {
        let what = format!("read QUA_Data (0x{QUA_DATA_W_LSB:02X}, 8 bytes)");
        let frame = self.exchange(&read_request(QUA_DATA_W_LSB, 8), &what, Expect::Data(8))?;
        self.decode(frame)
    }

    fn describe(&self) -> String {
        let mode = self.mode.name().to_ascii_uppercase();
        format!("BNO055 (UART, {mode} mode) on {}", self.id.port)
    }

    fn ready(&mut self) -> Result<Option<Calibration>, SensorError> {
        let what = format!("read CALIB_STAT (0x{CALIB_STAT:02X}, 1 byte)");
        let frame = self.exchange(&read_request(CALIB_STAT, 1), &what, Expect::Data(1))?;
        let Some(&byte) = frame.get(2) else {
            return Err(SensorError::BadReply {
                sensor: self.id.sensor,
                port: self.id.port.clone(),
                expected: Expect::Data(1).describe(),
                got: frame,
            });
        };
        let calibration = Calibration::from_byte(byte);
        if calibration.gyroscope == 0 {
            return Err(SensorError::Uncalibrated {
                sensor: self.id.sensor,
                port: self.id.port.clone(),
                calibration,
            });
        }
        Ok(Some(calibration))
    }

    fn set_cancel(&mut self, cancel: Cancel) {
        self.cancel = cancel;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sensor_bno055_frames() {
        assert_eq!(
            write_request(OPR_MODE, &[NDOF_MODE]),
            vec![0xAA, 0x00, 0x3D, 0x01, 0x0C]
        );
        assert_eq!(read_request(QUA_DATA_W_LSB, 8), [0xAA, 0x01, 0x20, 0x08]);
    }

    #[test]
    fn sensor_bno055_quaternion_bytes_are_signed_lsb_first() {
        let data = [0x00, 0x40, 0x00, 0xC0, 0xFF, 0x7F, 0x01, 0x80];
        assert_eq!(quaternion_raw(&data), [16384, -16384, 32767, -32767]);
    }

    #[test]
    fn sensor_bno055_status_names() {
        assert_eq!(status_name(0x07), "BUS_OVER_RUN_ERROR");
        assert_eq!(status_name(0x02), "READ_FAIL");
        assert_eq!(status_name(0x0A), "RECEIVE_CHARACTER_TIMEOUT");
        assert_eq!(status_name(0x42), "an undocumented status");
        assert!(is_transient(0x07) && is_transient(0x0A) && !is_transient(0x02));
    }
}
