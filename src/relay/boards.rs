//! Several relay boards in one replay: the `[[relay.boards]]` entries of a `[relay]` section
//! (each board with its own port, type and serial settings) as written and checked, and the
//! coil map that goes with them (`coil = "board:channel"`, boards 0-based in list order,
//! channels 1-based as printed). Every error names the field (`relay.boards[1].channels`,
//! `relay.map.3`) and what was expected.

use super::config::{coil_key, Fields, DEFAULT_SLAVE_ADDRESS};
use super::{BoardKind, BoardSpec, Channel, CoilMap, RelayConfig, Slot};
use crate::error::Result;
use crate::model::geometry::CoilId;
use serde::Deserialize;
use std::collections::BTreeMap;

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

/// With `[[relay.boards]]`, the keys describing one board at the top of `[relay]` are refused:
/// they belong in the entries.
pub(super) fn refuse_single_board_keys(raw: &RelayConfig, f: &Fields) -> Result<()> {
    let given = [
        ("board", raw.board.is_some()),
        ("baud", raw.baud.is_some()),
        ("channels", raw.channels.is_some()),
        ("slave_address", raw.slave_address.is_some()),
        ("timeout_ms", raw.timeout_ms.is_some()),
    ];
    match given.iter().find(|(_, set)| *set) {
        None => Ok(()),
        Some((key, _)) => Err(f.err(
            key,
            format!(
                "no top-level `{key}` next to [[relay.boards]]: one board is described at the top of [relay], several as [[relay.boards]] entries, each with its own `{key}`"
            ),
        )),
    }
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
    let timeout = f.timeout(&field("timeout_ms"), raw.timeout_ms)?;
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

/// The `[relay.map]` table with `[[relay.boards]]`: coil index -> `"board:channel"`, the board
/// one of the list and the channel one of its own, each board channel used once.
pub(super) fn slot_map(
    f: &Fields,
    m: BTreeMap<String, toml::Value>,
    boards: &[BoardSpec],
) -> Result<CoilMap> {
    let mut out = BTreeMap::new();
    let mut used: BTreeMap<Slot, CoilId> = BTreeMap::new();
    for (k, v) in m {
        let field = format!("map.{k}");
        let coil = coil_key(f, &field, &k)?;
        let slot = slot_value(f, &field, &v, boards)?;
        if let Some(other) = used.insert(slot, coil) {
            return Err(f.err(
                &field,
                format!(
                    "a board channel no other coil uses, got \"{slot}\" (board {}, channel {}), already coil {other}'s",
                    slot.board, slot.channel
                ),
            ));
        }
        out.insert(coil, slot);
    }
    Ok(CoilMap::Slots(out))
}

/// One `[relay.map]` value with `[[relay.boards]]`: `"board:channel"`, checked against the
/// boards.
fn slot_value(f: &Fields, field: &str, v: &toml::Value, boards: &[BoardSpec]) -> Result<Slot> {
    let last = boards.len().saturating_sub(1);
    let form = format!(
        "\"board:channel\" such as \"0:1\" (board 0..={last} in [[relay.boards]] order, channel from 1)"
    );
    let text = match v {
        toml::Value::String(s) => s.as_str(),
        toml::Value::Integer(n) => {
            return Err(f.err(
                field,
                format!(
                "{form}; with [[relay.boards]] a bare channel does not say which board, got {n}"
            ),
            ))
        }
        other => return Err(f.err(field, format!("{form}, got {other}"))),
    };
    let parsed = text.split_once(':').and_then(|(b, c)| {
        Some((
            b.trim().parse::<usize>().ok()?,
            c.trim().parse::<u16>().ok()?,
        ))
    });
    let Some((board, channel)) = parsed else {
        return Err(f.err(field, format!("{form}, got \"{text}\"")));
    };
    let Some(spec) = boards.get(board) else {
        return Err(f.err(
            field,
            format!(
                "a board of [[relay.boards]], 0..={last} ({} listed), got board {board} in \"{text}\"",
                boards.len()
            ),
        ));
    };
    if channel == 0 || channel > spec.channels {
        return Err(f.err(
            field,
            format!(
                "a channel of board {board} ({} board, channels 1..={}), got channel {channel} in \"{text}\"",
                spec.kind, spec.channels
            ),
        ));
    }
    Ok(Slot {
        board,
        channel: Channel(channel),
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::relay::RelaySettings;
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
