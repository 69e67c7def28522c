//! Two helpers for orientations as the rest of the API takes them (`[qx, qy, qz, qw]`, body
//! to world): a turn about an axis as a quaternion, and the angle between two orientations.

use crate::arg_err;
use crate::convert::{self, shown};
use pyo3::prelude::*;
use spherestep::model::geometry::{rot_q, rotation_angle, xyzw, Radians};

/// The orientation reached by turning `angle_deg` degrees about `axis` (x, y, z, any length
/// but zero; right-handed: positive turns counter-clockwise looking down the axis) from the
/// identity, as `(qx, qy, qz, qw)` with `qw >= 0` (as the results write orientations; a turn
/// of more than 180 degrees is the same orientation as the shorter turn the other way). What
/// `Motor.plan(axis, angle)` turns by, from the identity.
#[pyfunction]
pub fn quat_from_axis_angle(
    axis: &Bound<'_, PyAny>,
    angle_deg: &Bound<'_, PyAny>,
) -> PyResult<(f64, f64, f64, f64)> {
    let n = convert::axis(axis, "axis")?;
    let angle = angle_deg
        .extract::<f64>()
        .ok()
        .filter(|a| a.is_finite())
        .ok_or_else(|| {
            arg_err(
                "angle_deg",
                format!("a finite number of degrees, got {}", shown(angle_deg)),
            )
        })?;
    let [x, y, z, w] = xyzw(&rot_q(&n, Radians(angle.to_radians())));
    Ok((x, y, z, w))
}

/// The angle between two orientations `q1` and `q2` (each `[qx, qy, qz, qw]`, normalised
/// here), degrees in [0, 180]: the rotation angle of the turn from one to the other (the same
/// either way; `q` and `-q` are the same orientation). Accurate also near 0 and 180.
#[pyfunction]
pub fn angle_between(q1: &Bound<'_, PyAny>, q2: &Bound<'_, PyAny>) -> PyResult<f64> {
    let a = convert::orientation(q1, "q1")?;
    let b = convert::orientation(q2, "q2")?;
    Ok(rotation_angle(&(a.inverse() * b)).0.to_degrees())
}
