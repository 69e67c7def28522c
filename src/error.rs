//! The library's one error type, [`Error`], with the relay boards', the sensors' and the rig's
//! (the closed loop on the hardware) errors as variants, each gathered once. Every message
//! names where the problem is (file, field, setting or argument) and what was expected; the
//! library names a replay's settings by their fields, and the command line words them as its
//! flags ([`Error::worded`]).

use crate::physics::well_curve::StepError;
use crate::planning::fit::FitError;
use crate::planning::options::OptionError;
use crate::relay::{ConfigError, RelayError, Wording};
use crate::rig::RigError;
use crate::sensor::SensorError;
use std::path::PathBuf;

// Where they were first: how messages show numbers and text is the leaf `text`, which every
// layer's errors use (this module, which gathers the layers' errors, is above them).
pub use crate::text::{printable, printable_lines, shown};

/// Errors of the spherestep library.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum Error {
    /// A scenario file's field holds a value that is not allowed.
    #[error("{file}: field `{field}`: expected {expected}")]
    Field {
        /// The scenario file.
        file: PathBuf,
        /// The field, as the file names it (`section.key`).
        field: String,
        /// What the field may hold.
        expected: String,
    },
    /// A file could not be parsed at all (syntax, unknown key, wrong type).
    #[error("{file}: {message}")]
    Parse {
        /// The file.
        file: PathBuf,
        /// The parser's message.
        message: String,
    },
    /// A value given to a library call that it does not accept; `input` names the parameter
    /// (the command line words it as its flag: `commands::args::as_flag`).
    #[error("{input}: expected {expected}")]
    Input {
        /// The parameter.
        input: Input,
        /// What the parameter may be.
        expected: String,
    },
    /// A command-line argument is malformed.
    #[error("argument {arg}: expected {expected}")]
    Arg {
        /// The argument, as the caller names it (a flag on the command line).
        arg: String,
        /// What the argument may be.
        expected: String,
    },
    /// A row of a CSV input file is malformed.
    #[error("{file}: line {line}: {message}")]
    Row {
        /// The CSV file.
        file: PathBuf,
        /// The line in the file, from 1.
        line: usize,
        /// What is wrong with the row.
        message: String,
    },
    /// Drawing a figure failed (the backend's error, or data the figure cannot show).
    #[error("{path}: plotting failed: {message}")]
    Plot {
        /// The figure's file.
        path: PathBuf,
        /// What went wrong.
        message: String,
    },
    /// Writing CSV failed (`what` names the file or stream).
    #[error("{what}: writing CSV failed")]
    Csv {
        /// The file or stream written.
        what: String,
        /// The CSV writer's error.
        #[source]
        source: csv::Error,
    },
    /// Writing JSON failed (`what` names what was written).
    #[error("{what}: writing JSON failed")]
    Json {
        /// What was written.
        what: String,
        /// The JSON writer's error.
        #[source]
        source: serde_json::Error,
    },
    /// The worker threads could not be started.
    #[error("starting {threads} worker threads failed")]
    Threads {
        /// The number of threads asked for.
        threads: usize,
        /// Why the pool could not be built.
        #[source]
        source: rayon::ThreadPoolBuildError,
    },
    /// Reading or writing a file failed.
    /// (The cause is part of the message and not a `source`, so that printing the error chain
    /// does not say it twice.)
    #[error("{path}: {cause}")]
    Io {
        /// The file.
        path: PathBuf,
        /// The system's error.
        cause: std::io::Error,
    },
    /// A relay board, or a replay on the boards, failed (the message says whether the coils
    /// were switched off).
    #[error(transparent)]
    Relay(#[from] RelayError),
    /// An orientation sensor failed (the message names the sensor and its port).
    #[error(transparent)]
    Sensor(#[from] SensorError),
    /// A closed loop on the hardware stopped: on a board's error, the sensor's, or its own
    /// (the message says how far it got and that every coil was switched off).
    #[error(transparent)]
    Rig(#[from] RigError),
    /// The wells cannot be fitted to the data given (too few points or steps, no pull).
    #[error(transparent)]
    Fit(#[from] FitError),
    /// No excitation run can be played within the supply and the on-time limit.
    #[error(transparent)]
    Excite(#[from] crate::planning::excitation::ExciteError),
}

impl From<ConfigError> for Error {
    /// A `[relay]` section's or a map file's error, as the crate's `Field` or `Parse`.
    fn from(e: ConfigError) -> Error {
        match e {
            ConfigError::Field {
                file,
                field,
                expected,
            } => Error::Field {
                file,
                field,
                expected,
            },
            ConfigError::Parse { file, message } => Error::Parse { file, message },
        }
    }
}

impl From<OptionError> for Error {
    /// A loop option's or a plan's rows' refusal, as the crate's `Arg` or `Parse`.
    fn from(e: OptionError) -> Error {
        match e {
            OptionError::Arg { arg, expected } => Error::Arg { arg, expected },
            OptionError::Parse { file, message } => Error::Parse { file, message },
        }
    }
}

impl From<StepError> for Error {
    /// A well curve's step that is not allowed, as the crate's `Input` about `step_deg`.
    fn from(e: StepError) -> Error {
        Error::Input {
            input: Input::WellStep,
            expected: e.expected,
        }
    }
}

/// The parameter of a library call an [`Error::Input`] is about.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
#[non_exhaustive]
pub enum Input {
    /// The angle step of a well's torque curve, degrees (`step_deg`).
    WellStep,
    /// An output file, which must not be one of the files read (`out`).
    Output,
    /// The simulated orientations shown beside a plan (`sim`), which must be the plan's steps.
    Simulation,
}

impl Input {
    /// The parameter's name in the library.
    pub fn name(self) -> &'static str {
        match self {
            Input::WellStep => "step_deg",
            Input::Output => "out",
            Input::Simulation => "sim",
        }
    }
}

impl std::fmt::Display for Input {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "`{}`", self.name())
    }
}

/// Result with the library's error.
pub type Result<T> = std::result::Result<T, Error>;

impl Error {
    /// The message with a replay's settings named by `w` (the command line's flags); the
    /// same as `Display` for errors about no setting.
    pub fn worded(&self, w: &dyn Wording) -> String {
        match self {
            Error::Relay(e) => e.worded(w),
            Error::Rig(e) => e.worded(w),
            e => e.to_string(),
        }
    }

    /// A [`Error::Field`]: `file`'s `field` should hold `expected`.
    pub fn field(file: impl Into<PathBuf>, field: &str, expected: impl Into<String>) -> Self {
        Error::Field {
            file: file.into(),
            field: field.to_string(),
            expected: expected.into(),
        }
    }

    /// An [`Error::Io`]: reading or writing `path` failed with `cause`.
    pub fn io(path: impl Into<PathBuf>, cause: std::io::Error) -> Self {
        Error::Io {
            path: path.into(),
            cause,
        }
    }

    /// An [`Error::Csv`]: writing CSV to `what` failed.
    pub fn csv(what: impl std::fmt::Display, source: csv::Error) -> Self {
        Error::Csv {
            what: what.to_string(),
            source,
        }
    }

    /// An [`Error::Json`]: writing `what` as JSON failed.
    pub fn json(what: impl std::fmt::Display, source: serde_json::Error) -> Self {
        Error::Json {
            what: what.to_string(),
            source,
        }
    }
}
