//! How the fields of a `[relay]` section (or a `--map` file) are checked and named in errors:
//! the file and the prefix (`relay.` in a scenario, none in a map file), integers in a range,
//! durations within their bounds, coil keys. Shared by the single-board settings
//! (`config`) and the board list (`boards`).

use crate::model::geometry::CoilId;
use crate::text::shown;
use std::path::{Path, PathBuf};
use std::time::Duration;

/// A `[relay]` section (or a `--map` file) that cannot be used: the relay layer's own error
/// for its settings, which the crate's `Error` gathers as its `Field` and `Parse` (the same
/// messages).
#[derive(Debug, thiserror::Error)]
pub enum ConfigError {
    /// A field holds a value that is not allowed.
    #[error("{file}: field `{field}`: expected {expected}")]
    Field {
        /// The scenario or map file.
        file: PathBuf,
        /// The field, as the file names it (`relay.max_coils_on`, or `max_coils_on` in a map
        /// file).
        field: String,
        /// What the field may hold.
        expected: String,
    },
    /// A map file could not be parsed at all (syntax, unknown key, wrong type).
    #[error("{file}: {message}")]
    Parse {
        /// The map file.
        file: PathBuf,
        /// The parser's message.
        message: String,
    },
}

/// Result with the relay settings' error.
pub type Result<T> = std::result::Result<T, ConfigError>;

/// How the fields of a `[relay]` section are named in errors: the file and the prefix.
pub(super) struct Fields<'a> {
    pub(super) file: &'a Path,
    pub(super) prefix: &'a str,
}

impl Fields<'_> {
    pub(super) fn err(&self, field: &str, expected: String) -> ConfigError {
        ConfigError::Field {
            file: self.file.to_path_buf(),
            field: format!("{}{field}", self.prefix),
            expected,
        }
    }

    /// An optional integer in `lo..=hi`.
    pub(super) fn int(&self, field: &str, v: Option<i64>, lo: i64, hi: i64) -> Result<Option<i64>> {
        match v {
            Some(x) if x < lo || x > hi => {
                Err(self.err(field, format!("an integer in {lo}..={hi}, got {x}")))
            }
            v => Ok(v),
        }
    }

    /// A duration in seconds: above 0 and at most `max` (`default` when unset).
    pub(super) fn seconds(
        &self,
        field: &str,
        v: Option<f64>,
        default: f64,
        max: f64,
    ) -> Result<Duration> {
        match v {
            None => Ok(Duration::from_secs_f64(default)),
            Some(x) if x.is_finite() && x > 0.0 && x <= max => Ok(Duration::from_secs_f64(x)),
            Some(x) => Err(self.err(
                field,
                format!("a number of seconds > 0 and <= {max}, got {}", shown(x)),
            )),
        }
    }

    /// A duration in milliseconds: above 0 (or at least 0 with `zero_ok`) and at most `max`.
    pub(super) fn millis(
        &self,
        field: &str,
        v: Option<f64>,
        default: f64,
        zero_ok: bool,
        max: f64,
    ) -> Result<Duration> {
        let x = v.unwrap_or(default);
        let low_ok = x > 0.0 || (zero_ok && x == 0.0);
        if x.is_finite() && low_ok && x <= max {
            return Ok(Duration::from_secs_f64(x / 1000.0));
        }
        let low = if zero_ok { ">= 0" } else { "> 0" };
        Err(self.err(
            field,
            format!(
                "a number of milliseconds {low} and <= {max}, got {}",
                shown(x)
            ),
        ))
    }

    /// An optional finite number > 0, `default` when absent.
    pub(super) fn positive(&self, field: &str, v: Option<f64>, default: f64) -> Result<f64> {
        match v {
            None => Ok(default),
            Some(x) if x.is_finite() && x > 0.0 => Ok(x),
            Some(x) => Err(self.err(field, format!("a finite number > 0, got {}", shown(x)))),
        }
    }
}

/// A `[relay.map]` key: the coil index.
pub(super) fn coil_key(f: &Fields, field: &str, k: &str) -> Result<CoilId> {
    k.trim().parse::<usize>().map(CoilId).map_err(|_| {
        f.err(
            field,
            format!("a coil index (0, 1, ...) as the key, got '{k}'"),
        )
    })
}
