//! How a front end asks to play a plan on a plant (the command line's `run` and `simulate
//! --closed-loop` options, Python's `Motor.run` arguments), checked and turned into the loop's
//! settings in one place for every front end: a refusal names the option as the front end
//! calls it ([`LoopNames`]).

use crate::error::{Error, Result};
use crate::model::geometry::Radians;
use crate::planning::closed_loop::LoopSettings;
use crate::text::shown;

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
    pub noise_deg: &'static str,
    pub max_steps: &'static str,
}

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
    /// [0, [`MAX_SENSOR_NOISE_DEG`]] degrees, at least one step; a refusal is [`Error::Arg`]
    /// naming the option by `names`.
    pub fn check(&self, names: &LoopNames) -> Result<()> {
        if !(self.noise_deg.is_finite() && (0.0..=MAX_SENSOR_NOISE_DEG).contains(&self.noise_deg)) {
            return Err(Error::Arg {
                arg: names.noise_deg.into(),
                expected: format!(
                    "a noise in [0, {MAX_SENSOR_NOISE_DEG}] degrees (the goal tolerance is twice \
                     it), got {}",
                    shown(self.noise_deg)
                ),
            });
        }
        if self.max_steps == Some(0) {
            return Err(Error::Arg {
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
