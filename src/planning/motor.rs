//! The motor as a user calls it: the entry points of the library as methods of [`Motor`] (a
//! scenario's physics, copied out of it by [`crate::Scenario::motor`]), each the free function
//! of its layer with the motor's torques, body and settle parameters filled in.

use crate::model::geometry::{Orientation, Pair};
use crate::physics::dynamics::{self, SettleResult};
use crate::physics::well_curve::{summarise, well_curve, StepError, WellSummary};
use crate::planning::closed_loop::{run_closed_loop, LoopRun, LoopSettings};
use crate::planning::commutation::Motor;
use crate::planning::plan::{Plan, PlanRow, PlanSettings};
use crate::planning::planner;
use crate::planning::simulate::{self, SimRow};
use crate::planning::waypoints::WaypointPlan;

impl Motor {
    /// Settles the ball from `q0` under the coil:magnet pairs `pairs` (see
    /// [`dynamics::settle`]). The pairs' indices must be the motor's (a scenario checks them:
    /// [`crate::Scenario::check_active`]).
    ///
    /// # Errors
    ///
    /// None: a ball that does not come to rest within the settle's `t_max` is a result
    /// (`settled` false, [`SettleResult::stop`] says why), not an error.
    ///
    /// # Examples
    ///
    /// ```
    /// use spherestep::{parse_pairs, Orientation, Scenario};
    ///
    /// let sc = Scenario::prototype();
    /// let pairs = parse_pairs("0:14,12:26", "pairs").unwrap();
    /// let r = sc.motor().settle(&pairs, &Orientation::identity());
    /// assert!(r.settled && r.residual_torque_nm < sc.settle.torque_tol);
    /// ```
    pub fn settle(&self, pairs: &[Pair], q0: &Orientation) -> SettleResult {
        dynamics::settle(&self.torques, pairs, q0, self.body, self.settle)
    }

    /// Settles each of `sets` from `q0`, in parallel; the results in the sets' order, the same
    /// on any number of threads.
    ///
    /// # Errors
    ///
    /// None, as for [`Motor::settle`]: each result says whether its set settled.
    ///
    /// # Examples
    ///
    /// ```
    /// use spherestep::{parse_pairs, Orientation, Scenario};
    ///
    /// let m = Scenario::prototype().motor();
    /// let sets = vec![
    ///     parse_pairs("0:14,12:26", "pairs").unwrap(),
    ///     parse_pairs("0:14", "pairs").unwrap(),
    /// ];
    /// let q0 = Orientation::identity();
    /// let rs = m.settle_many(&sets, &q0);
    /// assert_eq!(rs.len(), 2);
    /// assert_eq!(rs[0].q, m.settle(&sets[0], &q0).q);
    /// ```
    pub fn settle_many(&self, sets: &[Vec<Pair>], q0: &Orientation) -> Vec<SettleResult> {
        dynamics::settle_many(&self.torques, sets, q0, self.body, self.settle)
    }

    /// Plans the motion `settings` asks for (axis, angle, step model, limits).
    ///
    /// # Errors
    ///
    /// None: a plan that does not reach the target is returned as far as it got, with
    /// `reached` false and [`Plan::message`] saying why.
    ///
    /// # Examples
    ///
    /// ```
    /// use spherestep::Scenario;
    ///
    /// let sc = Scenario::prototype();
    /// let p = sc.motor().plan(&sc.plan);
    /// assert!(p.rows.len() > 1);
    /// // reached: within the settings' tolerance (1 degree) of the target orientation
    /// let off = p.summary(&sc.plan).final_orientation_error_deg;
    /// assert_eq!(p.reached, off <= 1.0, "{:?}", p.message);
    /// ```
    pub fn plan(&self, settings: &PlanSettings) -> Plan {
        planner::plan(self, settings)
    }

    /// Plans one motion through `waypoints` (orientations, in order) from `settings.start`,
    /// every waypoint reached within `tolerance_deg` degrees: each leg is the shortest turn to
    /// its waypoint from where the ball is, planned with the settings' model, scheme and
    /// limits, its coils still on from the leg before (their on-times counted on). The
    /// settings' axis and angle are not used.
    ///
    /// # Errors
    ///
    /// None: a path that cannot be followed is a plan with `reached` false and
    /// [`WaypointPlan::message`] saying which waypoint was missed and why.
    ///
    /// # Examples
    ///
    /// ```
    /// use spherestep::{Orientation, Scenario};
    ///
    /// let sc = Scenario::prototype();
    /// // 20 degrees about Y, then 10 about X from there (world frame)
    /// let first = Orientation::from_euler_angles(0.0, 20f64.to_radians(), 0.0);
    /// let second = Orientation::from_euler_angles(10f64.to_radians(), 0.0, 0.0) * first;
    /// let p = sc.motor().plan_waypoints(&sc.plan, &[first, second], 3.0);
    /// assert!(p.reached, "{:?}", p.message);
    /// assert!(p.reached_at().iter().all(|w| w.error_deg <= 3.0));
    /// ```
    pub fn plan_waypoints(
        &self,
        settings: &PlanSettings,
        waypoints: &[Orientation],
        tolerance_deg: f64,
    ) -> WaypointPlan {
        crate::planning::waypoints::plan_waypoints(self, settings, waypoints, tolerance_deg)
    }

    /// Replays a plan's rows through the dynamics: where the ball really settles at each step
    /// (from row 0's orientation, each row's set from where the last left the ball). No rows,
    /// no steps.
    ///
    /// # Errors
    ///
    /// None: a step that does not settle is a row with `settled` false.
    ///
    /// # Examples
    ///
    /// ```
    /// use spherestep::Scenario;
    ///
    /// let sc = Scenario::prototype();
    /// let m = sc.motor();
    /// let sim = m.simulate(&m.plan(&sc.plan).rows);
    /// assert!(sim.iter().all(|s| s.deviation_deg < 1e-6));
    /// ```
    pub fn simulate(&self, rows: &[PlanRow]) -> Vec<SimRow> {
        simulate::simulate(self, rows)
    }

    /// The motor's well as a bench would measure it (what `spherestep wells` computes): the
    /// torque on one magnet passing one energised coil, (angle, deg; torque, N m) every
    /// `step_deg` degrees from 0 to the cut-off, and its summary. An error for a step outside
    /// [`MIN_STEP_DEG`, `MAX_STEP_DEG`].
    ///
    /// [`MIN_STEP_DEG`]: crate::physics::well_curve::MIN_STEP_DEG
    /// [`MAX_STEP_DEG`]: crate::physics::well_curve::MAX_STEP_DEG
    ///
    /// # Errors
    ///
    /// [`StepError`] (which [`crate::Error`] gathers as its `Input` about `step_deg`) for a
    /// `step_deg` that is not a number in [`MIN_STEP_DEG`, `MAX_STEP_DEG`].
    ///
    /// # Examples
    ///
    /// ```
    /// use spherestep::Scenario;
    ///
    /// let (curve, summary) = Scenario::prototype().motor().wells(0.5).unwrap();
    /// assert_eq!(curve[0], (0.0, 0.0));
    /// assert_eq!(summary.rows, curve.len());
    /// assert!(summary.peak_torque_nm > 0.8 && summary.peak_angle_deg > 5.0);
    /// ```
    pub fn wells(&self, step_deg: f64) -> Result<(Vec<(f64, f64)>, WellSummary), StepError> {
        let curve = well_curve(&self.torques.well, step_deg)?;
        let summary = summarise(&self.torques.well, &curve);
        Ok((curve, summary))
    }

    /// Plays `open` (a plan of this motor's for `settings`) on `plant` with the closed loop
    /// `cl` towards `goal` (see [`run_closed_loop`]; [`crate::goal_of`] gives a plan's goal):
    /// `plant` settles each set, a simulated sensor measures it, and the loop replans in this
    /// motor, its model, when the measurement strays.
    ///
    /// # Errors
    ///
    /// None: a run that cannot go on (no initial state, no step towards the goal, the step
    /// limit) ends with [`LoopSummary::reached`] false and [`LoopSummary::message`] saying
    /// why.
    ///
    /// [`LoopSummary::reached`]: crate::LoopSummary::reached
    /// [`LoopSummary::message`]: crate::LoopSummary::message
    ///
    /// # Examples
    ///
    /// The prototype's plan played open loop on the motor itself, with a noiseless sensor:
    ///
    /// ```
    /// use spherestep::{goal_of, LoopSettings, Radians, Scenario};
    ///
    /// let sc = Scenario::prototype();
    /// let m = sc.motor();
    /// let p = m.plan(&sc.plan);
    /// let goal = goal_of(&sc.plan, &p.rows).unwrap();
    /// let run = m.run(&m, &sc.plan, &p, goal, &LoopSettings::open(Radians(0.0), 1));
    /// assert_eq!(run.summary.replans, 0);
    /// assert!(!run.rows.is_empty());
    /// ```
    pub fn run(
        &self,
        plant: &Motor,
        settings: &PlanSettings,
        open: &Plan,
        goal: Orientation,
        cl: &LoopSettings,
    ) -> LoopRun {
        run_closed_loop(self, plant, settings, open, goal, cl)
    }
}
