//! Driver for Modbus RTU relay boards (RS-485 or USB): each relay is a coil.
//!
//! Protocol, from the Modbus Application Protocol Specification V1.1b3 (modbus.org, functions
//! 01 Read Coils, 05 Write Single Coil, 0F Write Multiple Coils) and the Modbus over Serial Line
//! guide V1.02 (section 6.2.2, the CRC: initial 0xFFFF, polynomial 0xA001 reflected, sent low
//! byte first); KMTronic's Modbus relay notes (<https://kmtronic.blogspot.com/2015>) give the
//! worked frames used in the tests, e.g. `01 05 00 00 FF 00 8C 3A` switches relay 1 on.
//! Frame: slave address, function, data, CRC. Write Single Coil: coil address (channel - 1,
//! big-endian), `FF 00` on / `00 00` off; the reply echoes the request. Write Multiple Coils
//! (all off): start `00 00`, quantity, byte count, packed bits (coil 0 in the lowest bit); the
//! reply echoes address, function, start and quantity. Read Coils: start, quantity; the reply
//! carries a byte count and the packed bits. An exception reply sets bit 7 of the function and
//! carries one exception code. 9600 baud 8N1 and slave 1 are the usual factory settings.

use super::{check_channel, BoardKind, Channel, Link, RelayBoard, RelayError};

/// Write Multiple Coils takes at most 0x07B0 coils.
pub const MAX_CHANNELS: u16 = 0x07B0;

/// The Modbus CRC-16 (polynomial 0xA001 reflected, initial 0xFFFF), as the two bytes sent:
/// low byte first.
pub fn crc16(data: &[u8]) -> [u8; 2] {
    let mut crc: u16 = 0xFFFF;
    for &b in data {
        crc ^= u16::from(b);
        for _ in 0..8 {
            crc = if crc & 1 == 1 {
                (crc >> 1) ^ 0xA001
            } else {
                crc >> 1
            };
        }
    }
    crc.to_le_bytes()
}

fn with_crc(mut pdu: Vec<u8>) -> Vec<u8> {
    let c = crc16(&pdu);
    pdu.extend_from_slice(&c);
    pdu
}

/// Function 05: switch one coil (channel `channel` is coil address `channel - 1`).
pub fn write_single_coil(slave: u8, channel: Channel, on: bool) -> Vec<u8> {
    let [hi, lo] = channel.0.saturating_sub(1).to_be_bytes();
    with_crc(vec![
        slave,
        0x05,
        hi,
        lo,
        if on { 0xFF } else { 0x00 },
        0x00,
    ])
}

/// Function 0F: write coils 0..count to the given states.
pub fn write_multiple_coils(slave: u8, states: &[bool]) -> Vec<u8> {
    let n = states.len() as u16;
    let mut bytes = vec![0u8; states.len().div_ceil(8)];
    for (i, &s) in states.iter().enumerate() {
        if s {
            bytes[i / 8] |= 1 << (i % 8);
        }
    }
    let [qh, ql] = n.to_be_bytes();
    let mut pdu = vec![slave, 0x0F, 0x00, 0x00, qh, ql, bytes.len() as u8];
    pdu.extend_from_slice(&bytes);
    with_crc(pdu)
}

/// Function 01: read coils 0..count.
pub fn read_coils(slave: u8, count: u16) -> Vec<u8> {
    let [qh, ql] = count.to_be_bytes();
    with_crc(vec![slave, 0x01, 0x00, 0x00, qh, ql])
}

/// The standard name of an exception code.
pub fn exception_name(code: u8) -> &'static str {
    match code {
        0x01 => "illegal function",
        0x02 => "illegal data address",
        0x03 => "illegal data value",
        0x04 => "server device failure",
        0x05 => "acknowledge",
        0x06 => "server device busy",
        _ => "unknown exception",
    }
}

/// A Modbus RTU relay board on a link.
pub struct Modbus {
    link: Link,
    channels: u16,
    slave: u8,
}

impl Modbus {
    /// A board driving `channels` relay coils, answering to slave address `slave`, talking over
    /// `link`.
    pub fn new(link: Link, channels: u16, slave: u8) -> Modbus {
        Modbus {
            link,
            channels,
            slave,
        }
    }

    fn bad(&self, expected: impl Into<String>, got: Vec<u8>) -> RelayError {
        RelayError::BadReply {
            board: BoardKind::Modbus,
            expected: expected.into(),
            got,
        }
    }

    /// Sends a request and reads the reply: `body_len` bytes after address and function, then
    /// the CRC (`body_len` from the reply's third byte when `None`). Checks address, function,
    /// exception and CRC; returns the whole reply (`None` in a dry run).
    fn transact(
        &mut self,
        request: &[u8],
        body_len: Option<usize>,
    ) -> Result<Option<Vec<u8>>, RelayError> {
        self.link.send(request)?;
        let function = request[1];
        let Some(mut reply) = self.link.recv_exact(BoardKind::Modbus, 3)? else {
            return Ok(None);
        };
        if reply[0] != self.slave {
            return Err(self.bad(format!("a reply from slave {}", self.slave), reply));
        }
        let rest = if reply[1] == function | 0x80 {
            2
        } else if reply[1] == function {
            match body_len {
                Some(n) => n + 1,
                None => reply[2] as usize + 2,
            }
        } else {
            return Err(self.bad(format!("a reply to function {function:02X}"), reply));
        };
        match self.link.recv_exact(BoardKind::Modbus, rest)? {
            Some(more) => reply.extend_from_slice(&more),
            None => return Ok(None),
        }
        let (data, crc) = reply.split_at(reply.len() - 2);
        if crc16(data) != crc {
            return Err(self.bad("a reply with a valid CRC", reply));
        }
        if reply[1] == function | 0x80 {
            return Err(RelayError::ModbusException {
                slave: self.slave,
                function,
                code: reply[2],
            });
        }
        Ok(Some(reply))
    }
}

impl RelayBoard for Modbus {
    fn kind(&self) -> BoardKind {
        BoardKind::Modbus
    }

    fn set(&mut self, channel: Channel, on: bool) -> Result<(), RelayError> {
        check_channel(BoardKind::Modbus, channel, self.channels)?;
        let req = write_single_coil(self.slave, channel, on);
        if let Some(reply) = self.transact(&req, Some(4))? {
            if reply != req {
                return Err(self.bad(format!("the echo {}", super::hex(&req)), reply));
            }
        }
        Ok(())
    }

    fn all_off(&mut self) -> Result<(), RelayError> {
        let req = write_multiple_coils(self.slave, &vec![false; self.channels as usize]);
        if let Some(reply) = self.transact(&req, Some(4))? {
            if reply[..6] != req[..6] {
                return Err(self.bad(format!("the echo of {}", super::hex(&req[..6])), reply));
            }
        }
        Ok(())
    }

    fn read_back(&self) -> Result<(), RelayError> {
        Ok(())
    }

    fn read_states(&mut self) -> Result<Option<Vec<bool>>, RelayError> {
        let n = self.channels as usize;
        let req = read_coils(self.slave, self.channels);
        let Some(reply) = self.transact(&req, None)? else {
            return Ok(None);
        };
        if reply[2] as usize != n.div_ceil(8) {
            return Err(self.bad(format!("{} data bytes", n.div_ceil(8)), reply));
        }
        let bits = &reply[3..reply.len() - 2];
        Ok(Some(
            (0..n).map(|i| bits[i / 8] >> (i % 8) & 1 == 1).collect(),
        ))
    }

    fn take_sent(&mut self) -> Vec<Vec<u8>> {
        self.link.take_sent()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn crc_matches_the_published_example() {
        // KMTronic's Modbus notes and countless Modbus references: 01 05 00 00 FF 00 -> 8C 3A.
        assert_eq!(crc16(&[0x01, 0x05, 0x00, 0x00, 0xFF, 0x00]), [0x8C, 0x3A]);
        assert_eq!(
            write_single_coil(1, Channel(1), true),
            [0x01, 0x05, 0x00, 0x00, 0xFF, 0x00, 0x8C, 0x3A]
        );
        assert_eq!(
            write_single_coil(1, Channel(1), false),
            [0x01, 0x05, 0x00, 0x00, 0x00, 0x00, 0xCD, 0xCA]
        );
    }

    #[test]
    fn multiple_coils_and_read_frames() {
        assert_eq!(
            write_multiple_coils(1, &[false; 8]),
            [0x01, 0x0F, 0x00, 0x00, 0x00, 0x08, 0x01, 0x00, 0xFE, 0x95]
        );
        assert_eq!(
            read_coils(1, 8),
            [0x01, 0x01, 0x00, 0x00, 0x00, 0x08, 0x3D, 0xCC]
        );
    }
}
