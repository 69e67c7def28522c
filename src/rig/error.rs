//! The rig's errors: a closed loop on the hardware ends on a board's error (the relay layer's),
//! the sensor's, or one of its own (stuck, out of steps, a replan refused), and says how far it
//! got ([`RigError::LoopStopped`]).

use crate::relay::{RelayError, Setting, Wording};
use crate::sensor::SensorError;

/// Errors of a closed-loop replay on the hardware.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum RigError {
    /// A relay board, or the replay's runner, failed (the message says whether the coils were
    /// switched off).
    #[error(transparent)]
    Relay(#[from] RelayError),
    /// The orientation sensor failed (its message names the sensor and its port).
    #[error(transparent)]
    Sensor(#[from] SensorError),
    /// The closed loop cannot go on (the controller found no plan from the measurement, or the
    /// plan in force ran out).
    #[error("closed loop stuck after step {step}: {message}")]
    Stuck {
        /// The steps switched so far.
        step: usize,
        /// Why, in words.
        message: String,
    },
    /// The closed loop took its most steps (`max`) without reaching the goal.
    #[error("{}", self.worded(&crate::relay::Fields))]
    MaxSteps {
        /// The steps switched after the initial state.
        steps: usize,
        /// The most steps allowed (`max_steps`).
        max: usize,
        /// The last measurement's angle from the goal, degrees.
        distance_deg: f64,
    },
    /// A replanned plan failed the checks of a schedule (coils mapped, coils on at once from
    /// what is on now, on-time across the joint) before anything of it was switched.
    #[error("{}", self.worded(&crate::relay::Fields))]
    ReplanRefused {
        /// The step switched last, after which the controller replanned.
        step: usize,
        /// The replan's number (the controller's count of replans, this one included).
        replan: usize,
        /// The schedule's check that refused it.
        cause: Box<RelayError>,
    },
    /// The closed loop stopped on `cause` (not a board's) and switching all off then failed
    /// too: `off` is that failure (the relay layer's `EndOffFailed` or `BoardsOffFailed`).
    #[error("{}", self.worded(&crate::relay::Fields))]
    OffFailed {
        /// The error the loop stopped on.
        cause: Box<RigError>,
        /// The all-off's failure.
        off: Box<RelayError>,
    },
    /// The closed-loop replay stopped on an error; every coil was switched off afterwards.
    #[error("{}", self.worded(&crate::relay::Fields))]
    LoopStopped {
        /// The error the loop stopped on.
        cause: Box<RigError>,
        /// The steps switched after the initial state.
        steps: usize,
        /// The replans made.
        replans: usize,
        /// The last measurement's angle from the goal, degrees (`None` before any).
        distance_deg: Option<f64>,
    },
}

impl RigError {
    /// The message, its settings named by `w` (`Display` is `worded(&Fields)`); the errors
    /// inside are worded the same way.
    pub fn worded(&self, w: &dyn Wording) -> String {
        match self {
            RigError::Relay(e) => e.worded(w),
            RigError::MaxSteps {
                steps,
                max,
                distance_deg,
            } => format!(
                "closed loop: {steps} step(s) without reaching the goal ({} {max}); the last \
                 measurement is {distance_deg:.2} deg from it",
                w.name(Setting::MaxSteps)
            ),
            RigError::ReplanRefused {
                step,
                replan,
                cause,
            } => {
                // a replan planned within the limit with its reserve: what it kept on is over
                // only when the search took longer than that
                let hint = match **cause {
                    RelayError::OnTooLong { .. } => {
                        " (the replan counted relay.replan_reserve_ms for its own search, which \
                         took longer: raise it)"
                    }
                    _ => "",
                };
                format!(
                    "the plan replanned after step {step} (replan {replan}) is refused before \
                     switching anything of it: {}{hint}",
                    cause.worded(w)
                )
            }
            RigError::OffFailed { cause, off } => off.after_text(&cause.worded(w), w),
            RigError::LoopStopped {
                cause,
                steps,
                replans,
                distance_deg,
            } => format!(
                "{}; all coils switched off (closed loop: {steps} step(s), {replans} \
                 replan(s){})",
                cause.worded(w),
                last_distance(*distance_deg)
            ),
            e => e.to_string(),
        }
    }

    /// The error that started it all (through `LoopStopped`, `OffFailed` and the relay
    /// layer's wrappers).
    pub fn root(&self) -> &RigError {
        match self {
            RigError::LoopStopped { cause, .. } | RigError::OffFailed { cause, .. } => cause.root(),
            e => e,
        }
    }

    /// The relay layer's error at the root, if it is one (see [`RelayError::root`]).
    pub fn relay_root(&self) -> Option<&RelayError> {
        match self.root() {
            RigError::Relay(e) => Some(e.root()),
            _ => None,
        }
    }
}

/// The end of `RigError::LoopStopped`'s message: the last measurement's distance.
fn last_distance(d: Option<f64>) -> String {
    d.map(|d| format!(", the last measurement {d:.2} deg from the goal"))
        .unwrap_or_default()
}
