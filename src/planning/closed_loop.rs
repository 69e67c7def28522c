//! Closed loop (docs/model.md, "Commutation" 6): a plan played on a plant, the ball's settled
//! orientation measured after each step (the plant's, plus seeded sensor noise), and the rest of
//! the motion replanned from the measurement towards the same goal R_target R_0 whenever the
//! measurement strays from what the plan predicted. The plans are made in the model's physics;
//! where the ball goes is the plant's. Everything is counted (steps, settles), nothing timed, so
//! the same inputs and seed give the same rows on any machine.

use crate::model::geometry::{rot_q, rotation_angle, rotation_axis, Orientation};
use crate::model::geometry::{CoilId, Pair, Radians, UnitVec};
use crate::model::random::SplitMix;
use crate::physics::dynamics::settle;
use crate::physics::torque::MagnetTorques;
use crate::planning::coilsets::{coils_of, label};
use crate::planning::commutation::{cumulative, cumulative_from, CommutationState, Motor, Step};
use crate::planning::identify::{Identifier, Observation};
use crate::planning::on_time::{self, OnTimes};
use crate::planning::plan::{path_deviation_deg, Plan, PlanRow, PlanSettings};
use crate::planning::search::{first_row, step_row};
use crate::planning::seek::{Path, Seek};
use serde::Serialize;

/// How the loop is closed.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LoopSettings {
    /// Replan at all (`false`: open loop, the plan played as it is, measured all the same).
    pub replan: bool,
    /// The sensor's noise: each measurement is the true orientation turned about a uniformly
    /// random axis by an angle drawn from a normal distribution of this standard deviation.
    pub noise: Radians,
    /// The noise generator's seed.
    pub seed: u64,
    /// Replan when the measurement is farther than this from the plan's prediction and the
    /// physics steering does not explain it (see [`Controller::observe`]).
    pub replan_beyond: Radians,
    /// Done when the ball is estimated within this of the goal.
    pub goal_tolerance: Radians,
    /// Give up after this many steps.
    pub max_steps: usize,
    /// Fit the wells to the measured steps ([`crate::planning::identify`]) and steer with the
    /// candidate that explains them clearly better than the model, once one does.
    pub identify: bool,
    /// The replan's beam: the states nearest the goal its search keeps at each depth
    /// ([`REPLAN_BEAM`] by default). A wider beam looks at more ways and takes longer, with the
    /// coils holding the ball.
    pub replan_beam: usize,
}

/// The loop replans beyond this many times the sensor's noise from the plan (a normal's three
/// deviations, which one measurement in 370 exceeds) ...
pub const REPLAN_NOISE_FACTOR: f64 = 3.0;
/// ... and at least this far, degrees.
pub const REPLAN_FLOOR_DEG: f64 = 1.0;
/// The loop is done within this many times the sensor's noise of the goal ...
pub const GOAL_NOISE_FACTOR: f64 = 2.0;
/// ... or this near, degrees, if that is more.
pub const GOAL_FLOOR_DEG: f64 = 1.5;

impl LoopSettings {
    /// Settings for a sensor noise of `noise`: replan beyond [`REPLAN_NOISE_FACTOR`] times the
    /// noise (at least [`REPLAN_FLOOR_DEG`]), done within [`GOAL_NOISE_FACTOR`] times the noise
    /// (at least [`GOAL_FLOOR_DEG`]), at most `max_steps` steps, the wells fitted.
    pub fn for_noise(noise: Radians, seed: u64, max_steps: usize) -> LoopSettings {
        LoopSettings {
            replan: true,
            noise,
            seed,
            replan_beyond: Radians(
                (REPLAN_NOISE_FACTOR * noise.0).max(REPLAN_FLOOR_DEG.to_radians()),
            ),
            goal_tolerance: Radians((GOAL_NOISE_FACTOR * noise.0).max(GOAL_FLOOR_DEG.to_radians())),
            max_steps,
            identify: true,
            replan_beam: REPLAN_BEAM,
        }
    }

    /// Open loop: the plan as it is, measured with the same sensor.
    pub fn open(noise: Radians, seed: u64) -> LoopSettings {
        LoopSettings {
            replan: false,
            max_steps: usize::MAX - 1,
            identify: false,
            ..LoopSettings::for_noise(noise, seed, 0)
        }
    }

    /// The least improvement a step must promise to be worth taking once the plan is played
    /// out: the noise (at least 0.25 degrees).
    fn worth(&self) -> f64 {
        self.noise.0.max(TRACK_DEG.to_radians())
    }
}

/// The ball is where the plan said when the physics steering puts the measurement's
/// equilibrium within this (degrees) of the plan's prediction: the same equilibrium, to the
/// settle's tolerance and the plan's rounding.
pub const TRACK_DEG: f64 = 0.25;

/// The replan's search (see [`crate::planning::seek`]): the states nearest the goal kept at
/// each depth, and how deep it looks at most (fewer where fewer steps are left). A replan is
/// made while the coils hold the ball: on 2 cores it takes tens of milliseconds.
pub const REPLAN_BEAM: usize = 4;
/// The replan's search looks at most this many steps deep (see [`REPLAN_BEAM`]).
pub const REPLAN_DEPTH: usize = 6;
/// The replan's search settles this many of each state's coil sets, those whose cheap
/// prediction lies nearest the goal.
pub const REPLAN_SETS: usize = 10;
/// A replan whose path gains less than [`SLOW_DEG`] a step towards the goal (and does not
/// reach it) is searched again settling this many sets per state; the nearer end is taken.
pub const REPLAN_SETS_WIDE: usize = 24;
/// A replan gaining less than this towards the goal per step, degrees, is searched again wider
/// ([`REPLAN_SETS_WIDE`]).
pub const SLOW_DEG: f64 = 5.0;

/// One step played on the plant.
#[derive(Debug, Clone, PartialEq)]
pub struct LoopRow {
    /// 0 is the initial commutation state.
    pub step: usize,
    /// What was on (the plan's set, as the model names its pairs).
    pub active: Vec<Pair>,
    /// Where the plan in force said the ball would be ...
    pub planned: Orientation,
    /// ... where the sensor said it was ...
    pub measured: Orientation,
    /// ... and where it was.
    pub truth: Orientation,
    /// The true cumulative rotation R_k R_0^T: its angle about the target axis and its axis
    /// error, degrees.
    pub cum_angle_deg: f64,
    /// The true cumulative axis error, degrees (see `cum_angle_deg`).
    pub cum_axis_error_deg: f64,
    /// The true orientation's angle from the goal R_target R_0, degrees.
    pub error_to_goal_deg: f64,
    /// Whether the rest of the motion was replanned after this step's measurement.
    pub replanned: bool,
    /// Whether the plant's settle of the step came to rest.
    pub settled: bool,
    /// The step's settle time, seconds: until the ball stayed within `settle.arrival_deg` of its
    /// rest.
    pub settle_time_s: f64,
}

/// How a closed-loop run ended.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct LoopSummary {
    /// Steps played after the initial commutation state.
    pub steps: usize,
    /// The true orientation's angle from the goal at the end, degrees.
    pub final_error_deg: f64,
    /// The true cumulative rotation's angle about the target axis at the end, degrees.
    pub final_angle_deg: f64,
    /// Worst true cumulative axis error over the steps that turned the ball at least
    /// [`MIN_AXIS_ANGLE_DEG`], degrees.
    pub max_axis_error_deg: f64,
    /// How far the measured orientations stray from the direct way: the worst angle (degrees)
    /// from one of them to the nearest point of the geodesic (the slerp) from the run's start
    /// (the plan's row 0) to its goal; what the loop saw, sensor noise included.
    pub max_path_deviation_deg: f64,
    /// How many times the controller replanned.
    pub replans: usize,
    /// The loop ended at the goal by its estimate (as the hardware loop decides) and its last
    /// measurement is within the goal tolerance too.
    pub reached: bool,
    /// The last measurement's angle from the goal, degrees.
    pub final_measured_error_deg: f64,
    /// Why the loop did not reach the goal, in words (`None` when it did).
    pub message: Option<String>,
    /// The fitted wells that steered the loop at the end (`None`: the model's own) ...
    pub fitted: Option<String>,
    /// ... from after this step's measurement (0: the initial commutation).
    pub fitted_after_step: Option<usize>,
    /// Settles spent fitting the wells.
    pub fit_settles: usize,
    /// The wall time of the replans (the whole decision after a measurement: the fit and the
    /// search), median and largest, ms (0 without replans). Reported, never decided on.
    pub replan_ms_median: f64,
    /// The largest replan's wall time, ms (see `replan_ms_median`).
    pub replan_ms_max: f64,
}

/// A closed-loop run: the rows and its summary.
#[derive(Debug, Clone)]
pub struct LoopRun {
    /// The steps played, row 0 (the initial commutation state) first.
    pub rows: Vec<LoopRow>,
    /// How the run ended.
    pub summary: LoopSummary,
    /// The wall time of each replan, ms, in order (the summary has their median and largest).
    pub replan_ms: Vec<f64>,
}

/// A sensor's noise: a turn about a uniform direction by a normal angle (Box-Muller) from
/// [`SplitMix`], the same on every machine (also the virtual motor's sensor's,
/// `crate::rehearse`).
pub struct Noise {
    rng: SplitMix,
    sigma: f64,
}

impl Noise {
    /// A sensor noise of standard deviation `sigma` from `seed`.
    pub fn new(seed: u64, sigma: Radians) -> Noise {
        Noise {
            rng: SplitMix::new(seed),
            sigma: sigma.0,
        }
    }

    /// A uniform number in (0, 1).
    pub fn uniform(&mut self) -> f64 {
        self.rng.uniform()
    }

    /// The true orientation as a sensor of this noise reports it.
    pub fn measure(&mut self, truth: &Orientation) -> Orientation {
        if self.sigma == 0.0 {
            return *truth;
        }
        let (u1, u2) = (self.uniform(), self.uniform());
        let angle = self.sigma * (-2.0 * u1.ln()).sqrt() * (std::f64::consts::TAU * u2).cos();
        let axis = self.rng.direction();
        rot_q(&axis, Radians(angle)) * truth
    }
}

/// What the controller decided after a measurement.
#[derive(Debug, Clone, PartialEq)]
pub enum Decision {
    /// Switch [`Controller::next_row`] next: the plan in force goes on ...
    Continue,
    /// ... or the rest was replanned from the measurement, and the new plan goes on.
    Replanned,
    /// The measurement is at the goal (closed loop), or the plan is played out (open loop).
    Done,
    /// Nothing more can be done: why.
    Stuck(String),
}

/// The closed loop's decisions, whatever measures the ball (a simulated plant and sensor, or
/// the hardware's): which row to switch next, and after each measurement whether the plan in
/// force goes on, is replanned, or is done.
///
/// A measurement is first explained: the set that was switched, settled in the physics that
/// steers (the model, or the fitted wells) from the measured orientation, gives the
/// equilibrium the ball is in. Where it lies within the noise of the measurement it is the
/// estimate (the noise filtered out: an equilibrium does not depend on where the ball came
/// from within its basin), else the measurement is. The plan goes on while the estimate is the
/// equilibrium it predicted; it is replanned from the estimate when the ball is elsewhere, when
/// the physics that steers changes, and when it is played out short of the goal (then only if
/// a step promises more than the noise).
pub struct Controller<'a> {
    model: &'a Motor,
    settings: PlanSettings,
    cl: LoopSettings,
    goal: Orientation,
    rows: Vec<PlanRow>,
    next: usize,
    replans: usize,
    /// Where the ball was before the row switched next: the plan's row 0 at first, then each
    /// measurement.
    last: Orientation,
    /// The fit of the wells to the measured steps (with `cl.identify`) ...
    identifier: Option<Identifier>,
    /// ... the step its candidate took over (after that step's measurement).
    fitted_at: Option<usize>,
    /// The candidate the plan in force was made with (`None`: the model).
    planned_with: Option<usize>,
    steps: usize,
    /// Wall time of each decision that searched (a replan), ms: reported, never decided on.
    replan_ms: Vec<f64>,
    /// The last measurement was at the goal (see [`Controller::arrived`]).
    arrived: bool,
    /// How long each coil on has been on, by the dwells of the rows played (see
    /// [`crate::planning::on_time`]): a replan keeps to the limit from there.
    on: OnTimes<CoilId>,
    /// Each step played: where the ball was before it and the coils it switched to (sorted).
    taken: Vec<(Orientation, Vec<CoilId>)>,
}

/// A replan from within this (degrees) of where the ball was before a step played earlier
/// does not take that step's coil set first again: the ball is back where it was, and the same
/// step would take it round the same circle (a plant the model does not describe can turn a
/// step the model expects forwards into one back).
pub const REVISIT_DEG: f64 = 0.5;

impl<'a> Controller<'a> {
    /// A controller that plays `open` (made with `model` for `settings`, row 0 its initial
    /// state) towards `goal`; `None` for a plan without rows.
    pub fn new(
        model: &'a Motor,
        settings: &PlanSettings,
        open: &Plan,
        goal: Orientation,
        cl: LoopSettings,
    ) -> Option<Self> {
        let first = open.rows.first()?;
        Some(Controller {
            model,
            settings: settings.clone(),
            cl,
            goal,
            rows: open.rows.clone(),
            next: 0,
            replans: 0,
            last: first.q,
            identifier: (cl.replan && cl.identify)
                .then(|| Identifier::new(&model.torques, cl.noise)),
            fitted_at: None,
            planned_with: None,
            steps: 0,
            replan_ms: Vec::new(),
            arrived: false,
            on: OnTimes::new(),
            taken: Vec::new(),
        })
    }

    /// The row whose set is switched next (row 0 first: the initial commutation state).
    pub fn next_row(&self) -> &PlanRow {
        &self.rows[self.next.min(self.rows.len() - 1)]
    }

    /// The goal orientation the loop steers to, as given to [`Controller::new`].
    pub fn goal(&self) -> Orientation {
        self.goal
    }

    /// The plan in force: the open plan, or after a replan the new one, whose row 0 is the
    /// state it was made from (the estimate, the coils on then) and whose row 1 is switched
    /// next.
    pub fn plan(&self) -> &[PlanRow] {
        &self.rows
    }

    /// How many times the controller has replanned so far.
    pub fn replans(&self) -> usize {
        self.replans
    }

    /// How long each coil on has been on as the loop counts it (empty without an on-time
    /// limit): the dwells of the rows played, [`STEP_IO`](on_time::STEP_IO) a step, and the
    /// limit's [`replan_reserve`](on_time::OnTimeLimit::replan_reserve) for each search while
    /// they held the ball.
    pub fn on_times(&self) -> &OnTimes<CoilId> {
        &self.on
    }

    /// The wall time of each replan so far (the whole decision: the fit and the search), ms.
    pub fn replan_ms(&self) -> &[f64] {
        &self.replan_ms
    }

    /// The most steps after the initial state the loop plays.
    pub fn max_steps(&self) -> usize {
        self.cl.max_steps
    }

    /// Whether the loop replans at all (else the plan is played as it is, measured).
    pub fn replanning(&self) -> bool {
        self.cl.replan
    }

    /// The goal tolerance, degrees.
    pub fn goal_tolerance_deg(&self) -> f64 {
        self.cl.goal_tolerance.0.to_degrees()
    }

    /// Whether `measured` is within the goal tolerance.
    pub fn at_goal(&self, measured: &Orientation) -> bool {
        angular(measured, &self.goal) <= self.cl.goal_tolerance.0
    }

    /// Whether the last measurement put the ball within the goal tolerance, as the loop
    /// estimated it (the measurement's equilibrium in the physics that steers, see
    /// [`Controller`]); open loop, by the measurement itself.
    pub fn arrived(&self) -> bool {
        self.arrived
    }

    /// The measurement after [`Controller::next_row`]'s set was switched and the ball settled:
    /// what to do next.
    pub fn observe(&mut self, measured: &Orientation) -> Decision {
        let started = std::time::Instant::now();
        let replans = self.replans;
        let d = self.decide(measured);
        if self.replans > replans || matches!(d, Decision::Stuck(_)) {
            self.replan_ms.push(started.elapsed().as_secs_f64() * 1e3);
        }
        d
    }

    fn decide(&mut self, measured: &Orientation) -> Decision {
        let row = self.next_row().clone();
        let last = self.next + 1 >= self.rows.len();
        if !self.cl.replan {
            self.arrived = self.at_goal(measured);
            self.next += 1;
            return if last {
                Decision::Done
            } else {
                Decision::Continue
            };
        }
        self.learn(&row.active, measured);
        if let Some(l) = self.settings.limits.on_time {
            row.hold(&mut self.on, &l);
        }
        loop {
            let steer = self.steering();
            let (est, explained) = self.estimate(steer, &row.active, measured);
            let distance = angular(&est, &self.goal);
            self.arrived = distance <= self.cl.goal_tolerance.0;
            // the plan's prediction is the equilibrium the ball is in, or lies within the noise
            // of the measurement
            let near = (explained && angular(&est, &row.q) <= TRACK_DEG.to_radians())
                || angular(measured, &row.q) <= self.cl.replan_beyond.0;
            let on_track = self.planned_with == steer && near;
            // arrived: done, unless the ball is on track and a row of the plan to come, within
            // the step budget, lies nearer the goal (the plan's landing comes nearer than the
            // tolerance, through states that may be further)
            if self.arrived && (last || !on_track || !self.nearer_ahead(distance)) {
                return Decision::Done;
            }
            if on_track && !last && self.next_fits() {
                self.next += 1;
                return Decision::Continue;
            }
            // played out on track: only a step that promises more than the noise is taken
            let worth = if on_track { self.cl.worth() } else { 0.0 };
            self.planned_with = steer;
            // the coils on hold the ball while the loop searches
            if let Some(l) = self.settings.limits.on_time {
                on_time::extend(&mut self.on, l.replan_reserve);
            }
            match self.search(steer, &est, &row.active) {
                Ok(p) if p.1 < distance - worth => return self.take(p.0),
                Ok(p) => {
                    return Decision::Stuck(format!(
                        "no step is expected to bring the ball nearer the goal than its {:.2} deg \
                         (by more than {:.2} deg; the nearest found {:.2} deg)",
                        distance.to_degrees(),
                        worth.to_degrees(),
                        p.1.to_degrees()
                    ))
                }
                // a fitted physics that leads nowhere steers no more: the next one tries
                Err(_) if steer.is_some() => {
                    if let (Some(k), Some(id)) = (steer, self.identifier.as_mut()) {
                        id.reject(k);
                    }
                }
                Err(m) => return Decision::Stuck(m),
            }
        }
    }

    /// Whether the plan's next row keeps every coil within the on-time limit as the loop
    /// counts it (the decisions included): a plan made in the open, or its steps after a slow
    /// stretch, may not; then the loop replans from what is on.
    fn next_fits(&self) -> bool {
        let (Some(l), Some(row)) = (self.settings.limits.on_time, self.rows.get(self.next + 1))
        else {
            return true;
        };
        let mut on = self.on.clone();
        row.hold(&mut on, &l);
        crate::planning::on_time::over(&on, l.max_on).is_none()
    }

    /// Whether a row of the plan still to come, within the steps left of `max_steps`, lies
    /// nearer the goal than `distance` (rad).
    fn nearer_ahead(&self, distance: f64) -> bool {
        let left = self.cl.max_steps.saturating_sub(self.steps);
        self.rows
            .iter()
            .skip(self.next + 1)
            .take(left)
            .any(|r| angular(&r.q, &self.goal) < distance)
    }

    /// The physics that steers now: `None` for the model, else the fitted candidate's index.
    fn steering(&self) -> Option<usize> {
        self.identifier.as_ref().and_then(|id| id.steer())
    }

    fn torques_of(&self, steer: Option<usize>) -> &MagnetTorques {
        match (steer, self.identifier.as_ref()) {
            (Some(k), Some(id)) => &id.candidate(k).torques,
            _ => &self.model.torques,
        }
    }

    /// Where the ball is, by the measurement and the physics `steer`: the equilibrium `active`
    /// holds it in, settled from the measurement, when it lies within the replan threshold of
    /// the measurement (`true`: explained); else the measurement itself.
    fn estimate(
        &self,
        steer: Option<usize>,
        active: &[Pair],
        measured: &Orientation,
    ) -> (Orientation, bool) {
        let torques = self.torques_of(steer);
        let pairs = label(torques, &coils_of(active), measured);
        let m = self.model;
        let r = settle(torques, &pairs, measured, m.body, m.settle);
        if r.settled && angular(&r.q, measured) <= self.cl.replan_beyond.0 {
            (r.q, true)
        } else {
            (*measured, false)
        }
    }

    /// The plan `p` (made from the estimate) in force from now on.
    fn take(&mut self, p: Plan) -> Decision {
        self.rows = p.rows;
        self.next = 1;
        self.replans += 1;
        Decision::Replanned
    }

    /// One more measured step for the fit of the wells (the ball was at `self.last`, `active`
    /// went on, it was measured at `measured`).
    fn learn(&mut self, active: &[Pair], measured: &Orientation) {
        let from = std::mem::replace(&mut self.last, *measured);
        self.steps += 1;
        self.taken.push((from, coils_of(active)));
        let Some(id) = self.identifier.as_mut() else {
            return;
        };
        let o = Observation {
            from,
            active: active.to_vec(),
            to: *measured,
        };
        let before = id.steer();
        id.observe(self.model, &o);
        // the step the fitted wells first took over from the model
        if id.steer().is_some() && before.is_none() {
            self.fitted_at = Some(self.steps - 1);
        }
    }

    /// What steers the loop: `None` for the model's own wells, else the fitted candidate's
    /// description and the step (0: the initial commutation) after which it took over.
    pub fn fitted(&self) -> Option<(String, usize)> {
        let id = self.identifier.as_ref()?;
        Some((id.candidate(id.steer()?).name.clone(), self.fitted_at?))
    }

    /// Settles spent fitting the wells.
    pub fn fit_settles(&self) -> usize {
        self.identifier.as_ref().map_or(0, |id| id.settles())
    }

    /// The rest of the motion in the physics `steer`, from the estimate `est` held by the
    /// coils on now: the search of [`Seek`] straight for the goal,
    /// [`LoopSettings::replan_beam`] wide, at most [`REPLAN_DEPTH`] deep, [`REPLAN_SETS`] sets
    /// settled per state (the steps left are counted against `max_steps`). Row 0 of the plan
    /// is the estimated state. The plan and the distance to the goal of its end; an
    /// error when no state is nearer the goal than the estimate.
    fn search(
        &self,
        steer: Option<usize>,
        est: &Orientation,
        active: &[Pair],
    ) -> Result<(Plan, f64), String> {
        let torques = self.torques_of(steer);
        let seek = Seek {
            motor: self.model,
            torques,
            per_step: self.settings.pairs,
            max_coils_on: self.settings.limits.max_coils_on,
            goal: self.goal,
            ranked: Some(REPLAN_SETS),
            on_time: self.settings.limits.on_time,
            held: self.on.clone(),
            not_first: (self.taken.iter())
                .filter(|(q, _)| angular(q, est) <= REVISIT_DEG.to_radians())
                .map(|(_, c)| c.clone())
                .collect(),
        };
        let root = CommutationState {
            q: *est,
            active: label(torques, &coils_of(active), est),
            settle_time_s: 0.0,
        };
        let left = self
            .cl
            .max_steps
            .saturating_sub(self.steps - 1)
            .clamp(1, REPLAN_DEPTH);
        let path = self.seek_path(&seek, &root, est, left);
        let Some(end) = path.states.last() else {
            let name = match steer {
                Some(_) => format!(
                    "the fitted {}",
                    self.fitted().map(|f| f.0).unwrap_or_default()
                ),
                None => "the model".into(),
            };
            return Err(format!(
                "no coil set leads the ball nearer the goal than its {:.2} deg within {left} \
                 steps ({} settles in {name})",
                angular(est, &self.goal).to_degrees(),
                path.settles,
            ));
        };
        let reached = angular(&end.q, &self.goal);
        let rows = self.rows_of(&root, est, &path);
        let plan = Plan {
            rows,
            reached: reached <= self.cl.goal_tolerance.0,
            message: None,
            settles: path.settles,
        };
        Ok((plan, reached))
    }

    /// [`Seek::search`] from `root`, `left` steps deep at most; when it gains less than
    /// [`SLOW_DEG`] a step short of the goal (the cheap ranking missed the way: broad wells,
    /// where every coil pulls many magnets), again with [`REPLAN_SETS_WIDE`] sets a state, and
    /// the nearer of the two (the settles of both counted).
    fn seek_path(
        &self,
        seek: &Seek,
        root: &CommutationState,
        est: &Orientation,
        left: usize,
    ) -> Path {
        let tolerance = self.cl.goal_tolerance.0;
        let mut path = seek.search(root, left, self.cl.replan_beam, tolerance);
        // short of the goal at less than SLOW_DEG a step: the cheap ranking missed the way
        // (broad wells, where every coil pulls many magnets); the search again, wider
        let start = angular(est, &self.goal);
        let slow = path.states.last().is_none_or(|end| {
            let gain = start - angular(&end.q, &self.goal);
            angular(&end.q, &self.goal) > tolerance
                && gain < SLOW_DEG.to_radians() * path.states.len() as f64
        });
        if slow {
            let wide = Seek {
                ranked: Some(REPLAN_SETS_WIDE),
                held: seek.held.clone(),
                not_first: seek.not_first.clone(),
                ..*seek
            };
            let again = wide.search(root, left, self.cl.replan_beam, tolerance);
            let end = |p: &Path| p.states.last().map_or(start, |e| angular(&e.q, &self.goal));
            let settles = path.settles + again.settles;
            if end(&again) < end(&path) {
                path = again;
            }
            path.settles = settles;
        }
        path
    }

    /// The plan's rows for `path` from `root` (the estimate `est`): row 0 the estimated state.
    fn rows_of(&self, root: &CommutationState, est: &Orientation, path: &Path) -> Vec<PlanRow> {
        let axis = &self.settings.axis;
        let mut rows = vec![first_row(root)];
        let mut from = root;
        let mut cum = 0.0;
        for to in &path.states {
            let (angle, axis_error) = cumulative(&from.q, &to.q, axis);
            let step = Step {
                pivot: None,
                new: to
                    .active
                    .iter()
                    .filter(|p| !from.active.iter().any(|o| o.coil == p.coil))
                    .copied()
                    .collect(),
                to: to.clone(),
                angle,
                axis_error,
            };
            let c = cumulative_from(est, &to.q, axis, cum);
            cum = c.0 .0;
            rows.push(step_row(rows.len(), &step, c));
            from = to;
        }
        rows
    }
}

/// The decision the loop makes from a measurement: [`Controller::observe`], handed to the
/// plant so that it can run it where it must (the hardware runs it under its watch of the
/// coils' on-time and of signals, see `crate::rig`).
pub type Decide<'a> = dyn FnMut(&Orientation) -> Decision + Send + 'a;

/// What a closed loop plays its rows on: a simulated motor and sensor, or the hardware's
/// boards and sensor. One loop ([`drive`]) drives the [`Controller`] against either.
pub trait Plant {
    /// Why the plant could not go on (nothing for a simulation; a board or sensor failure on
    /// the hardware).
    type Error;
    /// Switches `row`'s set as step `step` (0: the initial commutation state), lets the ball
    /// settle, measures it and hands the measurement to `decide`: the measurement and the
    /// decision.
    fn step(
        &mut self,
        step: usize,
        row: &PlanRow,
        decide: &mut Decide<'_>,
    ) -> Result<(Orientation, Decision), Self::Error>;
    /// After step `step` the controller `ctl` replaced the plan in force (`ctl.plan()`: row 0
    /// the measured state, row 1 switched next): the plant checks it against its own limits
    /// before anything of it is switched, and refuses it with an error.
    fn replanned(&mut self, step: usize, ctl: &Controller) -> Result<(), Self::Error>;
}

/// How a closed loop ended, unless its plant failed.
#[derive(Debug, Clone, PartialEq)]
pub enum Ending {
    /// The controller is done (the goal reached; open loop: the plan played out) ...
    Done,
    /// ... or nothing more can be done: why ...
    Stuck(String),
    /// ... or the controller's `max_steps` steps were played short of it.
    MaxSteps,
}

/// The closed loop: the controller's next row played on `plant`, the measurement decided on,
/// a replan handed to the plant to check, until the controller is done, stuck, or has played
/// its `max_steps` steps (steps 0..=max_steps). The ending and the last step played.
pub fn drive<P: Plant>(ctl: &mut Controller, plant: &mut P) -> Result<(Ending, usize), P::Error> {
    let max = ctl.max_steps();
    let mut step = 0;
    loop {
        let row = ctl.next_row().clone();
        let (_, decision) = plant.step(step, &row, &mut |q| ctl.observe(q))?;
        match decision {
            Decision::Continue => {}
            Decision::Replanned => plant.replanned(step, ctl)?,
            Decision::Done => return Ok((Ending::Done, step)),
            Decision::Stuck(m) => return Ok((Ending::Stuck(m), step)),
        }
        if step >= max {
            return Ok((Ending::MaxSteps, step));
        }
        step += 1;
    }
}

/// The simulated plant: the plant's physics settles each set from where the last left the
/// ball, a seeded sensor measures it; every step is kept as a [`LoopRow`].
struct Simulated<'a> {
    plant: &'a Motor,
    noise: Noise,
    truth: Orientation,
    rows: Loop<'a>,
}

impl Plant for Simulated<'_> {
    type Error = std::convert::Infallible;

    fn step(
        &mut self,
        _step: usize,
        row: &PlanRow,
        decide: &mut Decide<'_>,
    ) -> Result<(Orientation, Decision), Self::Error> {
        let p = self.plant;
        let res = settle(&p.torques, &row.active, &self.truth, p.body, p.settle);
        self.truth = res.q;
        let measured = self.noise.measure(&self.truth);
        let decision = decide(&measured);
        let replanned = decision == Decision::Replanned;
        self.rows.push(row, measured, &res, replanned);
        Ok((measured, decision))
    }

    fn replanned(&mut self, _step: usize, _ctl: &Controller) -> Result<(), Self::Error> {
        Ok(())
    }
}

/// Plays `open` (a plan made with `model` for `settings`) on `plant`, closing the loop as
/// `cl` says, towards `goal` (the plan's target: ROT[axis, angle] applied to its row 0, see
/// [`goal_of`]): the plant settles each set from where the last left the ball, a simulated
/// sensor measures it, the [`Controller`] decides ([`drive`]).
pub fn run_closed_loop(
    model: &Motor,
    plant: &Motor,
    settings: &PlanSettings,
    open: &Plan,
    goal: Orientation,
    cl: &LoopSettings,
) -> LoopRun {
    let Some(mut ctl) = Controller::new(model, settings, open, goal, *cl) else {
        return no_run("the plan has no initial commutation state");
    };
    let q0 = open.rows[0].q;
    let mut sim = Simulated {
        plant,
        noise: Noise {
            rng: SplitMix::new(cl.seed),
            sigma: cl.noise.0,
        },
        // row 0: the ball at rest at the plan's start, the initial set on
        truth: q0,
        rows: Loop {
            settings,
            q0,
            goal,
            rows: Vec::new(),
        },
    };
    let (ending, _) = match drive(&mut ctl, &mut sim) {
        Ok(end) => end,
        Err(never) => match never {},
    };
    let message = match ending {
        Ending::Done => None,
        Ending::Stuck(m) => Some(m),
        Ending::MaxSteps => Some(format!("stopped after {} steps", cl.max_steps)),
    };
    let lp = sim.rows;
    // the loop decides on its estimate (the measurement's equilibrium); reached is said on the
    // last measurement, as the hardware loop says it
    let measured = lp
        .rows
        .last()
        .map(|r| r.measured.angle_to(&goal).to_degrees());
    let measured = measured.unwrap_or(f64::INFINITY);
    let tolerance = cl.goal_tolerance.0.to_degrees();
    let reached = ctl.arrived() && measured <= tolerance;
    let message = match (message, ctl.arrived() && !reached) {
        (None, true) => Some(not_at_goal(measured, tolerance)),
        (m, _) => m,
    };
    let mut run = lp.finish(message, reached, ctl.replans());
    run.summary.final_measured_error_deg = measured;
    if let Some((name, step)) = ctl.fitted() {
        run.summary.fitted = Some(name);
        run.summary.fitted_after_step = Some(step);
    }
    run.summary.fit_settles = ctl.fit_settles();
    (run.summary.replan_ms_median, run.summary.replan_ms_max) = median_max(ctl.replan_ms());
    run.replan_ms = ctl.replan_ms().to_vec();
    run
}

/// Why a loop that stopped at the goal by its estimate is not at it: the last measurement
/// (`measured`, degrees) lies beyond the goal tolerance (degrees).
pub fn not_at_goal(measured: f64, tolerance: f64) -> String {
    format!(
        "the loop stopped at the goal by its estimate, but the last measurement is \
         {measured:.2} deg from it, over the goal tolerance of {tolerance:.2} deg"
    )
}

/// The median (the upper of the middle two) and the largest of `ms` (0 and 0 for none).
pub fn median_max(ms: &[f64]) -> (f64, f64) {
    let mut v = ms.to_vec();
    v.sort_by(f64::total_cmp);
    (
        v.get(v.len() / 2).copied().unwrap_or(0.0),
        v.last().copied().unwrap_or(0.0),
    )
}

pub use crate::planning::plan::goal_of;

/// The target a plan file says it is for: the rotation from its row 0 to its last row, as the
/// axis (`None` for no rotation) and angle of `settings`.
pub fn target_of(rows: &[PlanRow]) -> Option<(UnitVec, Radians)> {
    let (first, last) = (rows.first()?, rows.last()?);
    let turn = last.q * first.q.inverse();
    Some((rotation_axis(&turn)?, rotation_angle(&turn)))
}

fn angular(a: &Orientation, b: &Orientation) -> f64 {
    a.angle_to(b)
}

fn no_run(message: &str) -> LoopRun {
    LoopRun {
        replan_ms: Vec::new(),
        rows: Vec::new(),
        summary: LoopSummary {
            steps: 0,
            final_error_deg: f64::NAN,
            final_angle_deg: 0.0,
            max_axis_error_deg: 0.0,
            max_path_deviation_deg: 0.0,
            replans: 0,
            reached: false,
            final_measured_error_deg: f64::NAN,
            message: Some(message.into()),
            fitted: None,
            fitted_after_step: None,
            fit_settles: 0,
            replan_ms_median: 0.0,
            replan_ms_max: 0.0,
        },
    }
}

/// A cumulative rotation smaller than this (degrees) has no axis worth the name: its axis error
/// is left out of a run's worst (the row keeps it). The ball held by the plant's initial set
/// sits a fraction of a degree from where the model put it, and the axis of that offset
/// points anywhere (a 0.6 degree offset 90 degrees off the axis); at 2 degrees such an offset
/// still swings the axis by up to some 17 degrees, beyond 2 degrees less and less.
pub const MIN_AXIS_ANGLE_DEG: f64 = 2.0;

/// The worst true cumulative axis error over a run's rows, degrees, of the rows that have
/// turned the ball at least [`MIN_AXIS_ANGLE_DEG`] either way (0 when none has).
pub fn worst_axis_error_deg(rows: &[LoopRow]) -> f64 {
    rows.iter()
        .filter(|r| r.cum_angle_deg.abs() >= MIN_AXIS_ANGLE_DEG)
        .map(|r| r.cum_axis_error_deg)
        .fold(0.0, f64::max)
}

/// The rows of a simulated run as they come.
struct Loop<'a> {
    settings: &'a PlanSettings,
    q0: Orientation,
    goal: Orientation,
    rows: Vec<LoopRow>,
}

impl Loop<'_> {
    fn push(
        &mut self,
        row: &PlanRow,
        measured: Orientation,
        res: &crate::physics::dynamics::SettleResult,
        replanned: bool,
    ) {
        let before = self
            .rows
            .last()
            .map_or(0.0, |r| r.cum_angle_deg.to_radians());
        let (angle, err) = cumulative_from(&self.q0, &res.q, &self.settings.axis, before);
        self.rows.push(LoopRow {
            step: self.rows.len(),
            active: row.active.clone(),
            planned: row.q,
            measured,
            truth: res.q,
            cum_angle_deg: angle.0.to_degrees(),
            cum_axis_error_deg: err.0.to_degrees(),
            error_to_goal_deg: angular(&res.q, &self.goal).to_degrees(),
            replanned,
            settled: res.settled,
            settle_time_s: res.arrival_time_s,
        });
    }

    fn finish(self, message: Option<String>, reached: bool, replans: usize) -> LoopRun {
        let last = self.rows.last();
        let summary = LoopSummary {
            steps: self.rows.len().saturating_sub(1),
            final_error_deg: last.map(|r| r.error_to_goal_deg).unwrap_or(f64::NAN),
            final_angle_deg: last.map(|r| r.cum_angle_deg).unwrap_or(0.0),
            max_axis_error_deg: worst_axis_error_deg(&self.rows),
            max_path_deviation_deg: path_deviation_deg(
                self.rows.iter().map(|r| &r.measured),
                &self.q0,
                &self.goal,
            ),
            replans,
            reached,
            final_measured_error_deg: f64::NAN,
            message,
            fitted: None,
            fitted_after_step: None,
            fit_settles: 0,
            replan_ms_median: 0.0,
            replan_ms_max: 0.0,
        };
        LoopRun {
            replan_ms: Vec::new(),
            rows: self.rows,
            summary,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Every "max(F, K x noise)" the book and the replay's help state (the noise written `S`,
    /// `x noise` or ``x `--sensor-noise-deg` ``) as (F, K).
    fn thresholds_stated(text: &str) -> Vec<(f64, f64)> {
        let mut found = Vec::new();
        for part in text.split("max(").skip(1) {
            let Some((floor, rest)) = part.split_once(", ") else {
                continue;
            };
            let floor = floor
                .trim_end_matches(" degrees")
                .trim_end_matches(" degree");
            let floor = floor.trim_end_matches(" deg");
            let Some((factor, noise)) = rest.split_once(' ') else {
                continue;
            };
            let noisy = ["S)", "S;", "x noise", "x `--sensor-noise-deg`"];
            if !noisy.iter().any(|n| noise.starts_with(n)) {
                continue;
            }
            if let (Ok(f), Ok(k)) = (floor.parse::<f64>(), factor.parse::<f64>()) {
                found.push((f, k));
            }
        }
        found
    }

    #[test]
    fn the_book_and_the_help_state_the_thresholds_the_loop_has() {
        let root = std::path::Path::new(env!("CARGO_MANIFEST_DIR"));
        let mut files: Vec<_> = std::fs::read_dir(root.join("docs"))
            .unwrap()
            .map(|e| e.unwrap().path())
            .filter(|p| p.extension().is_some_and(|x| x == "md"))
            .collect();
        files.push(root.join("src/cli/replay.rs"));
        files.sort();
        let allowed = [
            (REPLAN_FLOOR_DEG, REPLAN_NOISE_FACTOR),
            (GOAL_FLOOR_DEG, GOAL_NOISE_FACTOR),
        ];
        let mut seen = Vec::new();
        for f in &files {
            let text = std::fs::read_to_string(f).unwrap().replace('\n', " ");
            let text = text.replace("///", " ");
            let text = text.split_whitespace().collect::<Vec<_>>().join(" ");
            for t in thresholds_stated(&text) {
                assert!(
                    allowed.contains(&t),
                    "{}: max({}, {} x noise)",
                    f.display(),
                    t.0,
                    t.1
                );
                seen.push(t);
            }
        }
        // both stated, in the book and the help (which this reads among the files)
        assert!(allowed.iter().all(|a| seen.contains(a)), "{seen:?}");
        assert!(seen.len() >= 8, "{seen:?}");
        // and what the settings use
        let l = LoopSettings::for_noise(Radians(2f64.to_radians()), 1, 10);
        assert!((l.replan_beyond.0.to_degrees() - 6.0).abs() < 1e-9);
        assert!((l.goal_tolerance.0.to_degrees() - 4.0).abs() < 1e-9);
        let quiet = LoopSettings::for_noise(Radians(0.1f64.to_radians()), 1, 10);
        assert!((quiet.replan_beyond.0.to_degrees() - 1.0).abs() < 1e-9);
        assert!((quiet.goal_tolerance.0.to_degrees() - 1.5).abs() < 1e-9);
    }
    use nalgebra::Vector3;

    #[test]
    fn the_sensor_noise_has_the_asked_spread_and_no_preferred_axis() {
        // |angle| of a normal of deviation sigma averages sigma sqrt(2 / pi); the turn axes
        // are uniform on the sphere (their mean is near 0)
        let sigma = 1f64.to_radians();
        let mut noise = Noise {
            rng: SplitMix::new(99),
            sigma,
        };
        let truth = rot_q(
            &UnitVec::new_normalize(Vector3::new(0.3, -0.2, 1.0)),
            Radians(0.7),
        );
        let n = 20_000;
        let (mut sum, mut axes) = (0.0, Vector3::zeros());
        for _ in 0..n {
            let m = noise.measure(&truth);
            let d = m * truth.inverse();
            sum += rotation_angle(&d).0;
            axes += rotation_axis(&d)
                .map(|a| a.into_inner())
                .unwrap_or_default();
        }
        let mean = sum / n as f64;
        let expected = sigma * (2.0 / std::f64::consts::PI).sqrt();
        assert!((mean / expected - 1.0).abs() < 0.02, "{mean} vs {expected}");
        assert!(axes.norm() / (n as f64) < 0.02, "{axes}");
        // no noise: the truth itself
        let mut none = Noise {
            rng: SplitMix::new(1),
            sigma: 0.0,
        };
        assert_eq!(none.measure(&truth), truth);
    }
}
