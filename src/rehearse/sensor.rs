//! The orientation sensors as their far end (`crate::sensor`'s two protocols): the quat-csv
//! line `w,x,y,z` a sketch prints, and the Bosch BNO055's UART register protocol (datasheet
//! BST-BNO055-DS000 section 4.7: `AA 00 reg len data` written and answered `EE 01`, `AA 01 reg
//! len` read and answered `BB len data`, or `EE status`), with its operating mode, the
//! calibration status and the quaternion registers. Pure bytes: [`super::live::run`] serves them on
//! a pseudo-terminal. The faults a rehearsal injects (a garbled reply, a sensor that stalls)
//! are decided by the caller.

use crate::model::geometry::Orientation;
use crate::sensor::bno055::{
    CALIB_STAT, CONFIG_MODE, IMU_MODE, NDOF_MODE, OPR_MODE, QUATERNION_LSB, QUA_DATA_W_LSB, READ,
    READ_SUCCESS, START, STATUS, WRITE, WRITE_SUCCESS,
};

/// One quat-csv line for an orientation: `w,x,y,z` and a newline, each number in full (the
/// shortest text that reads back as the same `f64`: the ball's orientation to the bit, as a
/// sketch printing every digit it has would send it; [`crate::sensor::quat_csv`] reads any
/// number of decimals).
pub fn quat_csv_line(q: &Orientation) -> String {
    let c = q.quaternion();
    format!("{},{},{},{}\n", c.w, c.i, c.j, c.k)
}

/// A garbled quat-csv line: what a line corrupted on the wire looks like (three fields, a
/// stray character).
pub fn garbled_line(q: &Orientation) -> String {
    let c = q.quaternion();
    format!("{},{}#{}\n", c.w, c.i, c.j)
}

/// What the BNO055 did with one request.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Request {
    /// A register written.
    Write {
        /// The first register written.
        register: u8,
        /// The bytes written, from that register on.
        data: Vec<u8>,
    },
    /// Registers read; `quaternion` when they were the quaternion's.
    Read {
        /// The first register read.
        register: u8,
        /// How many bytes were read.
        len: u8,
        /// Whether they were the quaternion's registers (QUA_DATA_W_LSB on).
        quaternion: bool,
    },
    /// Not understood: why (answered with an error status).
    Unknown(String),
}

/// Calibration status reported (CALIB_STAT, 0x35): system, gyroscope and accelerometer fully
/// calibrated (3), magnetometer 3 in NDOF and 0 in IMU mode (it is not fused there).
pub fn calibration_byte(mode: u8) -> u8 {
    if mode == NDOF_MODE {
        0xFF
    } else {
        0xFC
    }
}

/// A BNO055 in UART mode: its operating mode and the bytes of a request not yet complete.
#[derive(Debug, Clone)]
pub struct Bno055Emulator {
    /// The operating mode (the OPR_MODE register's low nibble) as last written; CONFIGMODE at the
    /// start.
    pub mode: u8,
    buf: Vec<u8>,
}

impl Default for Bno055Emulator {
    fn default() -> Self {
        Bno055Emulator {
            mode: CONFIG_MODE,
            buf: Vec::new(),
        }
    }
}

impl Bno055Emulator {
    /// Takes the bytes that arrived; for each whole request, what it was and its reply (the
    /// quaternion read from `now`, the orientation the sensor measures at this moment).
    pub fn feed(
        &mut self,
        bytes: &[u8],
        now: &mut dyn FnMut() -> Orientation,
    ) -> Vec<(Request, Vec<u8>)> {
        self.buf.extend_from_slice(bytes);
        let mut out = Vec::new();
        while let Some(&first) = self.buf.first() {
            if first != START {
                self.buf.remove(0);
                out.push((
                    Request::Unknown(format!("start byte {first:02X}, not AA")),
                    vec![STATUS, 0x06],
                ));
                continue;
            }
            if self.buf.len() < 4 {
                break;
            }
            let (op, register, len) = (self.buf[1], self.buf[2], self.buf[3]);
            match op {
                WRITE => {
                    let n = 4 + usize::from(len);
                    if self.buf.len() < n {
                        break;
                    }
                    let frame: Vec<u8> = self.buf.drain(..n).collect();
                    let data = frame[4..].to_vec();
                    out.push(self.write(register, data));
                }
                READ => {
                    self.buf.drain(..4);
                    out.push(self.read(register, len, now));
                }
                other => {
                    self.buf.drain(..4);
                    out.push((
                        Request::Unknown(format!("operation {other:02X} (00 write, 01 read)")),
                        vec![STATUS, 0x02],
                    ));
                }
            }
        }
        out
    }

    fn write(&mut self, register: u8, data: Vec<u8>) -> (Request, Vec<u8>) {
        if data.is_empty() {
            return (
                Request::Unknown("a write of 0 bytes".into()),
                vec![STATUS, 0x09],
            );
        }
        if register == OPR_MODE {
            let m = data[0];
            if ![CONFIG_MODE, IMU_MODE, NDOF_MODE].contains(&(m & 0x0F)) {
                return (
                    Request::Unknown(format!(
                        "OPR_MODE 0x{m:02X}: only CONFIGMODE, IMU and NDOF are emulated"
                    )),
                    vec![STATUS, 0x03],
                );
            }
            self.mode = m & 0x0F;
        }
        (
            Request::Write { register, data },
            vec![STATUS, WRITE_SUCCESS],
        )
    }

    fn read(
        &mut self,
        register: u8,
        len: u8,
        now: &mut dyn FnMut() -> Orientation,
    ) -> (Request, Vec<u8>) {
        if len == 0 {
            return (
                Request::Unknown("a read of 0 bytes".into()),
                vec![STATUS, 0x09],
            );
        }
        if len > 128 {
            return (
                Request::Unknown(format!("a read of {len} bytes (at most 128)")),
                vec![STATUS, 0x08],
            );
        }
        if usize::from(register) + usize::from(len) > 0x80 {
            return (
                Request::Unknown(format!("registers 0x{register:02X}+{len} beyond page 0")),
                vec![STATUS, 0x04],
            );
        }
        let mut regs = [0u8; 0x80];
        regs[usize::from(OPR_MODE)] = self.mode;
        regs[usize::from(CALIB_STAT)] = calibration_byte(self.mode);
        let quaternion = register < QUA_DATA_W_LSB + 8 && register + len > QUA_DATA_W_LSB;
        if quaternion && self.mode != CONFIG_MODE {
            let q = now();
            let c = q.quaternion();
            let raw = |v: f64| {
                ((v * QUATERNION_LSB).round().clamp(-32768.0, 32767.0) as i16).to_le_bytes()
            };
            for (k, v) in [c.w, c.i, c.j, c.k].into_iter().enumerate() {
                let b = raw(v);
                regs[usize::from(QUA_DATA_W_LSB) + 2 * k] = b[0];
                regs[usize::from(QUA_DATA_W_LSB) + 2 * k + 1] = b[1];
            }
        }
        let start = usize::from(register);
        let mut reply = vec![READ_SUCCESS, len];
        reply.extend_from_slice(&regs[start..start + usize::from(len)]);
        (
            Request::Read {
                register,
                len,
                quaternion,
            },
            reply,
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sensor::bno055::{quaternion_raw, read_request, write_request};
    use crate::sensor::quat_csv::parse_line;

    #[test]
    fn the_far_ends_answer_as_the_drivers_read() {
        let q = UnitQuaternionExt::about_z(0.3);
        // the line in full: the orientation back to the bit
        let back = parse_line(quat_csv_line(&q).trim_end()).unwrap();
        assert_eq!(back, q);
        assert!(parse_line(garbled_line(&q).trim_end()).is_err());
        let mut s = Bno055Emulator::default();
        let r = s.feed(&write_request(OPR_MODE, &[IMU_MODE]), &mut || q);
        assert_eq!(r[0].1, vec![STATUS, WRITE_SUCCESS]);
        let r = s.feed(&read_request(QUA_DATA_W_LSB, 8), &mut || q);
        let data: [u8; 8] = r[0].1[2..10].try_into().unwrap();
        let w = f64::from(quaternion_raw(&data)[0]) / QUATERNION_LSB;
        assert!((w - q.quaternion().w).abs() < 1e-4);
        let r = s.feed(&read_request(CALIB_STAT, 1), &mut || q);
        assert_eq!(r[0].1, vec![READ_SUCCESS, 1, 0xFC]);
    }

    struct UnitQuaternionExt;
    impl UnitQuaternionExt {
        fn about_z(a: f64) -> Orientation {
            Orientation::from_axis_angle(&nalgebra::Vector3::z_axis(), a)
        }
    }
}
