//! The library's one error type, [`Error`], with the relay boards' and the sensors' errors as
//! variants. Every message names where the problem is (file, field, setting or argument) and
//! what was expected; the library names a replay's settings by their fields, and the command
//! line words them as its flags ([`Error::worded`]).

use crate::relay::{RelayError, Wording};
use crate::sensor::SensorError;
use std::path::PathBuf;

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

/// A number as a message shows it: as written for ordinary magnitudes, in exponent form
/// (`1e300`) for the very large or small, so that no message spells out 300 digits.
pub fn shown(x: f64) -> String {
    let a = x.abs();
    if a != 0.0 && a.is_finite() && !(1e-4..1e15).contains(&a) {
        format!("{x:e}")
    } else {
        x.to_string()
    }
}

/// Text as a message or report shows it: control characters (NUL, terminal escapes, bells,
/// line ends) escaped as Rust does (`\0`, `\u{1b}`, `\n`), everything else as it is, so that
/// what a file or a device holds never reaches the terminal raw.
pub fn printable(text: &str) -> String {
    escaped(text, &[])
}

/// [`printable`], keeping line ends and tabs (for whole messages that may span lines).
pub fn printable_lines(text: &str) -> String {
    escaped(text, &['\n', '\t'])
}

fn escaped(text: &str, kept: &[char]) -> String {
    let mut out = String::with_capacity(text.len());
    for c in text.chars() {
        if c.is_control() && !kept.contains(&c) {
            out.extend(c.escape_debug());
        } else {
            out.push(c);
        }
    }
    out
}

#[cfg(test)]
mod shown_tests {
    #[test]
    fn printable_escapes_control_characters_only() {
        assert_eq!(
            super::printable("a\0b\u{1b}[31m'\"\\é\n"),
            "a\\0b\\u{1b}[31m'\"\\é\\n"
        );
        assert_eq!(
            super::printable_lines("x\u{7}\ny\tz\\t"),
            "x\\u{7}\ny\tz\\t"
        );
    }

    #[test]
    fn shown_keeps_ordinary_numbers_and_shortens_extreme_ones() {
        assert_eq!(super::shown(60001.0), "60001");
        assert_eq!(super::shown(0.25), "0.25");
        assert_eq!(super::shown(1e300), "1e300");
        assert_eq!(super::shown(-2e19), "-2e19");
        assert_eq!(super::shown(1e-300), "1e-300");
        assert_eq!(super::shown(f64::INFINITY), "inf");
        assert_eq!(super::shown(0.0), "0");
    }
}
