//! Replay settings: the `[relay]` section of a scenario, or the same keys at the top of a small
//! TOML map file (`replay --map FILE`). Which relay channel drives which stator coil, the board
//! (or the boards, `[[relay.boards]]`, checked in `super::boards`), its serial settings, and the
//! safety limits. Unknown keys are refused; every value is checked and an error names the file
//! and the field.

use super::boards::{self, reply_timeout, BoardConfig};
pub use super::boards::{DEFAULT_SLAVE_ADDRESS, DEFAULT_TIMEOUT_MS, MAX_TIMEOUT_MS};
use super::fields::{coil_key, ConfigError, Fields, Result};
use super::{BoardKind, BoardSpec, Channel, Slot};
use crate::model::geometry::CoilId;
use serde::Deserialize;
use std::collections::BTreeMap;
use std::path::Path;
use std::time::Duration;

/// Default limit on coils on at once: the supply gives 100 W at 24 V; at about 1 A per coil
/// (25 W) that is four coils. Set it from your coils' measured current.
pub const DEFAULT_MAX_COILS_ON: usize = crate::planning::commutation::DEFAULT_MAX_COILS_ON;
/// Default limit on one coil's continuous on-time, s.
pub const DEFAULT_MAX_ON_TIME_S: f64 = crate::planning::on_time::DEFAULT_MAX_ON_TIME_S;
/// Default dwell: the predicted settle time times this factor...
pub const DEFAULT_DWELL_FACTOR: f64 = crate::planning::on_time::DEFAULT_DWELL_FACTOR;
/// ...but at least this long, ms (relays take a few ms to close, the ball longer to settle).
pub const DEFAULT_DWELL_FLOOR_MS: f64 = crate::planning::on_time::DEFAULT_DWELL_FLOOR_MS;
/// What a closed loop counts for each replan by default, ms (`replan_reserve_ms`).
pub const DEFAULT_REPLAN_RESERVE_MS: f64 = crate::planning::on_time::DEFAULT_REPLAN_RESERVE_MS;
/// The longest `max_on_time_s` accepted (a day).
pub const MAX_ON_TIME_LIMIT_S: f64 = 86_400.0;
/// The longest `dwell_floor_ms` accepted (an hour).
pub const MAX_DWELL_FLOOR_MS: f64 = 3_600_000.0;

/// The order of the two halves of a step.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Deserialize, Default)]
#[serde(rename_all = "kebab-case")]
pub enum SwitchOrder {
    /// The new coils go on before the released ones go off: the ball stays held (default).
    #[default]
    MakeBeforeBreak,
    /// The released coils go off first: fewer coils on at once, the ball briefly less held.
    BreakBeforeMake,
}

/// The `[relay]` section as written (every key optional). One board is described by the keys
/// `board`, `baud`, `slave_address`, `channels` and `timeout_ms` here; several by `boards`
/// (`[[relay.boards]]`, each entry with those keys and its `port`), never both.
#[derive(Debug, Default, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RelayConfig {
    /// lcus, kmtronic, numato or modbus (`--board` overrides).
    pub board: Option<String>,
    /// Baud rate (`--baud` overrides); default the vendor's.
    pub baud: Option<i64>,
    /// Modbus slave address 1..=247.
    pub slave_address: Option<i64>,
    /// Channels on the board; default 8 (lcus, kmtronic) or 16 (numato, modbus).
    pub channels: Option<i64>,
    /// How long to wait for a board's reply, ms.
    pub timeout_ms: Option<f64>,
    /// Most coils on at once.
    pub max_coils_on: Option<i64>,
    /// Longest continuous on-time of one coil, s.
    pub max_on_time_s: Option<f64>,
    /// Dwell = predicted settle time x this factor...
    pub dwell_factor: Option<f64>,
    /// ...and at least this many ms.
    pub dwell_floor_ms: Option<f64>,
    /// What a closed loop counts against the coils holding the ball while it replans, ms.
    pub replan_reserve_ms: Option<f64>,
    /// "make-before-break" (default) or "break-before-make".
    pub order: Option<SwitchOrder>,
    /// Several boards, in order (board 0 first): `[[relay.boards]]`.
    pub boards: Option<Vec<BoardConfig>>,
    /// Coil (0-based, as a key) to channel (1-based): `[relay.map]` with `0 = 1`, `1 = 2`, ...;
    /// with `boards`, to `"board:channel"` (`0 = "0:1"`, `15 = "1:8"`). Without it, coil i is
    /// on channel i + 1 (with `boards`: laid onto the boards in order).
    pub map: Option<BTreeMap<String, toml::Value>>,
}

/// Which channel (of which board) drives which coil.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum CoilMap {
    /// One board: coil i on channel i + 1.
    Default,
    /// One board: only the listed coils are driven.
    Explicit(BTreeMap<CoilId, Channel>),
    /// `[[relay.boards]]` and no map: the coils laid onto the boards in order (coil 0 on board
    /// 0 channel 1, ..., then board 1 channel 1, ...); the boards' channel counts.
    Laid(Vec<u16>),
    /// `[[relay.boards]]`: only the listed coils are driven, each on a board's channel.
    Slots(BTreeMap<CoilId, Slot>),
}

impl CoilMap {
    /// The channel driving `coil` (on whichever board), if any.
    pub fn channel(&self, coil: CoilId) -> Option<Channel> {
        self.slot(coil).map(|s| s.channel)
    }

    /// The board and channel driving `coil`, if any (board 0 with a single board).
    pub fn slot(&self, coil: CoilId) -> Option<Slot> {
        let on_board_0 = |channel| Slot { board: 0, channel };
        match self {
            CoilMap::Default => u16::try_from(coil.0 + 1).ok().map(Channel).map(on_board_0),
            CoilMap::Explicit(m) => m.get(&coil).copied().map(on_board_0),
            CoilMap::Laid(counts) => {
                let mut k = coil.0;
                for (board, &n) in counts.iter().enumerate() {
                    let n = usize::from(n);
                    if k < n {
                        let channel = Channel(u16::try_from(k + 1).ok()?);
                        return Some(Slot { board, channel });
                    }
                    k -= n;
                }
                None
            }
            CoilMap::Slots(m) => m.get(&coil).copied(),
        }
    }
}

/// Checked replay settings. With a single board, `board`, `baud`, `slave_address`, `channels`
/// and `timeout` describe it (the command line may override the first two) and `boards` is
/// empty; with `[[relay.boards]]`, `boards` holds them (those fields are then unset or default
/// and unused).
#[derive(Debug, Clone, PartialEq)]
pub struct RelaySettings {
    /// `relay.board`: the single board's type (`None` with `[[relay.boards]]`, or when only the
    /// command line gives it).
    pub board: Option<BoardKind>,
    /// `relay.baud`: the single board's baud rate, bits per second (`None`: the type's default).
    pub baud: Option<u32>,
    /// `relay.slave_address`: the single Modbus board's slave address.
    pub slave_address: u8,
    /// `relay.channels`: the single board's channel count (`None`: the type's default).
    pub channels: Option<u16>,
    /// `relay.timeout_ms`: how long the single board's reply is awaited.
    pub timeout: Duration,
    /// `relay.max_coils_on`: the most coils on at once, all boards together (the supply).
    pub max_coils_on: usize,
    /// `relay.max_on_time_s`: one coil's longest continuous on-time (heat).
    pub max_on_time: Duration,
    /// `relay.dwell_factor`: a step's dwell is its settle time times this (positive).
    pub dwell_factor: f64,
    /// `relay.dwell_floor_ms`: the shortest dwell derived from a settle time.
    pub dwell_floor: Duration,
    /// `replan_reserve_ms`: see [`crate::planning::on_time::OnTimeLimit::replan_reserve`].
    pub replan_reserve: Duration,
    /// `relay.order`: which relays of a step switch first.
    pub order: SwitchOrder,
    /// Which board and channel drive each coil (`[relay.map]`, or a `--map` file).
    pub map: CoilMap,
    /// `[[relay.boards]]`, checked (empty: the single-board form).
    pub boards: Vec<BoardSpec>,
}

impl Default for RelaySettings {
    fn default() -> Self {
        RelaySettings::from_config(RelayConfig::default(), Path::new("<defaults>"), "")
            .expect("the defaults are valid")
    }
}

impl RelaySettings {
    /// Checks a `[relay]` section; `prefix` is how fields are named in errors (`relay.` in a
    /// scenario, empty in a map file).
    pub fn from_config(mut raw: RelayConfig, file: &Path, prefix: &str) -> Result<RelaySettings> {
        let f = Fields { file, prefix };
        let listed = match raw.boards.take() {
            None => Vec::new(),
            Some(list) => {
                refuse_single_board_keys(&raw, &f)?;
                boards::check_boards(&f, list)?
            }
        };
        let one = single_board(&raw, &f)?;
        let dwell_floor = f.millis(
            "dwell_floor_ms",
            raw.dwell_floor_ms,
            DEFAULT_DWELL_FLOOR_MS,
            true,
            MAX_DWELL_FLOOR_MS,
        )?;
        let replan_reserve = f.millis(
            "replan_reserve_ms",
            raw.replan_reserve_ms,
            DEFAULT_REPLAN_RESERVE_MS,
            true,
            MAX_DWELL_FLOOR_MS,
        )?;
        let map = match (raw.map, listed.is_empty()) {
            (None, true) => CoilMap::Default,
            (None, false) => CoilMap::Laid(listed.iter().map(|b| b.channels).collect()),
            (Some(m), true) => coil_map(&f, m)?,
            (Some(m), false) => slot_map(&f, m, &listed)?,
        };
        Ok(RelaySettings {
            board: one.board,
            baud: one.baud,
            slave_address: one.slave_address,
            channels: one.channels,
            timeout: one.timeout,
            max_coils_on: f
                .int("max_coils_on", raw.max_coils_on, 1, 1000)?
                .map_or(DEFAULT_MAX_COILS_ON, |m| m as usize),
            max_on_time: f.seconds(
                "max_on_time_s",
                raw.max_on_time_s,
                DEFAULT_MAX_ON_TIME_S,
                MAX_ON_TIME_LIMIT_S,
            )?,
            dwell_factor: f.positive("dwell_factor", raw.dwell_factor, DEFAULT_DWELL_FACTOR)?,
            dwell_floor,
            replan_reserve,
            order: raw.order.unwrap_or_default(),
            map,
            boards: listed,
        })
    }

    /// The on-time limit and the dwells, as the planners keep to them.
    pub fn on_time_limit(&self) -> crate::planning::on_time::OnTimeLimit {
        crate::planning::on_time::OnTimeLimit {
            max_on: self.max_on_time,
            dwell_factor: self.dwell_factor,
            dwell_floor: self.dwell_floor,
            fixed_dwell: None,
            replan_reserve: self.replan_reserve,
        }
    }

    /// Parses relay settings written as a TOML map file (the `[relay]` keys at the top level).
    pub fn from_map_toml(text: &str, path: &Path) -> Result<RelaySettings> {
        let raw: RelayConfig = toml::from_str(text).map_err(|e| ConfigError::Parse {
            file: path.to_path_buf(),
            message: e.to_string().trim_end().to_string(),
        })?;
        RelaySettings::from_config(raw, path, "")
    }
}

/// The single-board keys at the top of `[relay]`, checked (all unset with `[[relay.boards]]`).
struct SingleBoard {
    board: Option<BoardKind>,
    baud: Option<u32>,
    slave_address: u8,
    channels: Option<u16>,
    timeout: Duration,
}

/// Checks the single-board keys at the top of `[relay]`.
fn single_board(raw: &RelayConfig, f: &Fields) -> Result<SingleBoard> {
    let board = match raw.board.as_deref() {
        None => None,
        // the parse error reads "expected ...": the field error says "expected" itself
        Some(s) => Some(
            s.parse::<BoardKind>()
                .map_err(|m| f.err("board", m.trim_start_matches("expected ").to_string()))?,
        ),
    };
    let max_channels = i64::from(super::modbus::MAX_CHANNELS);
    let channels = f
        .int("channels", raw.channels, 1, max_channels)?
        .map(|c| c as u16);
    if let (Some(b), Some(c)) = (board, channels) {
        if c > b.max_channels() {
            let hint = match b {
                BoardKind::Lcus => {
                    " (16 coils need a bigger board, e.g. numato or modbus, or two boards)"
                }
                _ => "",
            };
            let limit = b.max_channels();
            let expected = format!("at most {limit} for a {b} board, got {c}{hint}");
            return Err(f.err("channels", expected));
        }
    }
    let timeout = reply_timeout(f, "timeout_ms", raw.timeout_ms)?;
    Ok(SingleBoard {
        board,
        baud: f.int("baud", raw.baud, 1, 4_000_000)?.map(|b| b as u32),
        slave_address: f
            .int("slave_address", raw.slave_address, 1, 247)?
            .map_or(DEFAULT_SLAVE_ADDRESS, |a| a as u8),
        channels,
        timeout,
    })
}

/// The `[relay.map]` table of a single board: coil index -> channel, each channel used once.
fn coil_map(f: &Fields, m: BTreeMap<String, toml::Value>) -> Result<CoilMap> {
    let mut out = BTreeMap::new();
    let mut used: BTreeMap<Channel, CoilId> = BTreeMap::new();
    for (k, v) in m {
        let field = format!("map.{k}");
        let coil = coil_key(f, &field, &k)?;
        let v = match v {
            toml::Value::Integer(v) => v,
            toml::Value::String(s) => {
                return Err(f.err(
                    &field,
                    format!("a channel number (1, 2, ...); \"board:channel\" values need [[relay.boards]], got \"{s}\""),
                ))
            }
            other => return Err(f.err(&field, format!("a channel number (1, 2, ...), got {other}"))),
        };
        let ch = f
            .int(&field, Some(v), 1, i64::from(u16::MAX))?
            .map(|c| Channel(c as u16))
            .unwrap_or(Channel(1));
        if let Some(other) = used.insert(ch, coil) {
            return Err(f.err(
                &field,
                format!("a channel no other coil uses, got {ch}, already coil {other}'s"),
            ));
        }
        out.insert(coil, ch);
    }
    Ok(CoilMap::Explicit(out))
}

/// With `[[relay.boards]]`, the keys describing one board at the top of `[relay]` are refused:
/// they belong in the entries.
fn refuse_single_board_keys(raw: &RelayConfig, f: &Fields) -> Result<()> {
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

/// The `[relay.map]` table with `[[relay.boards]]`: coil index -> `"board:channel"`, the board
/// one of the list and the channel one of its own, each board channel used once.
fn slot_map(f: &Fields, m: BTreeMap<String, toml::Value>, boards: &[BoardSpec]) -> Result<CoilMap> {
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

    #[test]
    fn defaults_and_map() {
        let s = RelaySettings::default();
        assert_eq!(s.map.channel(CoilId(0)), Some(Channel(1)));
        assert_eq!(s.map.channel(CoilId(15)), Some(Channel(16)));
        assert_eq!(s.order, SwitchOrder::MakeBeforeBreak);
        let s = RelaySettings::from_map_toml(
            "board = \"numato\"\norder = \"break-before-make\"\n[map]\n0 = 3\n5 = 1\n",
            Path::new("m.toml"),
        )
        .unwrap();
        assert_eq!(s.board, Some(BoardKind::Numato));
        assert_eq!(s.order, SwitchOrder::BreakBeforeMake);
        assert_eq!(s.map.channel(CoilId(5)), Some(Channel(1)));
        assert_eq!(s.map.channel(CoilId(1)), None);
    }

    #[test]
    fn errors_name_file_and_field() {
        let e = RelaySettings::from_map_toml("[map]\n0 = 1\n1 = 1\n", Path::new("m.toml"))
            .unwrap_err()
            .to_string();
        assert!(e.contains("m.toml") && e.contains("map.1"), "{e}");
        let e =
            RelaySettings::from_map_toml("board = \"lcus\"\nchannels = 16\n", Path::new("m.toml"))
                .unwrap_err()
                .to_string();
        assert!(e.contains("`channels`") && e.contains("at most 8"), "{e}");
        let e = RelaySettings::from_map_toml("bord = \"lcus\"\n", Path::new("m.toml"))
            .unwrap_err()
            .to_string();
        assert!(e.contains("m.toml") && e.contains("bord"), "{e}");
        let e = RelaySettings::from_map_toml("slave_address = 300\n", Path::new("m.toml"))
            .unwrap_err()
            .to_string();
        assert!(e.contains("slave_address") && e.contains("1..=247"), "{e}");
    }
}
