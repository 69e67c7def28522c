//! Several relay boards in one replay: the `[[relay.boards]]` entries of a `[relay]` section
//! (each board with its own port, type and serial settings) as written and checked, with the
//! serial defaults and bounds every board shares. Every error names the field
//! (`relay.boards[1].channels`) and what was expected. The coil map that goes with a list of
//! boards (`coil = "board:channel"`) is read in `config`.

use super::fields::{Fields, Result};
use super::{BoardKind, BoardSpec};
use serde::Deserialize;
use std::time::Duration;

/// The modbus slave address when none is given.
pub const DEFAULT_SLAVE_ADDRESS: u8 = 1;
/// The time to wait for a board's reply when none is given, ms.
pub const DEFAULT_TIMEOUT_MS: f64 = 1000.0;
/// The longest `timeout_ms` accepted (a minute).
pub const MAX_TIMEOUT_MS: f64 = 60_000.0;

/// A board's reply timeout, `timeout_ms`: above 0, at most [`MAX_TIMEOUT_MS`].
pub(super) fn reply_timeout(f: &Fields, field: &str, v: Option<f64>) -> Result<Duration> {
    f.millis(field, v, DEFAULT_TIMEOUT_MS, false, MAX_TIMEOUT_MS)
}

/// One `[[relay.boards]]` entry as written.
#[derive(Debug, Default, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct BoardConfig {
    /// The serial device, e.g. `/dev/ttyUSB0` (`--port`, once per board, overrides).
    pub port: Option<String>,
    /// lcus, kmtronic, numato or modbus (required).
    pub board: Option<String>,
    /// Baud rate; default the vendor's.
    pub baud: Option<i64>,
    /// Channels on the board; default 8 (lcus, kmtronic) or 16 (numato, modbus).
    pub channels: Option<i64>,
    /// Modbus slave address 1..=247.
    pub slave_address: Option<i64>,
    /// How long to wait for this board's reply, ms.
    pub timeout_ms: Option<f64>,
}

/// Checks the `[[relay.boards]]` entries: at least one, each valid, no port used twice.
pub(super) fn check_boards(f: &Fields, list: Vec<BoardConfig>) -> Result<Vec<BoardSpec>> {
    if list.is_empty() {
        return Err(f.err("boards", "at least one [[relay.boards]] entry".to_string()));
    }
    let mut out: Vec<BoardSpec> = Vec::with_capacity(list.len());
    for (i, raw) in list.into_iter().enumerate() {
        let spec = check_board(f, i, raw)?;
        if let Some(port) = &spec.port {
            if let Some(j) = out.iter().position(|b| b.port.as_ref() == Some(port)) {
                return Err(f.err(
                    &format!("boards[{i}].port"),
                    format!("a port no other board uses, got {port}, already board {j}'s"),
                ));
            }
        }
        out.push(spec);
    }
    Ok(out)
}

/// Checks one `[[relay.boards]]` entry (number `i`, 0-based).
fn check_board(f: &Fields, i: usize, raw: BoardConfig) -> Result<BoardSpec> {
    let field = |key: &str| format!("boards[{i}].{key}");
    let kind = match raw.board.as_deref() {
        None => {
            return Err(f.err(
                &field("board"),
                "the board's type: lcus, kmtronic, numato or modbus".to_string(),
            ))
        }
        Some(s) => s
            .parse::<BoardKind>()
            // the parse error reads "expected ...": the field error says "expected" itself
            .map_err(|m| f.err(&field("board"), m.trim_start_matches("expected ").into()))?,
    };
    let max = kind.max_channels();
    let channels = match raw.channels {
        None => kind.default_channels(),
        Some(c) if (1..=i64::from(max)).contains(&c) => c as u16,
        Some(c) => {
            return Err(f.err(
                &field("channels"),
                format!("an integer in 1..={max} for a {kind} board, got {c}"),
            ))
        }
    };
    let port = match raw.port {
        Some(p) if p.trim().is_empty() => {
            return Err(f.err(
                &field("port"),
                "a serial device such as /dev/ttyUSB0, got an empty string".to_string(),
            ))
        }
        p => p,
    };
    let timeout = reply_timeout(f, &field("timeout_ms"), raw.timeout_ms)?;
    Ok(BoardSpec {
        kind,
        channels,
        baud: f
            .int(&field("baud"), raw.baud, 1, 4_000_000)?
            .map_or(kind.default_baud(), |b| b as u32),
        slave_address: f
            .int(&field("slave_address"), raw.slave_address, 1, 247)?
            .map_or(DEFAULT_SLAVE_ADDRESS, |a| a as u8),
        timeout,
        port,
    })
}

#[cfg(test)]
mod tests {
    use crate::model::geometry::CoilId;
    use crate::relay::{Channel, RelaySettings, Slot};
    use std::path::Path;

    const TWO: &str = "[[boards]]\nport = \"/dev/a\"\nboard = \"lcus\"\n[[boards]]\nport = \"/dev/b\"\nboard = \"modbus\"\nchannels = 4\n";

    fn err(text: &str) -> String {
        RelaySettings::from_map_toml(text, Path::new("m.toml"))
            .unwrap_err()
            .to_string()
    }

    #[test]
    fn boards_and_laid_map() {
        let s = RelaySettings::from_map_toml(TWO, Path::new("m.toml")).unwrap();
        assert_eq!(s.boards.len(), 2);
        assert_eq!(s.boards[0].channels, 8);
        assert_eq!(s.boards[1].baud, 9600);
        assert_eq!(s.boards[1].port.as_deref(), Some("/dev/b"));
        let slot = |b, c| {
            Some(Slot {
                board: b,
                channel: Channel(c),
            })
        };
        assert_eq!(s.map.slot(CoilId(0)), slot(0, 1));
        assert_eq!(s.map.slot(CoilId(7)), slot(0, 8));
        assert_eq!(s.map.slot(CoilId(8)), slot(1, 1));
        assert_eq!(s.map.slot(CoilId(11)), slot(1, 4));
        assert_eq!(s.map.slot(CoilId(12)), None);
        let s = RelaySettings::from_map_toml(
            &format!("{TWO}[map]\n0 = \"1:4\"\n5 = \" 0 : 2 \"\n"),
            Path::new("m.toml"),
        )
        .unwrap();
        assert_eq!(s.map.slot(CoilId(0)), slot(1, 4));
        assert_eq!(s.map.slot(CoilId(5)), slot(0, 2));
        assert_eq!(s.map.slot(CoilId(1)), None);
    }

    #[test]
    fn entries_and_map_values_are_checked_by_name() {
        let e = err(&format!("board = \"lcus\"\n{TWO}"));
        assert!(
            e.contains("field `board`") && e.contains("[[relay.boards]]"),
            "{e}"
        );
        let e = err("[[boards]]\nport = \"/dev/a\"\n");
        assert!(e.contains("`boards[0].board`"), "{e}");
        let e = err("[[boards]]\nboard = \"lcus\"\nchannels = 9\n");
        assert!(
            e.contains("`boards[0].channels`") && e.contains("1..=8"),
            "{e}"
        );
        let e = err("[[boards]]\nboard = \"lcus\"\nport = \"/dev/a\"\n[[boards]]\nboard = \"lcus\"\nport = \"/dev/a\"\n");
        assert!(
            e.contains("`boards[1].port`") && e.contains("board 0's"),
            "{e}"
        );
        let e = err("[[boards]]\nboard = \"lcus\"\nspeed = 1\n");
        assert!(e.contains("speed"), "{e}");
        let e = err(&format!("{TWO}[map]\n3 = 2\n"));
        assert!(e.contains("`map.3`") && e.contains("bare channel"), "{e}");
        let e = err(&format!("{TWO}[map]\n3 = \"12\"\n"));
        assert!(
            e.contains("`map.3`") && e.contains("\"board:channel\""),
            "{e}"
        );
        let e = err("[map]\n3 = \"0:1\"\n");
        assert!(
            e.contains("`map.3`") && e.contains("need [[relay.boards]]"),
            "{e}"
        );
    }
}
