//! Driver for the Numato Lab USB relay modules (1 to 32 relays, USB CDC serial).
//!
//! Protocol, from Numato's module documentation and their sample code
//! (<https://numato.com/docs/8-channel-usb-relay-module>,
//! <https://numato.com/kb/understanding-readallwriteall-commands-for-relay-modules/>, and
//! `usb_relay/usbrelay_16.py` in github.com/NumatoLab/NumatoIO_Python): human-readable ASCII
//! commands ended by a carriage return: `relay on N\r`, `relay off N\r`, `relay read N\r`
//! (answers `on` or `off`), `relay readall\r` and `relay writeall XX..\r` (a hexadecimal mask,
//! relay 0 in the lowest bit, two digits per 8 relays). Relays are numbered from 0; relays 10
//! and up are written as upper-case letters `A`, `B`, ... (not hexadecimal: they go past `F`).
//! The module echoes the command, then `\n\r`, then any answer followed by `\n\r`, then the
//! prompt `>`: this driver reads up to the prompt after every command, so echoes never pile up.
//! Baud is ignored by the CDC device (19200 in Numato's samples). Channel c here is relay c-1.

use super::{check_channel, BoardKind, Channel, Link, RelayBoard, RelayError};

/// The largest modules have 32 relays (`0`..`9`, `A`..`V`).
pub const MAX_CHANNELS: u16 = 32;

/// The relay index character for a channel (channel 1 is relay `0`, channel 11 relay `A`).
pub fn relay_index(channel: Channel) -> char {
    let i = channel.0.saturating_sub(1) as u8;
    if i < 10 {
        (b'0' + i) as char
    } else {
        (b'A' + (i - 10)) as char
    }
}

/// The command switching `channel` on or off.
pub fn set_command(channel: Channel, on: bool) -> String {
    format!(
        "relay {} {}\r",
        if on { "on" } else { "off" },
        relay_index(channel)
    )
}

/// Hex digits `readall`/`writeall` use for a module with `channels` relays (None: no such
/// command for that size).
pub fn mask_digits(channels: u16) -> Option<usize> {
    match channels {
        8 | 16 | 32 => Some(channels as usize / 4),
        _ => None,
    }
}

/// A Numato module on a link.
pub struct Numato {
    link: Link,
    channels: u16,
}

impl Numato {
    /// A module driving `channels` relays (checked against [`MAX_CHANNELS`] where the settings
    /// are), talking over `link`.
    pub fn new(link: Link, channels: u16) -> Numato {
        Numato { link, channels }
    }

    /// Sends a command and returns the answer between the echo and the prompt (`None` in a dry
    /// run).
    fn command(&mut self, cmd: &str) -> Result<Option<String>, RelayError> {
        self.link.send(cmd.as_bytes())?;
        let Some(reply) = self.link.recv_until(BoardKind::Numato, b'>', 256)? else {
            return Ok(None);
        };
        let text = String::from_utf8_lossy(&reply).into_owned();
        let echo = cmd.trim_end_matches('\r');
        let rest = text
            .strip_prefix(echo)
            .ok_or_else(|| RelayError::BadReply {
                board: BoardKind::Numato,
                expected: format!("the echo of '{echo}' then the prompt '>'"),
                got: reply.clone(),
            })?;
        let answer = rest
            .trim_end_matches('>')
            .trim_matches(|c: char| c == '\r' || c == '\n' || c == ' ');
        Ok(Some(answer.to_string()))
    }

    fn bad(&self, expected: String, answer: &str) -> RelayError {
        RelayError::BadReply {
            board: BoardKind::Numato,
            expected,
            got: answer.as_bytes().to_vec(),
        }
    }
}

impl RelayBoard for Numato {
    fn kind(&self) -> BoardKind {
        BoardKind::Numato
    }

    fn set(&mut self, channel: Channel, on: bool) -> Result<(), RelayError> {
        check_channel(BoardKind::Numato, channel, self.channels)?;
        self.command(&set_command(channel, on)).map(|_| ())
    }

    fn all_off(&mut self) -> Result<(), RelayError> {
        match mask_digits(self.channels) {
            Some(d) => self
                .command(&format!("relay writeall {}\r", "0".repeat(d)))
                .map(|_| ()),
            None => {
                for ch in 1..=self.channels {
                    self.command(&set_command(Channel(ch), false))?;
                }
                Ok(())
            }
        }
    }

    fn read_back(&self) -> Result<(), RelayError> {
        Ok(())
    }

    fn read_states(&mut self) -> Result<Option<Vec<bool>>, RelayError> {
        let n = self.channels;
        match mask_digits(n) {
            Some(d) => {
                let Some(ans) = self.command("relay readall\r")? else {
                    return Ok(None);
                };
                let mask = (ans.len() == d)
                    .then(|| u64::from_str_radix(&ans, 16).ok())
                    .flatten()
                    .ok_or_else(|| self.bad(format!("{d} hexadecimal digits"), &ans))?;
                Ok(Some((0..n).map(|i| mask >> i & 1 == 1).collect()))
            }
            None => {
                let mut states = Vec::with_capacity(n as usize);
                for ch in 1..=n {
                    let cmd = format!("relay read {}\r", relay_index(Channel(ch)));
                    let Some(ans) = self.command(&cmd)? else {
                        return Ok(None);
                    };
                    states.push(match ans.as_str() {
                        "on" => true,
                        "off" => false,
                        _ => return Err(self.bad("'on' or 'off'".into(), &ans)),
                    });
                }
                Ok(Some(states))
            }
        }
    }

    fn take_sent(&mut self) -> Vec<Vec<u8>> {
        self.link.take_sent()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn commands_use_letters_from_relay_ten() {
        assert_eq!(set_command(Channel(1), true), "relay on 0\r");
        assert_eq!(set_command(Channel(10), false), "relay off 9\r");
        assert_eq!(set_command(Channel(11), true), "relay on A\r");
        assert_eq!(set_command(Channel(15), true), "relay on E\r");
        assert_eq!(set_command(Channel(32), true), "relay on V\r");
    }

    #[test]
    fn all_off_uses_writeall_with_the_module_width() {
        let mut b = Numato::new(Link::dry_run(), 16);
        b.all_off().unwrap();
        assert_eq!(b.take_sent(), vec![b"relay writeall 0000\r".to_vec()]);
        let mut b = Numato::new(Link::dry_run(), 2);
        b.all_off().unwrap();
        assert_eq!(
            b.take_sent(),
            vec![b"relay off 0\r".to_vec(), b"relay off 1\r".to_vec()]
        );
    }
}
