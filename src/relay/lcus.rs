//! Driver for the CH340 "LCUS-1/2/4/8" USB relay boards (LC Technology and clones).
//!
//! Protocol, as the vendor listings document it (e.g. the LCUS-1 listing at
//! <https://tilga.com/prod/5732195> and the LCUS-2 manual at <https://manuals.plus/asin/B0F1CK5L4H>):
//! 9600 baud 8N1; every command is four bytes `A0 ch op sum`: start mark `0xA0`, channel
//! `0x01..`, operation `0x00` off / `0x01` on, and a checksum that is the low byte of the sum
//! of the first three (`A0 01 01 A2` switches relay 1 on, `A0 01 00 A1` off). The boards do not
//! answer, and their status query differs between clones, so this driver does not read back.
//! The largest board, LCUS-8, has 8 channels; "all off" is sent as one off frame per channel
//! (the `A0 0F ..` all-channel form is only on some clones).

use super::{check_channel, BoardKind, Channel, Link, RelayBoard, RelayError};

/// The LCUS-8 has the most channels of the family.
pub const MAX_CHANNELS: u16 = 8;

/// The frame switching `channel` on or off.
pub fn frame(channel: Channel, on: bool) -> [u8; 4] {
    let ch = channel.0 as u8;
    let op = u8::from(on);
    [0xA0, ch, op, 0xA0u8.wrapping_add(ch).wrapping_add(op)]
}

/// An LCUS board on a link.
pub struct Lcus {
    link: Link,
    channels: u16,
}

impl Lcus {
    /// A board driving `channels` relays (checked against [`MAX_CHANNELS`] where the settings are),
    /// talking over `link`.
    pub fn new(link: Link, channels: u16) -> Lcus {
        Lcus { link, channels }
    }
}

impl RelayBoard for Lcus {
    fn kind(&self) -> BoardKind {
        BoardKind::Lcus
    }

    fn set(&mut self, channel: Channel, on: bool) -> Result<(), RelayError> {
        check_channel(BoardKind::Lcus, channel, self.channels)?;
        self.link.send(&frame(channel, on))
    }

    fn all_off(&mut self) -> Result<(), RelayError> {
        for ch in 1..=self.channels {
            self.link.send(&frame(Channel(ch), false))?;
        }
        Ok(())
    }

    fn take_sent(&mut self) -> Vec<Vec<u8>> {
        self.link.take_sent()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn frames_match_the_vendor_examples() {
        assert_eq!(frame(Channel(1), true), [0xA0, 0x01, 0x01, 0xA2]);
        assert_eq!(frame(Channel(1), false), [0xA0, 0x01, 0x00, 0xA1]);
        assert_eq!(frame(Channel(2), true), [0xA0, 0x02, 0x01, 0xA3]);
        assert_eq!(frame(Channel(8), false), [0xA0, 0x08, 0x00, 0xA8]);
    }

    #[test]
    fn refuses_channels_outside_the_board() {
        let mut b = Lcus::new(Link::dry_run(), 4);
        assert!(matches!(
            b.set(Channel(5), true),
            Err(RelayError::ChannelOutOfRange { .. })
        ));
        assert!(b.take_sent().is_empty());
        b.all_off().unwrap();
        assert_eq!(b.take_sent().len(), 4);
    }
}
