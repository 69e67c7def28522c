//! Parsers of the command line's argument strings: an axis `x,y,z` and an orientation
//! `qx,qy,qz,qw`, each error naming the argument (`arg`) and what was expected. (Scenario and
//! plan files are read by `io`; these are for what is typed.) And the wording of the library's
//! errors about a parameter ([`Error::Input`]) as the flag that gives it ([`as_flag`]).

use crate::error::{Error, Input, Result};
use crate::io::output::check_not_input;
use crate::model::geometry::{orientation_from_xyzw, unit, Orientation, UnitVec};
use nalgebra::Vector3;
use std::path::Path;

/// A library error about the parameter `input` worded as the command line's argument `flag`
/// (an [`Error::Arg`], as the command line words every argument); any other error as it is.
pub fn as_flag(e: Error, input: Input, flag: &str) -> Error {
    match e {
        Error::Input { input: i, expected } if i == input => Error::Arg {
            arg: flag.into(),
            expected,
        },
        e => e,
    }
}

/// [`check_not_input`] for an output given as `--out` (or written into its folder).
pub fn check_out<P: AsRef<Path>>(out: &Path, inputs: &[P]) -> Result<()> {
    check_not_input(out, inputs).map_err(|e| as_flag(e, Input::Output, "--out"))
}

/// Parses `x,y,z` into a unit vector (normalised; zero and NaN refused).
pub fn parse_axis(text: &str, arg: &str) -> Result<UnitVec> {
    let v = parse_numbers::<3>(text, arg, "x,y,z")?;
    unit(Vector3::new(v[0], v[1], v[2])).ok_or_else(|| Error::Arg {
        arg: arg.into(),
        expected: format!("a non-zero, finite vector x,y,z, got '{text}'"),
    })
}

/// Parses `qx,qy,qz,qw` into an orientation (normalised; zero and NaN refused).
pub fn parse_orientation(text: &str, arg: &str) -> Result<Orientation> {
    let v = parse_numbers::<4>(text, arg, "qx,qy,qz,qw")?;
    orientation_from_xyzw(v[0], v[1], v[2], v[3]).ok_or_else(|| Error::Arg {
        arg: arg.into(),
        expected: format!("a non-zero, finite quaternion qx,qy,qz,qw, got '{text}'"),
    })
}

/// A sensor's mounting `qx,qy,qz,qw` (given as `arg`): a unit quaternion, as `[sensor] mount`
/// requires it.
pub fn parse_mount(text: &str, arg: &str) -> Result<Orientation> {
    let v = parse_numbers::<4>(text, arg, "qx,qy,qz,qw")?;
    crate::io::sensor_section::quaternion(&v).map_err(|expected| Error::Arg {
        arg: arg.into(),
        expected,
    })
}

fn parse_numbers<const N: usize>(text: &str, arg: &str, form: &str) -> Result<[f64; N]> {
    let parts: Vec<&str> = text.split(',').map(str::trim).collect();
    let bad = || Error::Arg {
        arg: arg.into(),
        expected: format!("{N} numbers {form}, got '{text}'"),
    };
    if parts.len() != N {
        return Err(bad());
    }
    let mut out = [0.0; N];
    for (o, p) in out.iter_mut().zip(&parts) {
        *o = p.parse::<f64>().map_err(|_| bad())?;
    }
    Ok(out)
}
