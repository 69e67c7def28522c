//! How a front end asks to play a plan on a plant (the command line's `run` and `simulate
//! --closed-loop` options, Python's `Motor.run` and `Motor.simulate` arguments), checked and
//! turned into the loop's settings in one place for every front end: the loop's options
//! ([`LoopOptions`]), and the plan the loop plays with its goal ([`LoopPlan`]: a plan just made,
//! or a plan's rows aimed at their own target). A refusal names the option as the front end
//! calls it ([`LoopNames`]), or where the rows came from ([`RowsFrom`]).

use crate::model::geometry::{Orientation, Radians};
use crate::planning::closed_loop::{target_of, LoopSettings, LoopSummary};
use crate::planning::plan::{goal_of, Plan, PlanRow, PlanSettings};
use crate::text::shown;
use serde::Serialize;
use std::path::{Path, PathBuf};

/// A front end's option, or a plan's rows, that the loop cannot play: the crate's `Error`
/// gathers it as its `Arg` and `Parse` (the same messages).
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum OptionError {
    /// An option (as the front end names it) holds a value that is not allowed.
    #[error("argument {arg}: expected {expected}")]
    Arg {
        /// The option, as the front end calls it.
        arg: String,
        /// What the option may be.
        expected: String,
    },
    /// A plan file whose rows the loop cannot play.
    #[error("{file}: {message}")]
    Parse {
        /// The plan file.
        file: PathBuf,
        /// What is wrong with it.
        message: String,
    },
}

/// Result with the options' error.
pub type Result<T> = std::result::Result<T, OptionError>;

/// How to play a plan on the plant.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LoopOptions {
    /// Replan from the measurements (the closed loop), or play the plan as it is.
    pub closed: bool,
    /// The sensor's noise, degrees.
    pub noise_deg: f64,
    /// The noise's seed.
    pub seed: u64,
    /// At most this many steps (default [`default_max_steps`] of the open-loop plan's).
    pub max_steps: Option<usize>,
    /// Fit the wells to the measurements and steer with the fit where the model is wrong.
    pub identify: bool,
}

/// What a front end calls the options that can be refused (`--sensor-noise-deg` on the command
/// line, `sensor_noise_deg` in Python).
#[derive(Debug, Clone, Copy)]
pub struct LoopNames {
    /// The sensor noise option's name (`--sensor-noise-deg`, `sensor_noise_deg`).
    pub noise_deg: &'static str,
    /// The most-steps option's name (`--max-steps`, `max_steps`).
    pub max_steps: &'static str,
    /// The motion asked for (`--axis/--angle` on the command line), refused when the model
    /// cannot plan it ([`LoopPlan::planned`]).
    pub motion: &'static str,
}

/// Where a plan's rows came from, for a refusal of them: a plan file (the refusal names the
/// file, and the line), or a front end's argument (named with the step).
#[derive(Debug, Clone, Copy)]
pub enum RowsFrom<'a> {
    /// A plan file.
    File(&'a Path),
    /// A front end's argument, by the name it goes by.
    Argument(&'a str),
}

/// The sensor noise's seed when none is given (the command line's `--seed` default, Python's
/// `seed=None`).
pub const DEFAULT_SEED: u64 = 1;

/// The largest sensor noise accepted, degrees. The loop's thresholds grow with the noise
/// (replan beyond three times it, done within twice it): at 10 degrees of noise a run counts as
/// reached within 20 degrees of the goal, and a noisier sensor cannot tell a step from the
/// noise (the prototype's steps turn 10 to 30 degrees), so it is refused rather than reported
/// as reached.
pub const MAX_SENSOR_NOISE_DEG: f64 = 10.0;

/// The closed loop's step budget when none is given: three times the plan's steps plus six. It
/// must not hang on the plan's length alone: a plan made in a wrong model may be much shorter
/// than the plant needs, and a fit of the wells takes a step or two.
pub fn default_max_steps(planned_steps: usize) -> usize {
    3 * planned_steps + 6
}

impl LoopOptions {
    /// Checks the options before anything is computed: the noise within
    /// [0, [`MAX_SENSOR_NOISE_DEG`]] degrees, at least one step; a refusal is [`OptionError::Arg`]
    /// naming the option by `names`.
    pub fn check(&self, names: &LoopNames) -> Result<()> {
        if !(self.noise_deg.is_finite() && (0.0..=MAX_SENSOR_NOISE_DEG).contains(&self.noise_deg)) {
            return Err(OptionError::Arg {
                arg: names.noise_deg.into(),
                expected: format!(
                    "a noise in [0, {MAX_SENSOR_NOISE_DEG}] degrees (the goal tolerance is twice \
                     it), got {}",
                    shown(self.noise_deg)
                ),
            });
        }
        if self.max_steps == Some(0) {
            return Err(OptionError::Arg {
                arg: names.max_steps.into(),
                expected: "a whole number >= 1, got 0".into(),
            });
        }
        Ok(())
    }

    /// The loop's settings, checked ([`LoopOptions::check`]), for a plan of `planned_steps`.
    pub fn settings(&self, planned_steps: usize, names: &LoopNames) -> Result<LoopSettings> {
        self.check(names)?;
        let noise = Radians(self.noise_deg.to_radians());
        Ok(if self.closed {
            let max = self.max_steps.unwrap_or(default_max_steps(planned_steps));
            LoopSettings {
                identify: self.identify,
                ..LoopSettings::for_noise(noise, self.seed, max)
            }
        } else {
            LoopSettings::open(noise, self.seed)
        })
    }
}

/// What a run of the loop on a plant reports (`run` and `simulate --closed-loop`, `--json`;
/// Python's `Run.summary`): how it was played, then the loop's summary. The keys are the
/// fields, in this order.
#[derive(Debug, Clone, Serialize)]
pub struct RunSummary {
    /// "closed" or "open".
    pub mode: &'static str,
    /// The sensor's noise (its standard deviation), degrees.
    pub sensor_noise_deg: f64,
    /// The seed of the sensor's noise.
    pub seed: u64,
    /// Steps of the plan made before the motion (the open-loop plan).
    pub planned_steps: usize,
    /// The loop's summary, its keys flattened into this one.
    #[serde(flatten)]
    pub run: LoopSummary,
}

impl RunSummary {
    /// The summary of a run played closed loop (`closed`) or open, with a sensor of
    /// `sensor_noise_deg` degrees and `seed`, of a plan of `planned_steps` steps.
    pub fn new(
        closed: bool,
        sensor_noise_deg: f64,
        seed: u64,
        planned_steps: usize,
        run: LoopSummary,
    ) -> RunSummary {
        RunSummary {
            mode: if closed { "closed" } else { "open" },
            sensor_noise_deg,
            seed,
            planned_steps,
            run,
        }
    }

    /// The summary of a run played as `o` says.
    pub fn of(o: &LoopOptions, planned_steps: usize, run: LoopSummary) -> RunSummary {
        RunSummary::new(o.closed, o.noise_deg, o.seed, planned_steps, run)
    }
}

/// A plan as the loop plays it: the planning settings the loop replans with, aimed at the
/// plan's goal, the plan (the open-loop one) and the goal.
#[derive(Debug, Clone)]
pub struct LoopPlan {
    /// The planning settings the loop replans with, aimed at the plan's goal.
    pub settings: PlanSettings,
    /// The plan the loop plays (the open-loop one).
    pub plan: Plan,
    /// The goal orientation, world frame.
    pub goal: Orientation,
}

impl LoopPlan {
    /// The plan `plan` just made with `settings` (`run`), aimed at the settings' goal. A plan
    /// without a step (so without a goal: none without row 0) is refused as [`OptionError::Arg`]
    /// naming the motion by `names`.
    pub fn planned(settings: &PlanSettings, plan: Plan, names: &LoopNames) -> Result<LoopPlan> {
        let goal = match goal_of(settings, &plan.rows) {
            Some(goal) if plan.rows.len() >= 2 => goal,
            _ => {
                return Err(OptionError::Arg {
                    arg: names.motion.into(),
                    expected: format!(
                        "a motion the model can plan: {}",
                        plan.message.as_deref().unwrap_or("no step")
                    ),
                })
            }
        };
        Ok(LoopPlan {
            settings: settings.clone(),
            plan,
            goal,
        })
    }

    /// A plan's `rows` as the closed loop plays them (`simulate PLAN --closed-loop`, the
    /// closed-loop replay): `settings` (the model's and the limits) aimed at the rows' own
    /// target (the rotation from row 0 to the last row, from row 0's orientation), the rows as
    /// the open-loop plan and the last orientation the goal. Rows that do not turn the ball are
    /// refused, naming where they came from: [`OptionError::Parse`] of the file, or [`OptionError::Arg`].
    pub fn of_rows(
        settings: &PlanSettings,
        rows: Vec<PlanRow>,
        from: RowsFrom<'_>,
    ) -> Result<LoopPlan> {
        const TURNS: &str = "a plan that turns the ball (its last row is where its first is)";
        let (axis, angle) = target_of(&rows).ok_or_else(|| match from {
            RowsFrom::File(file) => OptionError::Parse {
                file: file.to_path_buf(),
                message: format!("expected {TURNS}"),
            },
            RowsFrom::Argument(name) => OptionError::Arg {
                arg: name.into(),
                expected: TURNS.into(),
            },
        })?;
        let settings = PlanSettings {
            axis,
            angle,
            start: rows[0].q,
            target: None,
            ..settings.clone()
        };
        let goal = rows[rows.len() - 1].q;
        Ok(LoopPlan {
            settings,
            plan: Plan {
                rows,
                reached: true,
                message: None,
                settles: 0,
            },
            goal,
        })
    }

    /// Steps of the plan (its rows but row 0, the initial commutation).
    pub fn planned_steps(&self) -> usize {
        self.plan.rows.len() - 1
    }
}
