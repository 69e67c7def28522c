//! An excitation run: a plan of random coil sets, each switched on where the set before left
//! the ball, to be replayed with a sensor so that `fit --log` can fit the wells to its log. A
//! plan towards a target keeps the magnets near their coils, so its log says little about how
//! far a well reaches; random sets drag magnets across the whole well. Every set is drawn from
//! one seeded generator and kept only where the hardware may play it: with the set before it
//! (make before break) it powers at most the supply's coils, no coil stays on past the on-time
//! limit with the replay's dwells ([`on_time`], as `replay` counts them), and the ball comes to
//! rest under it within the settle's t_max, so the sensor reads a ball at rest. The rows are a
//! plan file's: `simulate`, `view` and `replay` take them as they take any plan.

use crate::model::geometry::{CoilId, Orientation, Pair};
use crate::model::random::SplitMix;
use crate::physics::dynamics::settle;
use crate::planning::commutation::{cumulative_from, nearest_magnet, step_measure, Motor};
use crate::planning::on_time::{self, OnTimeLimit, OnTimes};
use crate::planning::plan::{PlanRow, PlanSettings};

/// The fewest and the most coils a random set switches on (capped by the supply): what the
/// fit's checks log (docs/fit.md), two or three coils pull a ball across a well's whole reach.
pub const EXCITE_COILS: (usize, usize) = (2, 3);

/// How many sets are drawn for one step before the step before it is drawn again (a set can
/// leave no way on: with a supply of 3, after a set of 3 only its pairs of coils fit, and they
/// may all keep a coil on too long).
pub const DRAWS_PER_STEP: usize = 64;

/// How many sets a run may draw per step in all, backtracking included, before it is given up.
pub const DRAWS_PER_STEP_IN_ALL: usize = 4 * DRAWS_PER_STEP;

/// The most steps an excitation run may have.
pub const MAX_EXCITE_STEPS: usize = 10_000;

/// Why no excitation run was made.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum ExciteError {
    /// The supply cannot switch from one set to another: with make before break, two sets of
    /// 2 coils need 3 coils on at once at least.
    #[error(
        "an excitation run switches from one set of {} or more coils to another with both on for a moment, so it needs a supply of {} coils or more, but the supply powers {max_coils_on} (relay.max_coils_on)",
        EXCITE_COILS.0, EXCITE_COILS.0 + 1
    )]
    Supply {
        /// The supply's limit.
        max_coils_on: usize,
    },
    /// No run was found within the draws allowed.
    #[error(
        "no excitation run of {steps} steps found in {draws} random sets of {}-{} coils (the furthest reached step {furthest}): each set must settle where the set before left the ball, within the supply ({max_coils_on} coils on at once) and the coils' on-time limit",
        EXCITE_COILS.0, EXCITE_COILS.1
    )]
    NoRun {
        /// The steps asked.
        steps: usize,
        /// The sets drawn.
        draws: usize,
        /// The furthest step reached.
        furthest: usize,
        /// The supply's limit.
        max_coils_on: usize,
    },
}

/// An excitation run: its rows (row 0 the first set, from the settings' start) and how many
/// sets were drawn and settled to choose them.
#[derive(Debug, Clone, PartialEq)]
pub struct Excitation {
    /// The plan's rows; their angles are measured about the settings' axis, as any plan's.
    pub rows: Vec<PlanRow>,
    /// The sets drawn (and settled) in all.
    pub draws: usize,
}

/// The random sets the run is made of, as the fit's checks and the hardware see them: the
/// coils of each row, in order.
pub fn coil_sets(rows: &[PlanRow]) -> Vec<Vec<CoilId>> {
    rows.iter()
        .map(|r| r.active.iter().map(|p| p.coil).collect())
        .collect()
}

/// Plans an excitation run of `steps` steps after the first set (so `steps + 1` rows) from the
/// settings' start, drawn from `seed`: each step's set is 2 or 3 coils (at most the supply's),
/// other than the set before, that with it fits the supply, keeps no coil on past the
/// on-time limit (the settings' limits) and settles within t_max; each coil is written with the
/// magnet nearest it where the step starts, and the row's orientation is where the motor's
/// settle takes the ball, as `simulate` replays it. Where [`DRAWS_PER_STEP`] sets in a row are
/// refused, the step before is drawn again.
///
/// # Errors
/// The supply powers fewer than 3 coils, or [`DRAWS_PER_STEP_IN_ALL`] sets per step were drawn
/// without finding the run.
pub fn excitation(
    motor: &Motor,
    s: &PlanSettings,
    steps: usize,
    seed: u64,
) -> Result<Excitation, ExciteError> {
    let max_coils_on = s.limits.max_coils_on;
    if max_coils_on <= EXCITE_COILS.0 {
        return Err(ExciteError::Supply { max_coils_on });
    }
    let mut rng = SplitMix::new(seed);
    let start = Where {
        q: s.start,
        on: OnTimes::new(),
        held: Vec::new(),
    };
    let budget = DRAWS_PER_STEP_IN_ALL.saturating_mul(steps + 1);
    // the rows so far, each with where it leaves the run
    let mut run: Vec<(PlanRow, Where)> = Vec::with_capacity(steps + 1);
    let (mut draws, mut here, mut furthest) = (0, 0, 0);
    while run.len() <= steps {
        if draws >= budget {
            return Err(ExciteError::NoRun {
                steps,
                draws,
                furthest,
                max_coils_on,
            });
        }
        let at = run.last().map_or(&start, |(_, w)| w);
        let step = run.len();
        draws += 1;
        here += 1;
        let coils = draw_set(&mut rng, motor.torques.stator.len(), &at.held, max_coils_on);
        match coils.and_then(|c| at.step_to(motor, s.limits.on_time, &c, step)) {
            Some(next) => {
                run.push(next);
                furthest = furthest.max(step);
                here = 0;
            }
            None if here >= DRAWS_PER_STEP => {
                run.pop();
                here = 0;
            }
            None => {}
        }
    }
    let mut rows: Vec<PlanRow> = Vec::with_capacity(run.len());
    for (row, _) in run {
        let row = measured_row(row, rows.first(), rows.last(), s);
        rows.push(row);
    }
    Ok(Excitation { rows, draws })
}

/// Where a run stands: the ball's orientation, each coil's on-time and the coils on.
struct Where {
    q: Orientation,
    on: OnTimes<CoilId>,
    held: Vec<CoilId>,
}

impl Where {
    /// The row (its angles not yet measured) of switching to `coils` as step `step`, and where
    /// it leaves the run; `None` where the set does not settle or keeps a coil on too long.
    fn step_to(
        &self,
        motor: &Motor,
        limit: Option<OnTimeLimit>,
        coils: &[CoilId],
        step: usize,
    ) -> Option<(PlanRow, Where)> {
        let active: Vec<Pair> = coils
            .iter()
            .map(|&coil| Pair {
                coil,
                magnet: nearest_magnet(&motor.torques, coil, &self.q).0,
            })
            .collect();
        let r = settle(&motor.torques, &active, &self.q, motor.body, motor.settle);
        if !r.settled {
            return None;
        }
        let mut on = self.on.clone();
        if let Some(l) = limit {
            on_time::hold(
                &mut on,
                coils.iter().copied(),
                step,
                l.dwell(r.arrival_time_s),
            );
            if on_time::over(&on, l.max_on).is_some() {
                return None;
            }
        }
        let new = (active.iter())
            .filter(|p| !self.held.contains(&p.coil))
            .copied()
            .collect();
        let row = PlanRow {
            step,
            pivot: None,
            new,
            active,
            q: r.q,
            step_angle_deg: 0.0,
            step_axis_error_deg: 0.0,
            cum_angle_deg: 0.0,
            cum_axis_error_deg: 0.0,
            settle_time_s: r.arrival_time_s,
            settled: true,
        };
        let next = Where {
            q: r.q,
            on,
            held: coils.to_vec(),
        };
        Some((row, next))
    }
}

/// `row` with its angles measured about the settings' axis: the step's from the row before,
/// the cumulative from row 0 (none for row 0 itself).
fn measured_row(
    mut row: PlanRow,
    first: Option<&PlanRow>,
    before: Option<&PlanRow>,
    s: &PlanSettings,
) -> PlanRow {
    let (Some(first), Some(before)) = (first, before) else {
        return row;
    };
    let (a, e) = step_measure(&before.q, &row.q, &s.axis);
    let before_cum = before.cum_angle_deg.to_radians();
    let (ca, ce) = cumulative_from(&first.q, &row.q, &s.axis, before_cum);
    row.step_angle_deg = a.0.to_degrees();
    row.step_axis_error_deg = e.0.to_degrees();
    row.cum_angle_deg = ca.0.to_degrees();
    row.cum_axis_error_deg = ce.0.to_degrees();
    row
}

/// One random set of [`EXCITE_COILS`] coils (its size drawn first, capped by the supply) among
/// `coils`, in increasing order, that with `held` (the set before, on while it switches) powers
/// at most `max_coils_on` coils; `None` where it would be `held` itself.
fn draw_set(
    rng: &mut SplitMix,
    coils: usize,
    held: &[CoilId],
    max_coils_on: usize,
) -> Option<Vec<CoilId>> {
    let (least, most) = (EXCITE_COILS.0, EXCITE_COILS.1.min(max_coils_on));
    let size = least + ((rng.uniform() * (most - least + 1) as f64) as usize).min(most - least);
    let size = size.min(coils);
    let mut set: Vec<CoilId> = Vec::with_capacity(size);
    while set.len() < size {
        let on_at_once = held.iter().filter(|c| !set.contains(c)).count() + set.len();
        // at the supply's limit only a coil of the set before may join
        let open: Vec<CoilId> = (0..coils)
            .map(CoilId)
            .filter(|c| !set.contains(c) && (on_at_once < max_coils_on || held.contains(c)))
            .collect();
        if open.is_empty() {
            return None;
        }
        let pick = ((rng.uniform() * open.len() as f64) as usize).min(open.len() - 1);
        set.push(open[pick]);
    }
    set.sort_unstable();
    (set != held).then_some(set)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_drawn_set_with_the_set_before_never_exceeds_the_supply() {
        let mut rng = SplitMix::new(3);
        let mut held: Vec<CoilId> = Vec::new();
        let mut sizes = [0usize; 4];
        for _ in 0..2000 {
            let Some(set) = draw_set(&mut rng, 16, &held, 4) else {
                continue;
            };
            let mut all: Vec<CoilId> = held.iter().chain(&set).copied().collect();
            all.sort_unstable();
            all.dedup();
            assert!(all.len() <= 4, "{held:?} then {set:?}");
            assert!(set.windows(2).all(|w| w[0] < w[1]), "{set:?}");
            assert_ne!(set, held);
            sizes[set.len()] += 1;
            held = set;
        }
        // both sizes drawn, about evenly
        assert!(sizes[2] > 700 && sizes[3] > 700, "{sizes:?}");
        // a supply of 3: after a set of 3 only its own coils may join (2 of them)
        let held = vec![CoilId(1), CoilId(5), CoilId(9)];
        for _ in 0..200 {
            if let Some(set) = draw_set(&mut rng, 16, &held, 3) {
                assert!(set.iter().all(|c| held.contains(c)), "{set:?}");
            }
        }
    }
}
