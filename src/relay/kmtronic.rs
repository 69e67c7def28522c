//! Driver for the KMTronic USB relay boards (1, 2, 4 and 8 relays, FTDI serial).
//!
//! Protocol, from KMTronic's "USB Relay Test software" command list
//! (<https://info.kmtronic.com/kmtronic-usb-relay-test-software.html>): 9600 baud 8N1; three
//! bytes `FF ch op`: `FF 01 01` relay 1 on, `FF 01 00` off. Status: on the one- and two-relay
//! boards `FF ch 03` answers `FF ch xx` (`01` on, `00` off); on the four- and eight-relay boards
//! `FF 09 00` answers one byte per relay (`00`/`01`, relay 1 first). Switching commands get no
//! answer. "All off" is one off frame per channel.

use super::{check_channel, BoardKind, Channel, Link, RelayBoard, RelayError};

/// The USB boards have at most eight relays (`FF 09 00` is the status request there).
pub const MAX_CHANNELS: u16 = 8;

/// The frame switching `channel` on or off.
pub fn frame(channel: Channel, on: bool) -> [u8; 3] {
    [0xFF, channel.0 as u8, u8::from(on)]
}

/// A KMTronic board on a link.
pub struct Kmtronic {
    link: Link,
    channels: u16,
}

impl Kmtronic {
    /// A board driving `channels` relays (checked against [`MAX_CHANNELS`] where the settings are),
    /// talking over `link`.
    pub fn new(link: Link, channels: u16) -> Kmtronic {
        Kmtronic { link, channels }
    }

    fn bad(&self, expected: &str, got: Vec<u8>) -> RelayError {
        RelayError::BadReply {
            board: BoardKind::Kmtronic,
            expected: expected.into(),
            got,
        }
    }

    fn state_byte(&self, b: u8, got: &[u8]) -> Result<bool, RelayError> {
        match b {
            0 => Ok(false),
            1 => Ok(true),
            _ => Err(self.bad("status bytes 00 or 01", got.to_vec())),
        }
    }
}

impl RelayBoard for Kmtronic {
    fn kind(&self) -> BoardKind {
        BoardKind::Kmtronic
    }

    fn set(&mut self, channel: Channel, on: bool) -> Result<(), RelayError> {
        check_channel(BoardKind::Kmtronic, channel, self.channels)?;
        self.link.send(&frame(channel, on))
    }

    fn all_off(&mut self) -> Result<(), RelayError> {
        for ch in 1..=self.channels {
            self.link.send(&frame(Channel(ch), false))?;
        }
        Ok(())
    }

    fn read_back(&self) -> Result<(), RelayError> {
        match self.channels {
            1 | 2 | 4 | 8 => Ok(()),
            n => Err(RelayError::NoReadBack {
                board: BoardKind::Kmtronic,
                reason: format!(
                    "status replies exist for 1, 2, 4 and 8 relay boards, the settings say {n} channels (set relay.channels to the board's relay count)"
                ),
            }),
        }
    }

    fn read_states(&mut self) -> Result<Option<Vec<bool>>, RelayError> {
        self.read_back()?;
        let n = self.channels;
        let mut states = Vec::with_capacity(n as usize);
        if n <= 2 {
            for ch in 1..=n {
                self.link.send(&[0xFF, ch as u8, 0x03])?;
                let Some(r) = self.link.recv_exact(BoardKind::Kmtronic, 3)? else {
                    return Ok(None);
                };
                if r[0] != 0xFF || r[1] != ch as u8 {
                    return Err(self.bad(&format!("FF {ch:02X} xx"), r));
                }
                states.push(self.state_byte(r[2], &r)?);
            }
        } else {
            self.link.send(&[0xFF, 0x09, 0x00])?;
            let Some(r) = self.link.recv_exact(BoardKind::Kmtronic, n as usize)? else {
                return Ok(None);
            };
            for &b in &r {
                states.push(self.state_byte(b, &r)?);
            }
        }
        Ok(Some(states))
    }

    fn take_sent(&mut self) -> Vec<Vec<u8>> {
        self.link.take_sent()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn frames_match_the_vendor_list() {
        assert_eq!(frame(Channel(1), true), [0xFF, 0x01, 0x01]);
        assert_eq!(frame(Channel(1), false), [0xFF, 0x01, 0x00]);
        assert_eq!(frame(Channel(8), true), [0xFF, 0x08, 0x01]);
    }

    #[test]
    fn read_back_only_for_documented_counts() {
        assert!(Kmtronic::new(Link::dry_run(), 8).read_back().is_ok());
        assert!(Kmtronic::new(Link::dry_run(), 3).read_back().is_err());
    }
}
