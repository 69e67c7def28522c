//! How long each coil stays on when a plan is replayed: the one computation that the planners
//! (which refuse steps that would keep a coil on past the limit) and `replay`'s schedule check
//! (which refuses a plan that does) share. A step's dwell is its predicted settle time times
//! the dwell factor, at least the dwell floor; a coil's continuous on-time is the sum of the
//! dwells of the consecutive steps it stays on in, counting the step that switched it on, each
//! with [`STEP_IO`] for the step's frames. A plan may keep a coil on for at most
//! [`budget`]: the limit less the margin ([`guard_margin`]) at which replay's runtime guard
//! switches every coil off, so that a plan within the limit on paper never meets the guard on
//! the wire.

use std::collections::BTreeMap;
use std::time::Duration;

/// The replay's timing and its on-time limit, as the planners see them (`[relay]`'s
/// `max_on_time_s`, `dwell_factor` and `dwell_floor_ms`).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct OnTimeLimit {
    /// One coil's longest continuous on-time.
    pub max_on: Duration,
    /// A step's dwell is its settle time times this...
    pub dwell_factor: f64,
    /// ...and at least this.
    pub dwell_floor: Duration,
    /// `replay --dwell-ms`: every step dwells this long instead.
    pub fixed_dwell: Option<Duration>,
    /// What a closed loop counts against the on-time of the coils on while it replans (the
    /// search from the measurement, with the last step's coils holding the ball), beside the
    /// reading in [`STEP_IO`] (`relay.replan_reserve_ms`, [`DEFAULT_REPLAN_RESERVE_MS`]).
    pub replan_reserve: Duration,
}

/// The default limit on one coil's continuous on-time, s (`relay.max_on_time_s`).
pub const DEFAULT_MAX_ON_TIME_S: f64 = 10.0;
/// The default dwell factor (`relay.dwell_factor`): dwell = predicted settle time x this...
pub const DEFAULT_DWELL_FACTOR: f64 = 1.5;
/// ...but at least this long, ms (`relay.dwell_floor_ms`).
pub const DEFAULT_DWELL_FLOOR_MS: f64 = 200.0;

/// What every step adds to the on-time of the coils it keeps on, besides its dwell: the step's
/// frames on every board (a USB relay frame and its reply take 1-5 ms, a Modbus frame and its
/// reply at 9600 baud about 20 ms), a `--verify` read back, and in a closed loop the sensor's
/// reading (a quat-csv line comes every 20 ms).
pub const STEP_IO: Duration = Duration::from_millis(20);

/// The default [`OnTimeLimit::replan_reserve`], ms: the closed-loop grid's replans of the
/// default planner on the prototype's plants take 91 ms at the median and 283 ms at most on a
/// 2-core machine (a decision on track, a few ms, is within [`STEP_IO`]); a coil-set model's
/// replans take seconds, and want a larger reserve. The replans plan with it, so that what they
/// keep on fits the limit on the wire too, and the simulated loop counts it as the hardware
/// loop does; `replay --sensor` checks each replan against the coils' measured on-times, which
/// count a longer search as it was.
pub const DEFAULT_REPLAN_RESERVE_MS: f64 = 500.0;

/// How far ahead of `relay.max_on_time_s` the runtime guard switches every coil off, at most
/// (a quarter of the limit below 400 ms): room for the guard's poll (10 ms, 5 ms in a board's
/// wait), a late wake-up of a loaded machine and the all-off frames of every board.
pub const GUARD_MARGIN: Duration = Duration::from_millis(100);

/// The guard's margin under a limit of `max_on`: [`GUARD_MARGIN`], at most a quarter of it.
pub fn guard_margin(max_on: Duration) -> Duration {
    GUARD_MARGIN.min(max_on / 4)
}

/// The longest on-time a plan may give a coil under a limit of `max_on` (its dwells and
/// [`STEP_IO`] per step): the limit less the [`guard_margin`].
pub fn budget(max_on: Duration) -> Duration {
    max_on - guard_margin(max_on)
}

/// The on-time limit and what counts against it, in words for messages: "1.100 s
/// (relay.max_on_time_s 1.200 s less the guard's 100 ms; each step counts its dwell and 20 ms
/// of frames)".
pub fn budget_text(max_on: Duration) -> String {
    format!(
        "{:.3} s (relay.max_on_time_s {:.3} s less the guard's {} ms; each step counts its dwell \
         and {} ms of frames)",
        budget(max_on).as_secs_f64(),
        max_on.as_secs_f64(),
        guard_margin(max_on).as_millis(),
        STEP_IO.as_millis()
    )
}

impl Default for OnTimeLimit {
    /// The replay's defaults (a scenario without `[relay]`).
    fn default() -> Self {
        OnTimeLimit {
            max_on: Duration::from_secs_f64(DEFAULT_MAX_ON_TIME_S),
            dwell_factor: DEFAULT_DWELL_FACTOR,
            dwell_floor: Duration::from_secs_f64(DEFAULT_DWELL_FLOOR_MS / 1000.0),
            fixed_dwell: None,
            replan_reserve: Duration::from_secs_f64(DEFAULT_REPLAN_RESERVE_MS / 1000.0),
        }
    }
}

impl OnTimeLimit {
    /// The dwell of a step predicted to settle in `settle_time_s`: the fixed one, else that
    /// settle time times the factor, at least the floor.
    pub fn dwell(&self, settle_time_s: f64) -> Duration {
        match self.fixed_dwell {
            Some(d) => d,
            None => dwell(settle_time_s, self.dwell_factor, self.dwell_floor),
        }
    }
}

/// Every relay of `on` held `extra` longer (what is on stays on while a closed loop replans).
pub fn extend<K: Ord + Copy>(on: &mut OnTimes<K>, extra: Duration) {
    on.values_mut().for_each(|h| h.on += extra);
}

/// The dwell of a step predicted to settle in `settle_time_s`: that times `factor`, at least
/// `floor` (a settle time that is not a finite positive number counts as 0; at most 1e6 s).
pub fn dwell(settle_time_s: f64, factor: f64, floor: Duration) -> Duration {
    let t = settle_time_s * factor;
    let d = if t.is_finite() && t > 0.0 {
        Duration::from_secs_f64(t.min(1e6))
    } else {
        Duration::ZERO
    };
    d.max(floor)
}

/// A relay that is on: the step it went on in and how long it has been on.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Held {
    /// The plan step it went on in, as the plan numbers it.
    pub since_step: usize,
    /// How long it has been on.
    pub on: Duration,
}

/// What is on and for how long, by relay (a coil, or a board's channel).
pub type OnTimes<K> = BTreeMap<K, Held>;

/// One step of a replay: `now_on` is what is on after step `step`, which dwells `dwell`.
/// What is no longer on is forgotten (it went off: its next on-time starts from zero), what
/// stays on adds the dwell and [`STEP_IO`], and what goes on starts with them.
pub fn hold<K: Ord + Copy>(
    on: &mut OnTimes<K>,
    now_on: impl IntoIterator<Item = K>,
    step: usize,
    dwell: Duration,
) {
    let now: Vec<K> = now_on.into_iter().collect();
    on.retain(|k, _| now.contains(k));
    for k in now {
        let h = on.entry(k).or_insert(Held {
            since_step: step,
            on: Duration::ZERO,
        });
        h.on += dwell + STEP_IO;
    }
}

/// The first relay (in key order) of `on` that has been on longer than a plan may keep it
/// under a limit of `max` (its [`budget`]), if any.
pub fn over<K: Ord + Copy>(on: &OnTimes<K>, max: Duration) -> Option<(K, Held)> {
    let budget = budget(max);
    on.iter()
        .find(|(_, h)| h.on > budget)
        .map(|(&k, &h)| (k, h))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_fixed_dwell_replaces_the_derived_one_and_a_replan_adds_its_reserve() {
        let mut l = OnTimeLimit::default();
        // 0.5 s settle x 1.5; a fixed dwell whatever the settle time
        assert_eq!(l.dwell(0.5), Duration::from_millis(750));
        l.fixed_dwell = Some(Duration::from_millis(120));
        assert_eq!(l.dwell(0.5), Duration::from_millis(120));
        assert_eq!(l.dwell(30.0), Duration::from_millis(120));
        let mut on = OnTimes::new();
        hold(&mut on, [3u32, 5], 0, l.dwell(1.0));
        extend(&mut on, l.replan_reserve);
        let each = Duration::from_millis(620) + STEP_IO;
        assert!(on.values().all(|h| h.on == each), "{on:?}");
    }

    #[test]
    fn a_coil_adds_up_its_dwells_until_it_goes_off() {
        let ms = Duration::from_millis;
        let io = STEP_IO.as_millis() as u64;
        let mut on = OnTimes::new();
        hold(&mut on, [1, 2], 0, ms(300));
        hold(&mut on, [1, 3], 1, ms(200));
        assert_eq!(on[&1].on, ms(500 + 2 * io));
        assert_eq!(on[&3].on, ms(200 + io));
        assert!(!on.contains_key(&2));
        hold(&mut on, [3], 2, ms(200));
        hold(&mut on, [1, 3], 3, ms(200));
        assert_eq!(
            on[&1],
            Held {
                since_step: 3,
                on: ms(200 + io)
            }
        );
        // coil 3: 600 ms of dwells and three steps' frames, against the limit less the margin
        let held = ms(600 + 3 * io);
        assert_eq!(on[&3].on, held);
        let limit = held + guard_margin(held + GUARD_MARGIN);
        assert_eq!(budget(limit), held);
        assert_eq!(over(&on, limit), None);
        assert_eq!(
            over(&on, limit - ms(1)),
            Some((
                3,
                Held {
                    since_step: 1,
                    on: held
                }
            ))
        );
    }

    #[test]
    fn the_guard_keeps_its_margin_or_a_quarter_of_a_short_limit() {
        let ms = Duration::from_millis;
        assert_eq!(budget(ms(10_000)), ms(9_900));
        assert_eq!(budget(ms(1_200)), ms(1_100));
        assert_eq!(budget(ms(200)), ms(150));
        // four 300 ms dwells do not fit a 1.2 s limit once frames and the margin count
        let mut on = OnTimes::new();
        for step in 0..4 {
            hold(&mut on, [7], step, ms(300));
        }
        assert!(over(&on, ms(1_200)).is_some());
        assert!(budget_text(ms(1_200)).starts_with("1.100 s (relay.max_on_time_s 1.200 s"));
    }

    #[test]
    fn the_dwell_is_the_settle_time_times_the_factor_at_least_the_floor() {
        let floor = Duration::from_millis(200);
        assert_eq!(dwell(1.0, 1.5, floor), Duration::from_millis(1500));
        assert_eq!(dwell(0.1, 1.5, floor), floor);
        assert_eq!(dwell(f64::NAN, 1.5, floor), floor);
    }
}
