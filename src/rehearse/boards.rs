//! The relay boards as their far end: each protocol of `crate::relay` (LCUS, KMTronic, Numato,
//! Modbus RTU) parsed from the bytes a driver sends and answered byte for byte as the board
//! does (read-back, the Numato echo and prompt, Modbus CRCs and exception replies), with the
//! relays it switches. Pure bytes, no port: [`super::live::run`] feeds it what arrives on a
//! pseudo-terminal, and the tests can feed it directly.

use crate::relay::modbus::crc16;
use crate::relay::numato::mask_digits;
use crate::relay::{kmtronic, lcus, BoardKind};
use crate::serial::hex;

/// What one frame did to the relays.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Action {
    /// Channel (1-based) switched on or off.
    Set(u16, bool),
    /// Every relay set from a mask (Numato `writeall`, Modbus function 0F): relay i on when
    /// bit i is.
    WriteAll(Vec<bool>),
    /// A read-back, answered.
    Read,
    /// Not understood (or addressed to another Modbus slave, or a bad CRC): why.
    Unknown(String),
}

/// One frame received: its bytes (as text for Numato's commands), what it did and the reply.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Frame {
    /// The bytes received (the whole frame).
    pub bytes: Vec<u8>,
    /// What the frame did.
    pub action: Action,
    /// The bytes answered (empty when the board answers nothing).
    pub reply: Vec<u8>,
}

impl Frame {
    /// The frame as the log writes it: hex, and a Numato command's text.
    pub fn shown(&self) -> String {
        match std::str::from_utf8(&self.bytes) {
            Ok(t) if t.ends_with('\r') && t.is_ascii() => {
                format!("{} ({})", hex(&self.bytes), t.trim_end())
            }
            _ => hex(&self.bytes),
        }
    }
}

/// The longest a frame can be before the bytes are given up as not understood (a Numato line,
/// a Modbus 0F frame for 1968 coils is 255 bytes): bounded memory whatever arrives.
pub const MAX_FRAME: usize = 512;

/// A relay board's far end: its protocol, relays and the bytes not yet a whole frame.
#[derive(Debug, Clone)]
pub struct BoardEmulator {
    /// The board type it emulates: its protocol.
    pub kind: BoardKind,
    /// Its relay count.
    pub channels: u16,
    /// Its Modbus slave address (the other types ignore it).
    pub slave_address: u8,
    /// Relay i (channel i + 1) as the board holds it.
    pub relays: Vec<bool>,
    buf: Vec<u8>,
}

impl BoardEmulator {
    /// A board of `kind` with `channels` relays, all open, answering Modbus frames to
    /// `slave_address`.
    pub fn new(kind: BoardKind, channels: u16, slave_address: u8) -> BoardEmulator {
        BoardEmulator {
            kind,
            channels,
            slave_address,
            relays: vec![false; usize::from(channels)],
            buf: Vec::new(),
        }
    }

    /// Takes the bytes that arrived and returns the whole frames among them, in order (the
    /// relays already switched by them; the caller sends each reply).
    pub fn feed(&mut self, bytes: &[u8]) -> Vec<Frame> {
        self.buf.extend_from_slice(bytes);
        let mut frames = Vec::new();
        while let Some(f) = self.next_frame() {
            self.apply(&f.action);
            frames.push(f);
        }
        if self.buf.len() > MAX_FRAME {
            let bytes = std::mem::take(&mut self.buf);
            frames.push(Frame {
                bytes,
                action: Action::Unknown(format!("more than {MAX_FRAME} bytes without a frame")),
                reply: Vec::new(),
            });
        }
        frames
    }

    /// The bytes of an incomplete frame left when the port closed, as a frame not understood.
    pub fn leftover(&mut self) -> Option<Frame> {
        if self.buf.is_empty() {
            return None;
        }
        Some(Frame {
            bytes: std::mem::take(&mut self.buf),
            action: Action::Unknown("an incomplete frame when the port closed".into()),
            reply: Vec::new(),
        })
    }

    fn apply(&mut self, a: &Action) {
        match a {
            Action::Set(ch, on) => {
                if let Some(r) = self.relays.get_mut(usize::from(*ch).wrapping_sub(1)) {
                    *r = *on;
                }
            }
            Action::WriteAll(states) => {
                for (r, s) in self.relays.iter_mut().zip(states) {
                    *r = *s;
                }
            }
            Action::Read | Action::Unknown(_) => {}
        }
    }

    fn take(&mut self, n: usize) -> Vec<u8> {
        self.buf.drain(..n).collect()
    }

    fn next_frame(&mut self) -> Option<Frame> {
        match self.kind {
            BoardKind::Lcus => self.lcus(),
            BoardKind::Kmtronic => self.kmtronic(),
            BoardKind::Numato => self.numato(),
            BoardKind::Modbus => self.modbus(),
        }
    }

    fn channel_ok(&self, ch: u8) -> bool {
        ch >= 1 && u16::from(ch) <= self.channels
    }

    /// A byte that starts no frame: given up alone, so that the next frame is found.
    fn stray(&mut self, start: u8, why: &str) -> Option<Frame> {
        let bytes = self.take(1);
        Some(Frame {
            bytes,
            action: Action::Unknown(format!("{why} (expected a frame starting {start:02X})")),
            reply: Vec::new(),
        })
    }

    /// `A0 ch op sum`; no reply.
    fn lcus(&mut self) -> Option<Frame> {
        let &first = self.buf.first()?;
        if first != 0xA0 {
            return self.stray(0xA0, "a byte outside a frame");
        }
        if self.buf.len() < 4 {
            return None;
        }
        let bytes = self.take(4);
        let (ch, op, sum) = (bytes[1], bytes[2], bytes[3]);
        let action = if 0xA0u8.wrapping_add(ch).wrapping_add(op) != sum {
            Action::Unknown("a bad checksum".into())
        } else if !self.channel_ok(ch) || u16::from(ch) > lcus::MAX_CHANNELS {
            Action::Unknown(format!("channel {ch}, the board has 1..={}", self.channels))
        } else if op > 1 {
            Action::Unknown(format!("operation {op:02X} (00 off, 01 on)"))
        } else {
            Action::Set(u16::from(ch), op == 1)
        };
        Some(Frame {
            bytes,
            action,
            reply: Vec::new(),
        })
    }

    /// `FF ch op`; `FF ch 03` (1 and 2 relays) answers `FF ch xx`, `FF 09 00` (4 and 8) one
    /// byte per relay.
    fn kmtronic(&mut self) -> Option<Frame> {
        let &first = self.buf.first()?;
        if first != 0xFF {
            return self.stray(0xFF, "a byte outside a frame");
        }
        if self.buf.len() < 3 {
            return None;
        }
        let bytes = self.take(3);
        let (ch, op) = (bytes[1], bytes[2]);
        let n = self.channels;
        let state = |k: usize| u8::from(self.relays.get(k).copied().unwrap_or(false));
        let (action, reply) = match (ch, op) {
            (0x09, 0x00) if n > 2 && n <= kmtronic::MAX_CHANNELS => (
                Action::Read,
                (0..usize::from(n)).map(state).collect::<Vec<u8>>(),
            ),
            (c, 0x03) if n <= 2 && self.channel_ok(c) => {
                (Action::Read, vec![0xFF, c, state(usize::from(c) - 1)])
            }
            (c, 0 | 1) if self.channel_ok(c) => (Action::Set(u16::from(c), op == 1), Vec::new()),
            _ => (
                Action::Unknown(format!(
                    "a {n}-relay board knows FF ch 00/01 with ch 1..={n} and {}",
                    if n <= 2 { "FF ch 03" } else { "FF 09 00" }
                )),
                Vec::new(),
            ),
        };
        Some(Frame {
            bytes,
            action,
            reply,
        })
    }

    /// ASCII commands ended by `\r`: echo, `\n\r`, any answer and `\n\r`, then `>`.
    fn numato(&mut self) -> Option<Frame> {
        let end = self.buf.iter().position(|&b| b == b'\r')?;
        let bytes = self.take(end + 1);
        let text = String::from_utf8_lossy(&bytes[..end]).into_owned();
        let words: Vec<&str> = text.split_whitespace().collect();
        let index = |w: &str| -> Option<u16> {
            let c = match w.as_bytes() {
                [c] => *c,
                _ => return None,
            };
            let i = match c {
                b'0'..=b'9' => c - b'0',
                b'A'..=b'V' => c - b'A' + 10,
                _ => return None,
            };
            let ch = u16::from(i) + 1;
            (ch <= self.channels).then_some(ch)
        };
        let digits = mask_digits(self.channels);
        let mask = |relays: &[bool]| -> u32 {
            (relays.iter().enumerate()).fold(0u32, |m, (i, &on)| m | (u32::from(on) << i))
        };
        let (action, answer) = match words.as_slice() {
            ["relay", "on", r] if index(r).is_some() => {
                (Action::Set(index(r).unwrap_or(0), true), None)
            }
            ["relay", "off", r] if index(r).is_some() => {
                (Action::Set(index(r).unwrap_or(0), false), None)
            }
            ["relay", "read", r] => match index(r) {
                Some(ch) => {
                    let on = self.relays[usize::from(ch) - 1];
                    (
                        Action::Read,
                        Some(if on { "on" } else { "off" }.to_string()),
                    )
                }
                None => (Action::Unknown(format!("no relay '{r}'")), None),
            },
            ["relay", "readall"] if digits.is_some() => {
                let d = digits.unwrap_or(4);
                (Action::Read, Some(format!("{:0d$x}", mask(&self.relays))))
            }
            ["relay", "writeall", m] if digits.is_some_and(|d| m.len() == d) => {
                match u32::from_str_radix(m, 16) {
                    Ok(v) => (
                        Action::WriteAll((0..self.channels).map(|i| v >> i & 1 == 1).collect()),
                        None,
                    ),
                    Err(_) => (
                        Action::Unknown(format!("mask '{m}' is not hexadecimal")),
                        None,
                    ),
                }
            }
            _ => (
                Action::Unknown(format!("command '{}'", text.escape_debug())),
                None,
            ),
        };
        let mut reply = format!("{text}\n\r");
        if let Some(a) = answer {
            reply.push_str(&a);
            reply.push_str("\n\r");
        }
        reply.push('>');
        Some(Frame {
            bytes,
            action,
            reply: reply.into_bytes(),
        })
    }

    /// Modbus RTU: 05 (8 bytes), 01 (8 bytes), 0F (9 + n bytes); CRC checked; exceptions
    /// 01 (function), 02 (address), 03 (value).
    fn modbus(&mut self) -> Option<Frame> {
        let len = self.modbus_len()?;
        if self.buf.len() < len {
            return None;
        }
        let bytes = self.take(len);
        let (data, crc) = bytes.split_at(len - 2);
        if crc16(data) != crc {
            return Some(Frame {
                bytes: bytes.clone(),
                action: Action::Unknown("a bad CRC: not answered".into()),
                reply: Vec::new(),
            });
        }
        if bytes[0] != self.slave_address {
            return Some(Frame {
                action: Action::Unknown(format!(
                    "addressed to slave {}, this is slave {}: not answered",
                    bytes[0], self.slave_address
                )),
                bytes,
                reply: Vec::new(),
            });
        }
        let (action, reply) = self.modbus_answer(&bytes);
        Some(Frame {
            bytes,
            action,
            reply,
        })
    }

    /// The length of the Modbus frame the buffer starts with, `None` while too little has
    /// arrived to tell.
    fn modbus_len(&self) -> Option<usize> {
        if self.buf.len() < 2 {
            return None;
        }
        Some(match self.buf[1] {
            0x05 | 0x01 => 8,
            0x0F => {
                if self.buf.len() < 7 {
                    return None;
                }
                9 + usize::from(self.buf[6])
            }
            // no length is known: what has arrived is the frame (a real slave waits for the
            // line's silence)
            _ => self.buf.len().max(4),
        })
    }

    /// What a whole Modbus frame to this slave, its CRC checked, does and the reply: the
    /// echo, the coils read or an exception.
    fn modbus_answer(&self, bytes: &[u8]) -> (Action, Vec<u8>) {
        let function = bytes[1];
        let n = usize::from(self.channels);
        let exception = |code: u8, why: String| {
            let mut r = vec![bytes[0], function | 0x80, code];
            r.extend(crc16(&r));
            (Action::Unknown(why), r)
        };
        let word = |i: usize| usize::from(u16::from_be_bytes([bytes[i], bytes[i + 1]]));
        match function {
            0x05 => {
                let (addr, value) = (word(2), word(4));
                if addr >= n {
                    exception(0x02, format!("coil address {addr}, the board has 0..{n}"))
                } else if value != 0xFF00 && value != 0 {
                    exception(0x03, format!("value {value:04X} (FF00 on, 0000 off)"))
                } else {
                    (
                        Action::Set(addr as u16 + 1, value == 0xFF00),
                        bytes.to_vec(),
                    )
                }
            }
            0x0F => {
                let (start, count) = (word(2), word(4));
                let nbytes = usize::from(bytes[6]);
                if start + count > n || count == 0 {
                    exception(0x02, format!("coils {start}..{} of 0..{n}", start + count))
                } else if nbytes != count.div_ceil(8) {
                    exception(0x03, format!("{nbytes} data bytes for {count} coils"))
                } else {
                    let mut states = self.relays.clone();
                    for i in 0..count {
                        states[start + i] = bytes[7 + i / 8] >> (i % 8) & 1 == 1;
                    }
                    let mut r = bytes[..6].to_vec();
                    r.extend(crc16(&r));
                    (Action::WriteAll(states), r)
                }
            }
            0x01 => {
                let (start, count) = (word(2), word(4));
                if start + count > n || count == 0 {
                    exception(0x02, format!("coils {start}..{} of 0..{n}", start + count))
                } else {
                    (Action::Read, self.modbus_coils(bytes[0], start, count))
                }
            }
            f => exception(0x01, format!("function {f:02X} (05, 0F and 01 are served)")),
        }
    }

    /// The reply to a read of coils `start..start + count` (function 01), packed and CRC'd.
    fn modbus_coils(&self, slave: u8, start: usize, count: usize) -> Vec<u8> {
        let mut r = vec![slave, 0x01, count.div_ceil(8) as u8];
        let mut packed = vec![0u8; count.div_ceil(8)];
        for i in 0..count {
            if self.relays[start + i] {
                packed[i / 8] |= 1 << (i % 8);
            }
        }
        r.extend(packed);
        r.extend(crc16(&r));
        r
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::relay::{modbus, numato, Channel};

    #[test]
    fn each_board_understands_its_drivers_frames() {
        let mut b = BoardEmulator::new(BoardKind::Lcus, 8, 1);
        let f = b.feed(&lcus::frame(Channel(3), true));
        assert_eq!(f[0].action, Action::Set(3, true));
        assert!(b.relays[2]);
        let mut b = BoardEmulator::new(BoardKind::Kmtronic, 8, 1);
        b.feed(&kmtronic::frame(Channel(2), true));
        let f = b.feed(&[0xFF, 0x09, 0x00]);
        assert_eq!(f[0].reply, vec![0, 1, 0, 0, 0, 0, 0, 0]);
        let mut b = BoardEmulator::new(BoardKind::Numato, 16, 1);
        b.feed(numato::set_command(Channel(11), true).as_bytes());
        let f = b.feed(b"relay readall\r");
        assert_eq!(f[0].reply, b"relay readall\n\r0400\n\r>".to_vec());
        let mut b = BoardEmulator::new(BoardKind::Modbus, 16, 1);
        let req = modbus::write_single_coil(1, Channel(1), true);
        let f = b.feed(&req[..3]);
        assert!(f.is_empty());
        let f = b.feed(&req[3..]);
        assert_eq!(f[0].reply, req);
        let f = b.feed(&modbus::write_multiple_coils(1, &[false; 16]));
        assert_eq!(f[0].action, Action::WriteAll(vec![false; 16]));
        assert_eq!(f[0].reply.len(), 8);
    }

    #[test]
    fn frames_not_understood_are_reported_and_answered_as_the_board_does() {
        let mut b = BoardEmulator::new(BoardKind::Modbus, 16, 1);
        let mut req = vec![0x01, 0x05, 0x00, 0x20, 0xFF, 0x00];
        req.extend(crc16(&req));
        let f = b.feed(&req);
        assert!(matches!(f[0].action, Action::Unknown(_)));
        assert_eq!(&f[0].reply[..3], &[0x01, 0x85, 0x02]);
        let mut bad = modbus::write_single_coil(1, Channel(1), true);
        bad[7] ^= 1;
        let f = b.feed(&bad);
        assert!(f[0].reply.is_empty() && !b.relays[0]);
        let mut b = BoardEmulator::new(BoardKind::Lcus, 8, 1);
        let f = b.feed(&[0x41, 0xA0, 0x01, 0x01, 0xA3]);
        assert_eq!(f.len(), 2);
        assert!(f.iter().all(|x| matches!(x.action, Action::Unknown(_))));
        let mut b = BoardEmulator::new(BoardKind::Numato, 16, 1);
        let f = b.feed(b"ver\r");
        assert_eq!(f[0].reply, b"ver\n\r>".to_vec());
        assert!(matches!(f[0].action, Action::Unknown(_)));
    }
}
