//! The replay's schedule: a plan's steps turned into relay switching, board by board and
//! channel by channel, checked against the coil limits before anything is sent.

use crate::model::geometry::CoilId;
use crate::planning::on_time;
use crate::planning::plan::PlanRow;
use crate::relay::{
    BoardKind, BoardSpec, Channel, CoilMap, OnTimeAdvice, RelayError, RelaySettings, Setting, Slot,
    SwitchOrder,
};
use std::collections::{BTreeMap, BTreeSet};
use std::str::FromStr;
use std::time::Duration;

/// How the replay advances.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Mode {
    /// Switch, wait the dwell, go on (the paper's "pseudo-realtime").
    Realtime,
    /// Wait for Enter before each step (`q` quits).
    Step,
}

impl FromStr for Mode {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        match s.trim().to_ascii_lowercase().as_str() {
            "realtime" => Ok(Mode::Realtime),
            "step" => Ok(Mode::Step),
            _ => Err(format!("expected realtime or step, got '{s}'")),
        }
    }
}

/// One relay switched: a coil, on its board (0 with a single board) and channel.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Switch {
    /// The coil the relay drives.
    pub coil: CoilId,
    /// Its board, 0-based in `[[relay.boards]]` order (0 with a single board).
    pub board: usize,
    /// Its channel on that board, 1-based.
    pub channel: Channel,
    /// `true`: switched on; `false`: off.
    pub on: bool,
}

impl Switch {
    /// Where the relay is.
    pub fn slot(&self) -> Slot {
        Slot {
            board: self.board,
            channel: self.channel,
        }
    }
}

/// One entry of the schedule: a plan step (or, when resuming, the re-energising of the step
/// before the first one replayed).
#[derive(Debug, Clone, PartialEq)]
pub struct Entry {
    /// The plan step, as the plan numbers it.
    pub step: usize,
    /// Re-energises `step`'s active set to hold the ball before resuming at `step + 1`.
    pub hold: bool,
    /// The switching, in the order it is sent.
    pub switches: Vec<Switch>,
    /// What is on after the entry, by board and channel.
    pub on_after: BTreeMap<Slot, CoilId>,
    /// The most coils on at any moment of the entry, all boards together.
    pub peak: usize,
    /// Time to wait after switching (realtime).
    pub dwell: Duration,
    /// The dwell comes from a settle time that is no settle: the step never settled in the
    /// plan (`settled = false`, its settle time t_max), so the replay says so when it waits.
    pub unsettled: bool,
}

/// The whole replay, worked out and checked before anything is sent.
#[derive(Debug, Clone, PartialEq)]
pub struct Schedule {
    /// The entries in the order they are replayed.
    pub entries: Vec<Entry>,
}

/// The dwell of a plan row: the override as given, or settle time x factor, at least the floor
/// (the planners' own computation, [`crate::planning::on_time::OnTimeLimit::dwell`]).
pub fn dwell(
    row: &PlanRow,
    settings: &RelaySettings,
    dwell_override: Option<Duration>,
) -> Duration {
    let limit = on_time::OnTimeLimit {
        fixed_dwell: dwell_override,
        ..settings.on_time_limit()
    };
    limit.dwell(row.settle_time_s)
}

/// `schedule_on` for a single board of type `board` with `channels` channels.
#[allow(clippy::too_many_arguments)]
pub fn schedule(
    rows: &[PlanRow],
    settings: &RelaySettings,
    board: BoardKind,
    channels: u16,
    stator_coils: usize,
    dwell_override: Option<Duration>,
    from_step: usize,
    mode: Mode,
) -> Result<Schedule, RelayError> {
    let spec = BoardSpec {
        kind: board,
        channels,
        baud: board.default_baud(),
        slave_address: settings.slave_address,
        timeout: settings.timeout,
        port: None,
    };
    let dwell = dwell_override;
    schedule_on(
        rows,
        settings,
        &[spec],
        stator_coils,
        dwell,
        from_step,
        mode,
    )
}

/// Works out the schedule of a plan on `boards` and checks it: every coil on the stator and
/// driven by a channel of a board, never more than `max_coils_on` coils on (all boards
/// together), and (realtime) no coil on longer than `max_on_time` in a row.
pub fn schedule_on(
    rows: &[PlanRow],
    settings: &RelaySettings,
    boards: &[BoardSpec],
    stator_coils: usize,
    dwell_override: Option<Duration>,
    from_step: usize,
    mode: Mode,
) -> Result<Schedule, RelayError> {
    if from_step >= rows.len() {
        return Err(RelayError::Setting {
            setting: Setting::FromStep,
            expected: format!(
                "a step of the plan, 0..={}, got {from_step}",
                rows.len().saturating_sub(1)
            ),
        });
    }
    let first = from_step.saturating_sub(1);
    let from = Resume {
        on: BTreeMap::new(),
        hold_first: from_step > 0,
    };
    let entries = entries_from(
        &rows[first..],
        settings,
        boards,
        stator_coils,
        dwell_override,
        from,
    )?;
    if mode == Mode::Realtime {
        let listed = !settings.boards.is_empty();
        check_on_time(&entries, settings.max_on_time, listed, BTreeMap::new())?;
    }
    Ok(Schedule { entries })
}

/// Where a run of entries starts from: what is on before it, and whether its first entry
/// re-energises a step (a resume) rather than switches one.
#[derive(Debug, Clone, Default)]
pub(crate) struct Resume {
    pub on: BTreeMap<Slot, CoilId>,
    pub hold_first: bool,
}

/// The entries of `rows`, in order, switching from what `from` says is on: every coil on the
/// stator and driven by a channel of a board, never more than `max_coils_on` coils on (all
/// boards together, counting the transitions).
pub(crate) fn entries_from(
    rows: &[PlanRow],
    settings: &RelaySettings,
    boards: &[BoardSpec],
    stator_coils: usize,
    dwell_override: Option<Duration>,
    from: Resume,
) -> Result<Vec<Entry>, RelayError> {
    let targets = rows.iter().map(|row| Target {
        step: row.step,
        coils: row.active.iter().map(|p| p.coil).collect(),
        dwell: dwell(row, settings, dwell_override),
        unsettled: !row.settled && dwell_override.is_none(),
    });
    entries_of(targets, settings, boards, stator_coils, from)
}

/// What one entry switches to: the coils on after it, and its dwell.
struct Target {
    step: usize,
    coils: Vec<CoilId>,
    dwell: Duration,
    unsettled: bool,
}

/// The entries switching to each of `targets` in turn from what `from` says is on, checked as
/// [`entries_from`] says.
fn entries_of(
    targets: impl Iterator<Item = Target>,
    settings: &RelaySettings,
    boards: &[BoardSpec],
    stator_coils: usize,
    from: Resume,
) -> Result<Vec<Entry>, RelayError> {
    let mut entries = Vec::new();
    let mut prev = from.on;
    for (k, t) in targets.enumerate() {
        let mut target = BTreeMap::new();
        for &coil in &t.coils {
            let slot = slot_of(coil, t.step, settings, boards, stator_coils)?;
            target.insert(slot, coil);
        }
        let (switches, peak) = transition(&prev, &target, settings.order);
        if peak > settings.max_coils_on {
            return Err(too_many_on(t.step, peak, &prev, &target, settings));
        }
        entries.push(Entry {
            step: t.step,
            hold: k == 0 && from.hold_first,
            switches,
            on_after: target.clone(),
            peak,
            dwell: t.dwell,
            unsettled: t.unsettled,
        });
        prev = target;
    }
    Ok(entries)
}

/// The schedule of a wiring check (`examples/hardware_check.rs`): each of `coils` on alone
/// for `on` (entry `2k` for the k-th coil), then nothing on for `on` (entry `2k + 1`); `None`:
/// every coil of the stator that a channel of the boards drives, in order. Checked as a plan's
/// schedule is (the coils mapped, coils on at once, each coil's on-time), so that the runner
/// plays it under the limits of a replay.
pub fn coil_check(
    coils: Option<&[CoilId]>,
    settings: &RelaySettings,
    boards: &[BoardSpec],
    stator_coils: usize,
    on: Duration,
) -> Result<Schedule, RelayError> {
    let driven = |c: CoilId| slot_of(c, 0, settings, boards, stator_coils);
    let coils: Vec<CoilId> = match coils {
        Some(c) => c.to_vec(),
        None => (0..stator_coils)
            .map(CoilId)
            .filter(|&c| driven(c).is_ok())
            .collect(),
    };
    if coils.is_empty() {
        // no coil is driven: why not the first
        driven(CoilId(0))?;
    }
    let targets = coils.iter().enumerate().flat_map(|(k, &coil)| {
        let target = |step, coils| Target {
            step,
            coils,
            dwell: on,
            unsettled: false,
        };
        [target(2 * k, vec![coil]), target(2 * k + 1, Vec::new())]
    });
    let entries = entries_of(targets, settings, boards, stator_coils, Resume::default())?;
    let listed = !settings.boards.is_empty();
    check_on_time(&entries, settings.max_on_time, listed, BTreeMap::new())?;
    Ok(Schedule { entries })
}

/// The switching from what is on (`prev`, by board and channel) to `target`, in the order it
/// is sent, and the most coils on at any moment of it.
fn transition(
    prev: &BTreeMap<Slot, CoilId>,
    target: &BTreeMap<Slot, CoilId>,
    order: SwitchOrder,
) -> (Vec<Switch>, usize) {
    let switches = |from: &BTreeMap<Slot, CoilId>, to: &BTreeMap<Slot, CoilId>, on| {
        from.iter()
            .filter(|(slot, _)| !to.contains_key(slot))
            .map(|(&slot, &coil)| Switch {
                coil,
                board: slot.board,
                channel: slot.channel,
                on,
            })
            .collect::<Vec<_>>()
    };
    let ons = switches(target, prev, true);
    let offs = switches(prev, target, false);
    match order {
        SwitchOrder::MakeBeforeBreak => (
            ons.iter().chain(&offs).copied().collect(),
            prev.len() + ons.len(),
        ),
        SwitchOrder::BreakBeforeMake => (
            offs.iter().chain(&ons).copied().collect(),
            prev.len().max(target.len()),
        ),
    }
}

/// The error of a step that would have `peak` coils on at once, naming them.
fn too_many_on(
    step: usize,
    peak: usize,
    prev: &BTreeMap<Slot, CoilId>,
    target: &BTreeMap<Slot, CoilId>,
    settings: &RelaySettings,
) -> RelayError {
    let coils: BTreeSet<CoilId> = prev.values().chain(target.values()).copied().collect();
    let names: Vec<String> = coils.iter().map(|c| c.to_string()).collect();
    RelayError::TooManyOn {
        step,
        count: peak,
        max: settings.max_coils_on,
        coils: format!("coils {}", names.join(", ")),
    }
}

/// The board and channel driving `coil` in plan step `step`, checked against the stator and
/// the boards.
fn slot_of(
    coil: CoilId,
    step: usize,
    settings: &RelaySettings,
    boards: &[BoardSpec],
    stator_coils: usize,
) -> Result<Slot, RelayError> {
    let unmapped = |reason: String| RelayError::Unmapped { step, coil, reason };
    if coil.0 >= stator_coils {
        return Err(unmapped(format!(
            "is not on the stator (the scenario has {stator_coils} coils)"
        )));
    }
    let slot = settings
        .map
        .slot(coil)
        .ok_or_else(|| unmapped(unmapped_reason(&settings.map)))?;
    if settings.boards.is_empty() {
        let (board, channels) = boards
            .first()
            .map_or((BoardKind::Lcus, 0), |b| (b.kind, b.channels));
        return single_channel(slot, board, channels).map_err(unmapped);
    }
    match boards.get(slot.board) {
        Some(b) if (1..=b.channels).contains(&slot.channel.0) => Ok(slot),
        Some(b) => Err(unmapped(format!(
            "is mapped to board {} channel {}, but board {} ({} board) has channels 1..={}",
            slot.board, slot.channel, slot.board, b.kind, b.channels
        ))),
        None => Err(unmapped(format!(
            "is mapped to board {}, but [[relay.boards]] lists {} boards",
            slot.board,
            boards.len()
        ))),
    }
}

/// Why no channel drives a coil, for each kind of map.
fn unmapped_reason(map: &CoilMap) -> String {
    match map {
        CoilMap::Laid(counts) => {
            let total: usize = counts.iter().map(|&n| usize::from(n)).sum();
            format!(
                "lies past the {total} channels of the {} boards (without [relay.map] the coils are laid onto [[relay.boards]] in order; give it a \"board:channel\" in [relay.map])",
                counts.len()
            )
        }
        CoilMap::Slots(_) => {
            "no relay channel drives (add it to [relay.map] as \"board:channel\", or to the map file)".into()
        }
        _ => "no relay channel drives (add it to [relay.map] or the map file)".into(),
    }
}

/// Checks a single board's channel against its count (the reason when it is past it).
fn single_channel(slot: Slot, board: BoardKind, channels: u16) -> Result<Slot, String> {
    let ch = slot.channel;
    if ch.0 > channels {
        let hint = if board == BoardKind::Lcus {
            format!(
                " (LCUS boards have at most {} channels: drive 16 coils from a 16-channel numato or modbus board, or map the coils this plan uses onto channels 1..={channels})",
                crate::relay::lcus::MAX_CHANNELS
            )
        } else {
            " (set relay.channels, or map the coil to a lower channel)".into()
        };
        return Err(format!(
            "is mapped to channel {ch}, but the {board} board has {channels} channels{hint}"
        ));
    }
    Ok(slot)
}

/// What is on before a run of entries, for the on-time check: by board and channel, the coil,
/// the step it went on in and how long it has been on.
pub(crate) type OnTimes = BTreeMap<Slot, (CoilId, usize, Duration)>;

/// Simulates the schedule: a coil's continuous on-time is the sum of the dwells while it stays
/// on, after the time it has been on already (`on`, empty for a schedule switched from all
/// off). `listed`: name the board in the error.
pub(crate) fn check_on_time(
    entries: &[Entry],
    max: Duration,
    listed: bool,
    on: OnTimes,
) -> Result<(), RelayError> {
    let mut held: on_time::OnTimes<Slot> = on
        .iter()
        .map(|(&s, &(_, since_step, on))| (s, on_time::Held { since_step, on }))
        .collect();
    for e in entries {
        on_time::hold(&mut held, e.on_after.keys().copied(), e.step, e.dwell);
        if let Some((slot, h)) = on_time::over(&held, max) {
            // what is held is what is on after the entry
            let coil = e.on_after.get(&slot).copied().unwrap_or(CoilId(0));
            let unsettled: Vec<String> = entries
                .iter()
                .filter(|x| x.unsettled && (h.since_step..=e.step).contains(&x.step))
                .map(|x| x.step.to_string())
                .collect();
            let unsettled = match unsettled.is_empty() {
                true => String::new(),
                false => format!(
                    " (step {} never settled in the plan: its settle time is t_max)",
                    unsettled.join(", ")
                ),
            };
            return Err(RelayError::OnTooLong {
                coil,
                board: listed.then_some(slot.board),
                channel: slot.channel,
                when: format!(
                    "would stay on from step {} through step {}{unsettled} for",
                    h.since_step, e.step
                ),
                on: h.on,
                max,
                advice: OnTimeAdvice::Dwell,
            });
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::geometry::Pair;
    use nalgebra::UnitQuaternion;

    fn row(step: usize, active: &[(usize, usize)], settle: f64) -> PlanRow {
        PlanRow {
            step,
            pivot: None,
            new: Vec::new(),
            active: active.iter().map(|&(c, m)| Pair::new(c, m)).collect(),
            q: UnitQuaternion::identity(),
            step_angle_deg: 0.0,
            step_axis_error_deg: 0.0,
            cum_angle_deg: 0.0,
            cum_axis_error_deg: 0.0,
            settle_time_s: settle,
            settled: true,
        }
    }

    #[test]
    fn dwell_is_settle_times_factor_at_least_the_floor() {
        let s = RelaySettings::default();
        assert_eq!(
            dwell(&row(0, &[], 0.1), &s, None),
            Duration::from_millis(200)
        );
        assert_eq!(
            dwell(&row(0, &[], 1.0), &s, None),
            Duration::from_millis(1500)
        );
        let fixed = Some(Duration::from_millis(7));
        assert_eq!(
            dwell(&row(0, &[], 1.0), &s, fixed),
            Duration::from_millis(7)
        );
    }

    #[test]
    fn resume_re_energises_the_step_before() {
        let rows = [
            row(0, &[(0, 1), (1, 2)], 0.1),
            row(1, &[(0, 1), (2, 3)], 0.1),
            row(2, &[(2, 3), (3, 4)], 0.1),
        ];
        let s = RelaySettings::default();
        let sc = schedule(&rows, &s, BoardKind::Lcus, 8, 16, None, 2, Mode::Realtime).unwrap();
        assert_eq!(sc.entries.len(), 2);
        let hold = &sc.entries[0];
        assert!(hold.hold && hold.step == 1);
        let on: Vec<u16> = hold.switches.iter().map(|w| w.channel.0).collect();
        assert_eq!(on, [1, 3]);
        let step = &sc.entries[1];
        assert_eq!(
            step.switches,
            [
                Switch {
                    coil: CoilId(3),
                    board: 0,
                    channel: Channel(4),
                    on: true
                },
                Switch {
                    coil: CoilId(0),
                    board: 0,
                    channel: Channel(1),
                    on: false
                },
            ]
        );
        assert_eq!(step.peak, 3);
        let e = schedule(&rows, &s, BoardKind::Lcus, 8, 16, None, 3, Mode::Realtime).unwrap_err();
        assert!(e.to_string().contains("`from_step`"), "{e}");
    }
}
