//! Python bindings of spherestep (PyO3): the library's facade, [`spherestep::Scenario`] and
//! [`spherestep::Motor`], as the Python classes `spherestep.Scenario` and `spherestep.Motor`,
//! their results as numpy columns. No CSV round trips: every call is the library's own, so the
//! numbers are the command line's to the bit (`python/tests` checks it against the binary).
//!
//! Every error is a `spherestep.Error` (a `ValueError`) carrying the library's message; what
//! comes from Python (pairs, orientations, axes, shapes, NaN) is checked here, at the boundary,
//! before any computation.

mod convert;
mod fitting;
mod motor;
mod replaced;
mod results;
mod rotations;
mod table;

use pyo3::prelude::*;

pyo3::create_exception!(
    spherestep,
    Error,
    pyo3::exceptions::PyValueError,
    "An error of spherestep: a file that cannot be read, a scenario or an argument that is not \
     allowed. The message is the library's: it names the file, field or argument and what was \
     expected."
);

/// The library's error as a `spherestep.Error`, with its message.
pub(crate) fn lib_err(e: impl Into<spherestep::Error>) -> PyErr {
    Error::new_err(e.into().to_string())
}

/// An argument of a Python call that is not allowed, worded as the library words its
/// arguments: `argument NAME: expected WHAT`.
pub(crate) fn arg_err(arg: &str, expected: impl Into<String>) -> PyErr {
    lib_err(spherestep::Error::Arg {
        arg: arg.into(),
        expected: expected.into(),
    })
}

/// spherestep: spherical stepper motors (a ball rotor of magnets turned by switching the coils
/// of a stator cap) from Python, at Rust speed. Start with `Scenario.load(path)` or
/// `Scenario.prototype()`, then `scenario.motor()`.
#[pymodule(name = "_spherestep")]
mod module {
    #[pymodule_export]
    use super::fitting::fit;
    #[pymodule_export]
    use super::motor::{Motor, Scenario};
    #[pymodule_export]
    use super::results::{Plan, Run, SettleResult, SettleTable, Simulation, Wells};
    #[pymodule_export]
    use super::rotations::{angle_between, quat_from_axis_angle};
    #[pymodule_export]
    use super::Error;
}
