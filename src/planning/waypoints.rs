//! Paths through waypoints: one motion that visits a list of orientations in order (a camera
//! raster, a tracking pattern), each reached within a tolerance. Each waypoint is planned as a
//! leg from where the plan before it leaves the ball (the settled state, its coils still on,
//! their on-times counted on), so that errors do not pile up from one waypoint to the next; a
//! leg that ends further than the tolerance from its waypoint is followed by correction legs
//! from where it ended. A consumer of the planner ([`plan`], [`plan_on_from`]): it settles
//! nothing itself.

use crate::model::geometry::Pair;
use crate::model::geometry::{rotation_axis, CoilId, Orientation};
use crate::planning::coilsets::coils_of;
use crate::planning::commutation::{
    combinations, cumulative_from, holds, settled_states, step_measure, CommutationState, Motor,
};
use crate::planning::on_time::{self, OnTimes};
pub use crate::planning::plan::turn_to;
use crate::planning::plan::{
    max_axis_error_deg, path_deviation_deg, total_settle_time, unsettled_steps, Plan, PlanRow,
    PlanSettings,
};
use crate::planning::planner::{plan, plan_on_from, replanned_from_row0};
use crate::planning::search::{on_times_of, over_on_time};
use serde::Serialize;

/// The default tolerance within which every waypoint must be reached, degrees: the prototype's
/// nearest equilibrium to an orientation can be over 2 degrees from it (2.3 on one of the
/// random paths tried), so a tighter tolerance refuses paths the motor cannot do better on.
pub const DEFAULT_WAYPOINT_TOLERANCE_DEG: f64 = 3.0;

/// How many legs may serve one waypoint: the first, then corrections from where the last ended
/// while it ends further than the tolerance from the waypoint and nearer than before.
pub const LEGS_PER_WAYPOINT: usize = 3;

/// A plan through waypoints.
#[derive(Debug, Clone, PartialEq)]
pub struct WaypointPlan {
    /// The steps, numbered 0, 1, ... through the whole motion (row 0: the initial commutation).
    /// A row's cumulative figures (`cum_angle_deg`, `cum_axis_error_deg`) count from where the
    /// ball was when it set out for the row's waypoint (the row before the waypoint's first;
    /// row 0 for the first waypoint), about the axis of the shortest turn from there to it.
    pub rows: Vec<PlanRow>,
    /// The waypoint (1, 2, ...) each row serves, row by row.
    pub serves: Vec<usize>,
    /// The waypoints, in order.
    pub waypoints: Vec<Orientation>,
    /// Every waypoint reached within the tolerance, within the on-time limit.
    pub reached: bool,
    /// Why not, when not.
    pub message: Option<String>,
    /// Settles the search spent over all legs.
    pub settles: usize,
}

/// Where a waypoint is reached: the last row serving it (or, when none does, the row the ball
/// was already within the tolerance at) and how far from it that row leaves the ball.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct WaypointReached {
    /// The waypoint, 1, 2, ...
    pub waypoint: usize,
    /// The row (step) where it is reached.
    pub step: usize,
    /// The angle from that row's orientation to the waypoint, degrees.
    pub error_deg: f64,
    /// How far the rows serving it stray from the direct way: the worst angle (degrees) from
    /// one of their orientations to the nearest point of the geodesic (the slerp) from the
    /// waypoint before (for the first, row 0's orientation) to this one; 0 when no row
    /// serves it.
    pub max_path_deviation_deg: f64,
}

/// A waypoint plan's figures (the JSON summary of `plan --waypoints`).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct WaypointSummary {
    /// Steps after row 0 (release steps included).
    pub steps: usize,
    /// Where each waypoint is reached, in order.
    pub waypoints: Vec<WaypointReached>,
    /// The largest of the waypoints' errors, degrees.
    pub worst_waypoint_error_deg: f64,
    /// The worst cumulative axis error of any leg, degrees.
    pub max_axis_error_deg: f64,
    /// The worst path deviation of any waypoint's rows, degrees (the largest of the
    /// waypoints' [`WaypointReached::max_path_deviation_deg`]).
    pub max_path_deviation_deg: f64,
    /// The tolerance every waypoint had to be reached within, degrees.
    pub tolerance_deg: f64,
    /// Every waypoint reached within the tolerance, within the on-time limit.
    pub reached: bool,
    /// The sum of the steps' predicted settle times, s.
    pub total_settle_time_s: f64,
    /// The planning scheme of every leg.
    pub scheme: String,
    /// The step model of every leg.
    pub model: String,
    /// Why the path was not followed, when it was not.
    pub message: Option<String>,
    /// Settles spent over all legs, those tried and not kept included.
    pub settles: usize,
    /// The steps predicted not to settle.
    pub unsettled_steps: Vec<usize>,
}

impl WaypointPlan {
    /// Where each waypoint is reached, in order.
    pub fn reached_at(&self) -> Vec<WaypointReached> {
        reached_at(&self.rows, &self.serves, &self.waypoints)
    }

    /// The plan's figures, for the settings it was made with.
    pub fn summary(&self, s: &PlanSettings, tolerance_deg: f64) -> WaypointSummary {
        let at = self.reached_at();
        WaypointSummary {
            steps: self.rows.len().saturating_sub(1),
            worst_waypoint_error_deg: at.iter().map(|w| w.error_deg).fold(0.0, f64::max),
            max_axis_error_deg: max_axis_error_deg(&self.rows),
            max_path_deviation_deg: at
                .iter()
                .map(|w| w.max_path_deviation_deg)
                .fold(0.0, f64::max),
            waypoints: at,
            tolerance_deg,
            reached: self.reached,
            total_settle_time_s: total_settle_time(&self.rows),
            scheme: s.scheme.name().into(),
            model: s.model.name().into(),
            message: self.message.clone(),
            settles: self.settles,
            unsettled_steps: unsettled_steps(&self.rows),
        }
    }
}

/// Where each of `waypoints` is reached by the rows that serve them (`serves`, row by row): its
/// last row, or for a waypoint no row serves, the last row before the next one's; and how far
/// its rows stray from the geodesic from the waypoint before (the first: from row 0).
pub fn reached_at(
    rows: &[PlanRow],
    serves: &[usize],
    waypoints: &[Orientation],
) -> Vec<WaypointReached> {
    let mut out = Vec::with_capacity(waypoints.len());
    for (k, w) in waypoints.iter().enumerate() {
        let number = k + 1;
        // the last row serving this waypoint or an earlier one
        let Some(row) = serves.iter().rposition(|&v| v <= number) else {
            continue;
        };
        let Some(r) = rows.get(row) else {
            continue;
        };
        let from = path_start(waypoints, rows, number);
        let leg = rows
            .iter()
            .zip(serves)
            .filter(|&(_, &v)| v == number)
            .map(|(r, _)| &r.q);
        out.push(WaypointReached {
            waypoint: number,
            step: r.step,
            error_deg: r.q.angle_to(w).to_degrees(),
            max_path_deviation_deg: from.map_or(0.0, |from| path_deviation_deg(leg, &from, w)),
        });
    }
    out
}

/// Plans one motion through `waypoints` in order from `s.start` with the settings' model,
/// scheme and limits (their axis and angle are ignored: each leg's are the shortest turn to its
/// waypoint from where the ball is), every waypoint within `tolerance_deg`.
pub fn plan_waypoints(
    motor: &Motor,
    s: &PlanSettings,
    waypoints: &[Orientation],
    tolerance_deg: f64,
) -> WaypointPlan {
    plan_waypoints_with(motor, s, waypoints, tolerance_deg, &mut |_| {})
}

/// [`plan_waypoints`], telling `served` how many waypoints the plan serves so far each time
/// that changes (one more served; fewer when it goes back to an earlier waypoint): a progress
/// bar's position, out of `waypoints.len()`.
pub fn plan_waypoints_with(
    motor: &Motor,
    s: &PlanSettings,
    waypoints: &[Orientation],
    tolerance_deg: f64,
    served: &mut dyn FnMut(usize),
) -> WaypointPlan {
    let mut out = WaypointPlan {
        rows: Vec::new(),
        serves: Vec::new(),
        waypoints: waypoints.to_vec(),
        reached: false,
        message: None,
        settles: 0,
    };
    let tolerance = tolerance_deg.to_radians();
    let mut spent = 0usize;
    // the waypoints served so far, each with where the plan stood before it (its length: rows
    // are only ever appended after it) and its untried legs
    let mut pending: Vec<Pending> = Vec::new();
    let mut failure: Option<(usize, WaypointPlan, String)> = None;
    let (mut k, mut legs, mut backtracks) = (0usize, None, 0usize);
    while let Some(goal) = waypoints.get(k) {
        let before = out.rows.len();
        match serve(
            motor,
            s,
            &mut out,
            (k + 1, goal),
            tolerance,
            legs.take(),
            &mut spent,
        ) {
            Ok(rest) => {
                pending.push(Pending {
                    before,
                    index: k,
                    legs: rest,
                });
                k += 1;
                served(k);
            }
            Err(why) => {
                if failure.as_ref().is_none_or(|(f, _, _)| k >= *f) {
                    failure = Some((k, out.clone(), why));
                }
                // back to the latest waypoint with a leg not tried yet
                while pending.last().is_some_and(|p| p.legs.is_empty()) {
                    pending.pop();
                }
                match pending.pop().filter(|_| backtracks < MAX_BACKTRACKS) {
                    Some(p) => {
                        backtracks += 1;
                        out.rows.truncate(p.before);
                        out.serves.truncate(p.before);
                        k = p.index;
                        served(k);
                        legs = Some(p.legs);
                    }
                    None => {
                        let (_, mut f, why) = failure.unwrap_or((k, out, String::new()));
                        f.message = Some(why);
                        f.settles = spent;
                        return f;
                    }
                }
            }
        }
    }
    out.settles = spent;
    if let Some(why) = over_on_time(&out.rows, s.limits.on_time) {
        out.message = Some(why);
        return out;
    }
    out.reached = !out.rows.is_empty();
    if !out.reached {
        out.message = Some("no waypoint to plan for".into());
    }
    out
}

/// Plans the legs that take the ball from the end of `out` to waypoint `number` (`goal`) and
/// appends them; an error when it cannot be reached within `tolerance` (rad). The candidate
/// legs towards it (`legs`, when going back to it; else [`candidate_legs`]), the first
/// [`CANDIDATE_LEGS`], are each tried with its correction legs; the one [`straightest`] picks is
/// kept (of those that end within the tolerance and near the waypoint, the one that strays least
/// from the waypoint's path; else the nearest-ending), and the others are returned, for a later
/// waypoint to come back to. Settles are counted in `spent`.
fn serve(
    motor: &Motor,
    s: &PlanSettings,
    out: &mut WaypointPlan,
    (number, goal): (usize, &Orientation),
    tolerance: f64,
    legs: Option<Vec<Leg>>,
    spent: &mut usize,
) -> Result<Vec<Leg>, String> {
    let first = out.rows.len();
    let end = |p: &WaypointPlan| p.rows.last().map_or(f64::INFINITY, |r| r.q.angle_to(goal));
    let legs = match legs {
        Some(l) => l,
        None if !out.rows.is_empty() && end(out) <= tolerance => {
            return Ok(Vec::new()); // already there: no row serves it
        }
        None => candidate_legs(motor, s, out, goal, number, spent)?,
    };
    // each leg is tried on the end of `out` and taken back off, its rows kept aside (no copy of
    // the whole plan: memory stays linear in the waypoints); the legs not taken are returned
    let mut legs = legs.into_iter();
    let mut tried: Vec<Tried> = Vec::new();
    for leg in legs.by_ref().take(CANDIDATE_LEGS) {
        append(out, leg.clone(), number);
        correct(motor, s, out, number, goal, spent);
        let ends = end(out);
        let strays = leg_strays(out, first, number, goal);
        let rows = out.rows.split_off(first);
        let serves = out.serves.split_off(first);
        tried.push(Tried {
            leg,
            end: ends,
            strays,
            rows,
            serves,
        });
    }
    let kept = straightest(&tried, tolerance, STRAIGHT_END * s.tolerance.0);
    let mut rest: Vec<Leg> = Vec::new();
    for (k, t) in tried.into_iter().enumerate() {
        if Some(k) == kept {
            out.rows.extend(t.rows);
            out.serves.extend(t.serves);
        } else {
            rest.push(t.leg);
        }
    }
    rest.extend(legs);
    if let Some(base) = first_base(&out.rows, first) {
        recount(&mut out.rows[first..], base, goal);
    }
    let error = end(out);
    if error > tolerance {
        return Err(format!(
            "waypoint {number} not reached: the plan leaves the ball {:.2} deg from it, over the \
             tolerance of {:.2} deg",
            error.to_degrees(),
            tolerance.to_degrees()
        ));
    }
    Ok(rest)
}

/// A candidate leg tried on the end of the plan: the leg, how far from its waypoint it (and
/// its corrections) leave the ball (rad), how far its rows stray from the waypoint's path
/// (rad), and those rows with the waypoint each serves.
struct Tried {
    leg: Leg,
    end: f64,
    strays: f64,
    rows: Vec<PlanRow>,
    serves: Vec<usize>,
}

/// A leg kept over the nearest-ending one when it strays less from its path needs to end
/// within this share of the plan's angle tolerance of its waypoint (or no further than the
/// nearest-ending leg).
const STRAIGHT_END: f64 = 0.75;

/// Which of `tried` serves its waypoint: of those that end within `tolerance` and within
/// `near` (or no further than the nearest-ending one), the one that strays least from the
/// waypoint's path (the first tried on a tie); else the nearest-ending (the first on a tie).
/// `None` when nothing was tried.
fn straightest(tried: &[Tried], tolerance: f64, near: f64) -> Option<usize> {
    let nearest = (0..tried.len()).min_by(|&a, &b| tried[a].end.total_cmp(&tried[b].end))?;
    let least = tried[nearest].end;
    let fit = |t: &Tried| t.end <= tolerance && (t.end <= near || t.end <= least);
    let straight = (0..tried.len())
        .filter(|&k| fit(&tried[k]))
        .min_by(|&a, &b| tried[a].strays.total_cmp(&tried[b].strays));
    Some(straight.unwrap_or(nearest))
}

/// How far the rows of `out` from `first` on stray from waypoint `number`'s path (rad): the
/// geodesic from the waypoint before (row 0 for the first) to `goal`, as the waypoint report
/// measures it ([`reached_at`]).
fn leg_strays(out: &WaypointPlan, first: usize, number: usize, goal: &Orientation) -> f64 {
    let from = path_start(&out.waypoints, &out.rows, number);
    let rows = out.rows.get(first..).unwrap_or_default();
    from.map_or(0.0, |f| {
        path_deviation_deg(rows.iter().map(|r| &r.q), &f, goal).to_radians()
    })
}

/// Where waypoint `number`'s (1, 2, ...) path starts: the waypoint before it, or row 0 of
/// `rows` for the first.
fn path_start(waypoints: &[Orientation], rows: &[PlanRow], number: usize) -> Option<Orientation> {
    match number.checked_sub(2) {
        Some(before) => waypoints.get(before).copied(),
        None => rows.first().map(|r| r.q),
    }
}

/// A waypoint served: how many rows the plan had before it and the candidate legs towards it
/// not tried yet.
struct Pending {
    before: usize,
    index: usize,
    legs: Vec<Leg>,
}

/// How many times the planner goes back to an earlier waypoint to take another of its legs
/// when a later one cannot be reached (a budget in legs, the same on any machine).
const MAX_BACKTRACKS: usize = 8;

/// How many candidate legs towards a waypoint are tried before it is given up.
const CANDIDATE_LEGS: usize = 4;

/// Appends `leg` to `out`, its rows serving waypoint `number` (a leg that goes on from the end
/// of `out` without its row 0, which is that end).
fn append(out: &mut WaypointPlan, leg: Leg, number: usize) {
    let skip = usize::from(!out.rows.is_empty());
    let base = out.rows.len();
    let rows = leg
        .release
        .into_iter()
        .chain(leg.plan.rows.into_iter().skip(skip));
    for (j, r) in rows.enumerate() {
        out.rows.push(PlanRow {
            step: base + j,
            ..r
        });
        out.serves.push(number);
    }
}

/// Correction legs from where `out` ends towards `goal`, at most [`LEGS_PER_WAYPOINT`] - 1 of
/// them, each the nearest-ending candidate, while it brings the ball nearer.
fn correct(
    motor: &Motor,
    s: &PlanSettings,
    out: &mut WaypointPlan,
    number: usize,
    goal: &Orientation,
    spent: &mut usize,
) {
    for _ in 1..LEGS_PER_WAYPOINT {
        let Some(distance) = out.rows.last().map(|r| r.q.angle_to(goal)) else {
            return;
        };
        if distance <= s.angle_tolerance.0 {
            return;
        }
        let Ok(legs) = candidate_legs(motor, s, out, goal, number, spent) else {
            return;
        };
        let Some(leg) = legs.into_iter().next() else {
            return;
        };
        if leg.end(goal) >= distance {
            return; // a correction that does not bring the ball nearer is not taken
        }
        append(out, leg, number);
    }
}

/// The legs towards `goal` from the end of `out` (from `s.start` with an initial commutation
/// when `out` has no rows yet), those with steps, nearest-ending first (the settles spent on
/// them added to `spent`); or why there is none.
fn candidate_legs(
    motor: &Motor,
    s: &PlanSettings,
    out: &WaypointPlan,
    goal: &Orientation,
    number: usize,
    spent: &mut usize,
) -> Result<Vec<Leg>, String> {
    let here = out.rows.last().map_or(s.start, |r| r.q);
    let (axis, angle) = turn_to(&here, goal, "the waypoint before")
        .map_err(|e| format!("waypoint {number}: expected {e}"))?;
    let leg = PlanSettings {
        axis,
        angle,
        start: here,
        target: None,
        ..s.clone()
    };
    let tried = match out.rows.last() {
        None => first_legs(motor, &leg, goal),
        Some(last) => go_on(motor, &leg, out, last, goal),
    };
    *spent += tried.iter().map(|l| l.plan.settles).sum::<usize>();
    let skip = usize::from(!out.rows.is_empty());
    let (mut legs, failed): (Vec<Leg>, Vec<Leg>) =
        tried.into_iter().partition(|l| l.plan.rows.len() > skip);
    if legs.is_empty() {
        let why = failed
            .into_iter()
            .find_map(|l| l.plan.message)
            .unwrap_or_else(|| "no plan".into());
        return Err(format!("waypoint {number}: {why}"));
    }
    // nearest-ending first; a stable sort keeps the order tried on a tie
    legs.sort_by(|a, b| a.end(goal).total_cmp(&b.end(goal)));
    Ok(legs)
}

/// The first legs, from `leg.start` with an initial commutation: the initial commutation moves
/// the ball before the first step (it settles where the coils switched on hold it), so the leg
/// is planned both as asked and again from where row 0 leaves the ball, aimed at `goal`.
fn first_legs(motor: &Motor, leg: &PlanSettings, goal: &Orientation) -> Vec<Leg> {
    let p = plan(motor, leg);
    let again = replanned_from_row0(motor, leg, &p, goal);
    std::iter::once(p)
        .chain(again)
        .map(|plan| Leg {
            release: None,
            plan,
        })
        .collect()
}

/// A leg towards a waypoint: a release step when the leg starts with one (a row that switches
/// some of the held pairs off and nothing on, see [`go_on`]), then the plan from there. The
/// plan's row 0 is the state its steps start from (where the release leaves the ball, else the
/// end of the plan so far, or the initial commutation for a first leg); [`append`] leaves it
/// out when the plan so far has rows, as it repeats the row before.
#[derive(Clone)]
struct Leg {
    release: Option<PlanRow>,
    plan: Plan,
}

impl Leg {
    /// How far from `goal` the leg leaves the ball, rad.
    fn end(&self, goal: &Orientation) -> f64 {
        self.plan
            .rows
            .last()
            .map_or(f64::INFINITY, |r| r.q.angle_to(goal))
    }
}

/// The fewest coils a leg sets out with switched off, so that a step can switch coils on within
/// the supply (make before break): a pair's coil and another's, as an initial commutation has.
const ROOM_FOR_NEW_COILS: usize = 2;

/// How many release steps a leg tries beside going straight on: the ones that keep the coils on
/// the shortest time first.
const RELEASES_TRIED: usize = 3;

/// Every leg tried from `last` (the end of `out`, its coils still on, their on-times counted
/// over `out`'s rows) towards `goal`, in the order tried, with or without steps: first the plan
/// straight on from `last` (with `leg`'s turn), then a plan after each release step (a row that
/// switches some of the held pairs off, see [`releases`]) for the first [`RELEASES_TRIED`]
/// releases that keep every coil within the on-time limit through the release's own dwell,
/// each aimed at `goal` from where its release leaves the ball. Choosing among them is left to
/// [`candidate_legs`] (those with steps, nearest-ending first).
fn go_on(
    motor: &Motor,
    leg: &PlanSettings,
    out: &WaypointPlan,
    last: &PlanRow,
    goal: &Orientation,
) -> Vec<Leg> {
    let on = on_times_of(&out.rows, leg.limits.on_time, None);
    let mut tried = vec![Leg {
        release: None,
        plan: plan_on_from(motor, leg, last.state(), on.clone()),
    }];
    // a release whose coils would be on too long by the end of its own dwell is not tried
    let released = releases(motor, leg, last, goal, &on)
        .into_iter()
        .filter_map(|freed| {
            let row = release_row(last, &freed);
            let mut on = on.clone();
            if let Some(l) = leg.limits.on_time {
                row.hold(&mut on, &l);
                if on_time::over(&on, l.max_on).is_some() {
                    return None;
                }
            }
            Some((freed, row, on))
        });
    for (freed, row, on) in released.take(RELEASES_TRIED) {
        let (axis, angle) = match turn_to(&freed.q, goal, "the release") {
            Ok(t) => t,
            Err(_) => (leg.axis, leg.angle),
        };
        let from = PlanSettings {
            axis,
            angle,
            start: freed.q,
            ..leg.clone()
        };
        tried.push(Leg {
            release: Some(row),
            plan: plan_on_from(motor, &from, freed, on),
        });
    }
    // Reached only when no release was tried and the plan straight on has no step and no
    // message: a plan without steps says why unless its row 0 already counts as reached, so
    // this is a turn to `goal` within the angle tolerance (`plan.angle_tolerance_deg`). That
    // needs a waypoint tolerance below the angle tolerance ([`serve`] asks for legs only when
    // the ball is further from the waypoint than the former, [`correct`] than the latter), and
    // the message then does not give the reason; it is kept as it was (no behaviour change).
    if tried.len() == 1 && tried[0].plan.rows.len() < 2 && tried[0].plan.message.is_none() {
        tried[0].plan.message = Some(format!(
            "the coils on at step {} hold the ball, and no subset of them that leaves room to \
             switch coils on does",
            last.step
        ));
    }
    tried
}

/// The states a release step from `last` can leave the ball in: some of its pairs switched off,
/// the rest held, at most the supply less [`ROOM_FOR_NEW_COILS`] coils on, each settled and
/// holding the ball; those whose coils have been on the shortest time (by `on`) first, then
/// those nearest `goal`.
fn releases(
    motor: &Motor,
    s: &PlanSettings,
    last: &PlanRow,
    goal: &Orientation,
    on: &OnTimes<CoilId>,
) -> Vec<CommutationState> {
    let keep = s
        .limits
        .max_coils_on
        .saturating_sub(ROOM_FOR_NEW_COILS)
        .max(1);
    let sets: Vec<Vec<Pair>> = (1..=keep.min(last.active.len().saturating_sub(1)))
        .flat_map(|k| combinations(last.active.len(), k))
        .map(|idx| idx.iter().map(|&i| last.active[i]).collect::<Vec<_>>())
        .filter(|set| coils_of(set).len() <= keep)
        .collect();
    let capture = s.limits.capture_for(s.model, &motor.torques.well);
    let longest = |st: &CommutationState| {
        st.active
            .iter()
            .filter_map(|p| on.get(&p.coil))
            .map(|h| h.on)
            .max()
            .unwrap_or_default()
    };
    let mut held: Vec<CommutationState> = settled_states(motor, sets, &last.q)
        .into_iter()
        .flatten()
        .filter(|st| holds(&motor.torques, st, capture))
        .collect();
    held.sort_by(|a, b| {
        longest(a)
            .cmp(&longest(b))
            .then(a.q.angle_to(goal).total_cmp(&b.q.angle_to(goal)))
    });
    held
}

/// The row of a release step from `last` to `to`: no pivot, nothing switched on.
fn release_row(last: &PlanRow, to: &CommutationState) -> PlanRow {
    PlanRow {
        step: last.step + 1,
        pivot: None,
        new: Vec::new(),
        active: to.active.clone(),
        q: to.q,
        settle_time_s: to.settle_time_s,
        settled: true,
        ..last.clone()
    }
}

/// The orientation a waypoint's rows count from: the row before its first (`first`), or its
/// first row for the first waypoint (`None` without rows).
fn first_base(rows: &[PlanRow], first: usize) -> Option<Orientation> {
    rows.get(first.saturating_sub(1)).map(|r| r.q)
}

/// Counts a waypoint's rows' step and cumulative figures from `base` about the shortest turn
/// from it to `goal`.
fn recount(rows: &mut [PlanRow], base: Orientation, goal: &Orientation) {
    let Some(axis) = rotation_axis(&(goal * base.inverse())) else {
        return;
    };
    let mut before = base;
    let mut cum = 0.0;
    for r in rows {
        let (sa, se) = step_measure(&before, &r.q, &axis);
        let (ca, ce) = cumulative_from(&base, &r.q, &axis, cum);
        if r.pivot.is_some() || r.step > 0 {
            r.step_angle_deg = sa.0.to_degrees();
            r.step_axis_error_deg = se.0.to_degrees();
        }
        r.cum_angle_deg = ca.0.to_degrees();
        r.cum_axis_error_deg = ce.0.to_degrees();
        cum = ca.0;
        before = r.q;
    }
}
