//! Closed loop on the hardware (`spherestep replay PLAN SCENARIO --sensor DEV ...`): the
//! replay of `relay::replay` (the same boards, switching, dwells, guards and all-off endings), and
//! after each step's dwell the ball's orientation read from an orientation sensor and handed to
//! the closed loop's [`Controller`]: the plan in force goes on, or is replaced by one replanned
//! from the measurement, or the ball is at the goal, or nothing more can be done. A replanned
//! plan is checked as `prepare` checks a schedule (every coil mapped, coils on at once counted
//! from what is on now, on-times across the joint) before anything of it is switched. Any sensor
//! error ends the replay with every coil of every board off. Steps are numbered as they are
//! switched (0: the initial state), through replans.
//!
//! While the sensor is awaited and the controller decides (fitting the wells, replanning:
//! seconds, with a large search), the coils of the step stay on. That phase runs on a worker
//! thread; this thread watches the stop flag (a signal) and the runner's guard every
//! [`POLL`](crate::relay::replay::POLL). When either fires it switches every coil off at once, before
//! a coil reaches its limit ([`guard_margin`](crate::planning::on_time::guard_margin) ahead of it), then abandons the reading
//! and the computation through the [`Cancel`] token they were given, and ends the replay.

use super::error::RigError;
use crate::model::geometry::Orientation;
use crate::planning::cancel::Cancel;
use crate::planning::closed_loop::{
    drive, Controller, Decide, Decision, Ending, LoopSettings, Plant,
};
use crate::planning::plan::PlanRow;
use crate::relay::replay::{
    check_on_time, entries_from, stdout_error, Drive, Entry, LogKind, Mode, Prepared, Resume,
    Runner, POLL,
};
use crate::relay::{Link, RelayError, Setting};
use crate::sensor::frame::{axis_angle_text, Tared};
use crate::sensor::{OrientationSensor, Reading, SensorError};
use std::io::Write;
use std::sync::atomic::{AtomicBool, AtomicU8, Ordering};
use std::sync::mpsc::{self, RecvTimeoutError};
use std::sync::Arc;
use std::time::Duration;

/// What the worker of a watched phase sends: the reading as soon as it is taken, then the
/// orientation read and the decision made from it.
enum Worked {
    Read(Reading),
    Decided(Orientation, Decision),
}

/// An error of the watched phase that only a bug can cause.
fn internal(step: usize, what: &str) -> RigError {
    RigError::Stuck {
        step,
        message: format!("{what} (an internal error)"),
    }
}

/// The phases of the watched part of a step, for messages.
const WAITING: u8 = 0;
const DECIDING: u8 = 1;

fn phase_name(phase: u8) -> &'static str {
    if phase == WAITING {
        "the closed loop was waiting for the sensor"
    } else {
        "the closed loop was deciding (fitting the wells, replanning)"
    }
}

/// What closes the loop: the sensor, the controller deciding from its readings, and what the
/// checks of a replanned plan need besides the prepared replay.
pub struct Sensing<'a> {
    /// The orientation sensor, read after each step's dwell.
    pub sensor: Box<dyn OrientationSensor>,
    /// The controller that decides each next step from the readings (and replans).
    pub controller: Controller<'a>,
    /// The controller's settings (its thresholds, for the header; `max_steps`).
    pub settings: LoopSettings,
    /// The stator's coil count (a replanned coil must be on it).
    pub stator_coils: usize,
    /// The sensor's mounting in the ball (the scenario's `[sensor]`): sensor to body.
    pub mount: Orientation,
    /// The token the controller's motor was built with ([`crate::planning::commutation::Motor`]'s
    /// `cancel`): set to abandon a replan when the coils must go off. The sensor is given it
    /// too.
    pub cancel: Cancel,
}

/// How a closed-loop replay that reached the goal went.
#[derive(Debug, Clone, PartialEq)]
pub struct ClosedSummary {
    /// Steps switched after the initial state.
    pub steps: usize,
    /// How many times the controller replanned.
    pub replans: usize,
    /// The last measurement's angle from the goal, degrees.
    pub distance_deg: f64,
}

/// Refuses the replay options a closed loop cannot honour: a dry run (nothing would measure the
/// ball), step mode and a first step other than 0 (see the messages).
pub fn refuse_options(drive: &Drive, dry_run: bool) -> Result<(), RelayError> {
    let refuse = |setting: Setting, expected: &str| {
        Err(RelayError::Setting {
            setting,
            expected: expected.into(),
        })
    };
    if dry_run {
        return refuse(
            Setting::DryRun,
            "none with a sensor (nothing would measure the ball: dry-run the plan without the \
             sensor, or simulate the closed loop in a plant scenario: `spherestep simulate` with \
             a plant and the closed loop)",
        );
    }
    if drive.mode == Mode::Step {
        return refuse(
            Setting::Mode,
            "realtime with a sensor (step mode waits for Enter instead of the dwell, so the \
             on-time of a replanned plan could not be checked before it is switched)",
        );
    }
    if drive.from_step != 0 {
        return refuse(
            Setting::FromStep,
            "0 with a sensor (the closed loop starts from the plan's initial state and replans \
             from what it measures: to go on after a stop, plan anew from where the ball is)",
        );
    }
    Ok(())
}

/// Replays `prep` over `links` (one per board, opened by the caller) closing the loop through
/// `sensing`: all off first, then for each step switch, verify (`--verify`), dwell, read the
/// sensor, decide. Ends with every coil off on every board, whatever happened.
pub fn execute_closed(
    prep: &Prepared,
    links: Vec<Link>,
    sensing: Sensing,
    stop: Arc<AtomicBool>,
    out: &mut dyn Write,
) -> Result<ClosedSummary, RigError> {
    refuse_options(&prep.drive, links.iter().all(Link::is_dry_run))?;
    let Sensing {
        mut sensor,
        mut controller,
        settings: s,
        stator_coils,
        mount,
        cancel,
    } = sensing;
    sensor.set_cancel(cancel.clone());
    // before any byte goes to a board: a sensor that cannot measure yet is refused
    if let Some(c) = sensor.ready()? {
        writeln!(out, "sensor calibration: {c}").map_err(stdout_error)?;
    }
    // the tare, before any byte goes to a board: the ball is at rest at the plan's start
    let start = controller.plan()[0].q;
    let (sensor, tare) =
        Tared::tare(sensor, mount, &start).map_err(|e| SensorError::Tare { cause: Box::new(e) })?;
    let frame = sensor.frame();
    writeln!(out, "{}", header(&s, &sensor.describe())).map_err(stdout_error)?;
    let w = frame.reference;
    writeln!(
        out,
        "sensor tare: its reference is the world turned {} (qx,qy,qz,qw = {:.6},{:.6},{:.6},{:.6}); mounted {} in the ball; tare reading \"{}\"",
        axis_angle_text(&w),
        w.i,
        w.j,
        w.k,
        w.w,
        axis_angle_text(&frame.mount),
        tare.raw.to_string().escape_debug()
    )
    .map_err(stdout_error)?;
    let mut r = Runner::start(prep, links, stop, None, out, LogKind::ClosedLoop)?;
    r.log_start(0)?;
    log_tare(&mut r, &w, &tare)?;
    let mut hw = Hardware {
        prep,
        entries: prep.schedule.entries.clone(),
        index: 0,
        current: None,
        steps: 0,
        senses: Senses {
            sensor: Box::new(sensor),
            cancel,
            goal: controller.goal(),
            last: None,
        },
        stator_coils,
        r: &mut r,
    };
    let result = hw.run(&mut controller);
    let (steps, last) = (hw.steps, hw.senses.last);
    let ending = LoopEnd {
        steps,
        last,
        replans: controller.replans(),
        replan: s.replan,
    };
    finish(&mut r, result, ending)
}

/// The hardware as the closed loop's [`Plant`]: the runner switching the boards, the sensor.
struct Hardware<'p, 'r, 'w> {
    prep: &'p Prepared,
    /// The checked entries of the plan in force (after a replan, from its row 1).
    entries: Vec<Entry>,
    /// The entry switched next (the controller's next row).
    index: usize,
    /// The entry switched last.
    current: Option<Entry>,
    /// The last step switched (or being switched).
    steps: usize,
    senses: Senses,
    stator_coils: usize,
    r: &'r mut Runner<'w>,
}

/// The sensor's side of the hardware: the sensor, the token that abandons its reading and the
/// decision, the goal and how far the last measurement was from it.
struct Senses {
    sensor: Box<dyn OrientationSensor>,
    cancel: Cancel,
    goal: Orientation,
    /// The last measurement's angle from the goal, degrees.
    last: Option<f64>,
}

impl Hardware<'_, '_, '_> {
    /// All off, then the closed loop ([`drive`]) until the controller is done (`Ok`) or
    /// something stops it.
    fn run(&mut self, ctl: &mut Controller) -> Result<(), RigError> {
        self.r.start_off()?;
        let (ending, step) = drive(ctl, self)?;
        match ending {
            // played as it is: the end of the plan, wherever the ball is
            Ending::Done if !ctl.replanning() => Ok(self.r.mark(step, "end")?),
            Ending::Done => match self.senses.last {
                // the loop decided on its estimate: the measurement must agree
                Some(d) if d > ctl.goal_tolerance_deg() => Err(RigError::Stuck {
                    step,
                    message: crate::planning::closed_loop::not_at_goal(d, ctl.goal_tolerance_deg()),
                }),
                _ => Ok(self.r.mark(step, "goal")?),
            },
            Ending::Stuck(message) => Err(RigError::Stuck { step, message }),
            Ending::MaxSteps => Err(RigError::MaxSteps {
                steps: step,
                max: ctl.max_steps(),
                distance_deg: self.senses.last.unwrap_or(f64::NAN),
            }),
        }
    }
}

impl Senses {
    /// Reads the sensor and has the controller decide on a worker thread, while this one
    /// watches the stop flag and the on-time limit (see the module comment): the reading and
    /// the decision, or why the coils were switched off first. The reading is printed and logged as soon as it arrives (the decision may take long).
    fn sense_and_decide(
        &mut self,
        r: &mut Runner,
        step: usize,
        planned: &Orientation,
        decide: &mut Decide<'_>,
    ) -> Result<(Orientation, Decision), RigError> {
        let cancel = self.cancel.clone();
        let phase = AtomicU8::new(WAITING);
        let goal = self.goal;
        let last = &mut self.last;
        let sensor = &mut self.sensor;
        let (tx, rx) = mpsc::channel();
        std::thread::scope(|scope| {
            let work = || read_and_decide(sensor.as_mut(), decide, &phase, tx);
            let worker = std::thread::Builder::new()
                .name("closed-loop decision".into())
                .spawn_scoped(scope, work)
                .map_err(|e| RigError::Stuck {
                    step,
                    message: format!("cannot start the thread that reads the sensor: {e}"),
                })?;
            let outcome = loop {
                match rx.recv_timeout(POLL) {
                    Ok(Ok(Worked::Decided(q, d))) => break Ok((q, d)),
                    Ok(Ok(Worked::Read(reading))) => {
                        match measured(r, step, &reading, planned, &goal) {
                            Ok(to_goal) => *last = Some(to_goal),
                            Err(e) => {
                                cancel.cancel();
                                break Err(e.into());
                            }
                        }
                    }
                    Ok(Err(e)) => break Err(e.into()),
                    Err(RecvTimeoutError::Timeout) => {}
                    Err(RecvTimeoutError::Disconnected) => {
                        break Err(internal(step, "the closed loop's decision failed"))
                    }
                }
                if let Err(e) = fired(r, phase.load(Ordering::SeqCst)) {
                    // off first, then abandon what the worker does
                    let _ = r.all_off();
                    cancel.cancel();
                    break Err(e.into());
                }
            };
            if worker.join().is_err() && outcome.is_ok() {
                return Err(internal(step, "the closed loop's decision failed"));
            }
            outcome
        })
    }
}

impl Plant for Hardware<'_, '_, '_> {
    type Error = RigError;

    /// Switches the next entry of the plan in force, verifies (`--verify`), dwells, reads the
    /// sensor and decides (watched, see the module comment).
    fn step(
        &mut self,
        _step: usize,
        row: &PlanRow,
        decide: &mut Decide<'_>,
    ) -> Result<(Orientation, Decision), RigError> {
        let Some(e) = self.entries.get(self.index).cloned() else {
            return Err(RigError::Stuck {
                step: self.steps,
                message: "the plan in force has no step left".into(),
            });
        };
        self.steps = e.step;
        let senses = &mut self.senses;
        // switch, verify, dwell (always realtime: `refuse_options`), then read and decide
        let (q, decision) = self.r.play(&e, |r| {
            let decided = senses.sense_and_decide(r, e.step, &row.q, decide)?;
            r.check_stop()?;
            Ok::<_, RigError>(decided)
        })?;
        if decision == Decision::Continue {
            self.index += 1;
        }
        self.current = Some(e);
        Ok((q, decision))
    }

    /// The controller replanned after the entry switched last: checks the new plan from what
    /// is on now and makes it the plan in force, or refuses it (nothing of it switched).
    fn replanned(&mut self, step: usize, ctl: &Controller) -> Result<(), RigError> {
        let e = (self.current.clone())
            .ok_or_else(|| internal(step, "a replan before any step was switched"))?;
        let r = &mut *self.r;
        let replan = ctl.replans();
        let mut rows: Vec<PlanRow> = ctl.plan().get(1..).unwrap_or_default().to_vec();
        for (j, row) in rows.iter_mut().enumerate() {
            row.step = e.step + 1 + j;
        }
        let refused = |cause| RigError::ReplanRefused {
            step: e.step,
            replan,
            cause: Box::new(cause),
        };
        let prep = self.prep;
        let from = Resume {
            on: e.on_after.clone(),
            hold_first: false,
        };
        let dwell = prep.drive.dwell_ms.map(Duration::from_millis);
        let stator = self.stator_coils;
        let entries = entries_from(&rows, &prep.settings, &prep.boards, stator, dwell, from)
            .map_err(refused)?;
        let now = r.now();
        let on = r.on_times(now);
        check_on_time(&entries, prep.settings.max_on_time, prep.listed(), on).map_err(refused)?;
        let t = format!("{:.3}", now.as_secs_f64());
        let fitted = ctl
            .fitted()
            .map(|(name, _)| format!("; steering with the fitted {name}"))
            .unwrap_or_default();
        r.say(&format!(
            "{t:>9} {:>5} replan   {} new step(s) from the measurement, checked (replan \
             {replan}{fitted})",
            e.step,
            entries.len()
        ))?;
        r.mark(e.step, "replan")?;
        self.entries = entries;
        self.index = 0;
        Ok(())
    }
}

/// The worker of a watched phase: reads `sensor`, sends the reading, decides and sends the
/// decision (or sends the sensor's error).
fn read_and_decide(
    sensor: &mut dyn OrientationSensor,
    decide: &mut Decide<'_>,
    phase: &AtomicU8,
    tx: mpsc::Sender<Result<Worked, crate::sensor::SensorError>>,
) {
    // the receiver is gone only when the watch gave up on this phase
    match sensor.read() {
        Ok(reading) => {
            phase.store(DECIDING, Ordering::SeqCst);
            let q = reading.orientation;
            let _ = tx.send(Ok(Worked::Read(reading)));
            let _ = tx.send(Ok(Worked::Decided(q, decide(&q))));
        }
        Err(e) => {
            let _ = tx.send(Err(e));
        }
    }
}

/// What the watch of a phase acts on now: a signal, or a coil at its guard (its on-time limit
/// less [`guard_margin`](crate::planning::on_time::guard_margin)).
fn fired(r: &Runner, phase: u8) -> Result<(), RelayError> {
    r.check_stop()?;
    r.check_on_time(|| phase_name(phase).to_string())
}

/// The replay's first line: the sensor and how the loop decides.
fn header(s: &LoopSettings, sensor: &str) -> String {
    match s.replan {
        true => format!(
            "closed loop: {sensor}; replan beyond {:.2} deg from the plan, done within {:.2} deg of the goal, at most {} steps",
            s.replan_beyond.0.to_degrees(),
            s.goal_tolerance.0.to_degrees(),
            s.max_steps
        ),
        false => format!(
            "measured open loop: {sensor}; the plan played as it is (no replanning), read after every step"
        ),
    }
}

/// How the loop ended: the steps switched, the last reading's angle from the goal, the
/// replans, and whether it replanned at all.
struct LoopEnd {
    steps: usize,
    last: Option<f64>,
    replans: usize,
    replan: bool,
}

/// Switches everything off and reports: the summary at the goal (or, not replanning, at the
/// plan's end), else why it stopped.
fn finish(
    r: &mut Runner,
    result: Result<(), RigError>,
    ending: LoopEnd,
) -> Result<ClosedSummary, RigError> {
    let LoopEnd {
        steps,
        last,
        replans,
        replan,
    } = ending;
    let (off, written) = r.close_off();
    let result = result.map_err(|e| match e {
        RigError::Relay(e) => RigError::Relay(r.with_off_time(e)),
        e => e,
    });
    if let Some(off) = off {
        return Err(match result {
            Ok(()) => RigError::Relay(off),
            Err(RigError::Relay(cause)) => RigError::Relay(off.after(Some(cause))),
            Err(cause) => RigError::OffFailed {
                cause: Box::new(cause),
                off: Box::new(off),
            },
        });
    }
    match result {
        Ok(()) => {
            written?;
            let d = last.unwrap_or(f64::NAN);
            r.say(&match replan {
                true => format!(
                    "closed loop done: at the goal after {steps} step(s), {replans} replan(s); the last measurement {d:.2} deg from the goal; all coils off"
                ),
                false => format!(
                    "measured open loop done: {steps} step(s) played and read; the last measurement {d:.2} deg from the plan's last orientation; all coils off"
                ),
            })?;
            Ok(ClosedSummary {
                steps,
                replans,
                distance_deg: d,
            })
        }
        Err(cause) => Err(RigError::LoopStopped {
            cause: Box::new(cause),
            steps,
            replans,
            distance_deg: last,
        }),
    }
}

/// Prints and logs a reading taken after `step`, with its angles from the plan's
/// prediction (`planned`) and from the goal.
fn measured(
    r: &mut Runner,
    step: usize,
    reading: &Reading,
    planned: &Orientation,
    goal: &Orientation,
) -> Result<f64, RelayError> {
    let q = reading.orientation;
    let from_plan = q.angle_to(planned).to_degrees();
    let to_goal = q.angle_to(goal).to_degrees();
    let t = format!("{:.3}", r.now().as_secs_f64());
    let raw = reading.raw.to_string();
    r.say(&format!(
        "{t:>9} {step:>5} sensor   [{:.4}, {:.4}, {:.4}, {:.4}] {from_plan:.2} deg from the plan, {to_goal:.2} deg from the goal  \"{}\"",
        q.w,
        q.i,
        q.j,
        q.k,
        raw.escape_debug()
    ))?;
    let q = [q.w, q.i, q.j, q.k];
    r.log_measurement(&t, step, "sensor", q, Some(to_goal), &raw)?;
    Ok(to_goal)
}

/// Logs the tare: a `tare` row at step 0 with the offset `w` of the sensor's reference in
/// the quaternion's columns and the tare reading as the sensor sent it.
fn log_tare(r: &mut Runner, w: &Orientation, tare: &Reading) -> Result<(), RelayError> {
    let t = format!("{:.3}", r.now().as_secs_f64());
    let q = [w.w, w.i, w.j, w.k];
    r.log_measurement(&t, 0, "tare", q, None, &tare.raw.to_string())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn closed_refuses_dry_run_step_mode_and_from_step() {
        let drive = Drive {
            board: None,
            baud: None,
            ports: Vec::new(),
            mode: Mode::Realtime,
            dwell_ms: None,
            from_step: 0,
            log: None,
            verify: false,
        };
        assert!(refuse_options(&drive, false).is_ok());
        let e = refuse_options(&drive, true).unwrap_err().to_string();
        assert!(
            e.starts_with("replay setting `dry_run`: expected none with a sensor"),
            "{e}"
        );
        let step = Drive {
            mode: Mode::Step,
            ..drive.clone()
        };
        let e = refuse_options(&step, false).unwrap_err().to_string();
        assert!(e.contains("`mode`") && e.contains("on-time"), "{e}");
        let from = Drive {
            from_step: 2,
            ..drive
        };
        let e = refuse_options(&from, false).unwrap_err().to_string();
        assert!(e.contains("`from_step`: expected 0 with a sensor"), "{e}");
    }
}
