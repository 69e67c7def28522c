//! The scenario's `[sensor]` section: how the orientation sensor sits in the ball, for the
//! closed loop on the hardware (`replay --sensor`, see `crate::sensor::frame`).
//!
//! ```toml
//! [sensor]
//! mount = [0.0, 0.0, 0.7071068, 0.7071068]   # qx, qy, qz, qw: the sensor's frame in the ball's
//!                                            # body frame (sensor to body); default identity
//! # or, the same as an axis and an angle:
//! # mount_axis = [0, 0, 1]
//! # mount_angle_deg = 90
//! ```
//!
//! A quaternion must have four finite components and a norm within [`MOUNT_NORM_TOLERANCE`]
//! of 1 (it is then normalised): a zero quaternion, or four numbers that are not one (an axis
//! and an angle in degrees written as a quaternion), are refused. An axis must be finite and
//! non-zero (it is normalised), the angle finite. The two forms exclude each other. Every
//! error names the file and the field.

use crate::error::{Error, Result};
use crate::model::geometry::{orientation_from_xyzw, unit, Orientation};
use crate::text::shown;
use nalgebra::Vector3;
use serde::Deserialize;
use std::path::Path;

/// How far the norm of `mount` may be from 1 (it is normalised).
pub const MOUNT_NORM_TOLERANCE: f64 = 0.01;

/// The section as written.
#[derive(Debug, Default, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RawSensor {
    mount: Option<Vec<f64>>,
    mount_axis: Option<Vec<f64>>,
    mount_angle_deg: Option<f64>,
}

/// The section, checked.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SensorSettings {
    /// The sensor's frame in the ball's body frame (sensor to body): a reading `s` of the ball
    /// at `q` is `W * q * mount`, `W` the sensor's reference (found by the tare).
    pub mount: Orientation,
}

impl Default for SensorSettings {
    fn default() -> Self {
        SensorSettings {
            mount: Orientation::identity(),
        }
    }
}

fn numbers(v: &[f64]) -> String {
    let parts: Vec<String> = v.iter().map(|&x| shown(x)).collect();
    format!("[{}]", parts.join(", "))
}

/// Checks the `[sensor]` section of scenario `file` (absent: the defaults).
pub fn check(raw: Option<RawSensor>, file: &Path) -> Result<SensorSettings> {
    let Some(raw) = raw else {
        return Ok(SensorSettings::default());
    };
    let err = |field: &str, expected: String| Error::field(file, field, expected);
    let mount = match (raw.mount, raw.mount_axis, raw.mount_angle_deg) {
        (None, None, None) => Orientation::identity(),
        (Some(_), axis, angle) if axis.is_some() || angle.is_some() => {
            return Err(err(
                "sensor.mount",
                "either mount = [qx, qy, qz, qw] or mount_axis and mount_angle_deg, not both"
                    .into(),
            ))
        }
        (Some(q), _, _) => quaternion(&q).map_err(|m| err("sensor.mount", m))?,
        (None, Some(axis), Some(angle)) => {
            let a = match axis[..] {
                [x, y, z] => unit(Vector3::new(x, y, z)),
                _ => None,
            };
            let a = a.ok_or_else(|| {
                err(
                    "sensor.mount_axis",
                    format!("a finite, non-zero axis [x, y, z], got {}", numbers(&axis)),
                )
            })?;
            if !angle.is_finite() {
                return Err(err(
                    "sensor.mount_angle_deg",
                    format!("a finite angle in degrees, got {}", shown(angle)),
                ));
            }
            Orientation::from_axis_angle(&a, angle.to_radians())
        }
        (None, Some(_), None) => {
            return Err(err(
                "sensor.mount_angle_deg",
                "an angle in degrees with sensor.mount_axis".into(),
            ))
        }
        (None, None, Some(_)) => {
            return Err(err(
                "sensor.mount_axis",
                "an axis [x, y, z] with sensor.mount_angle_deg".into(),
            ))
        }
    };
    Ok(SensorSettings { mount })
}

/// `[qx, qy, qz, qw]` as a unit quaternion, or what was expected (a sensor's mounting, in
/// `[sensor] mount` or `virtual --mount`).
pub fn quaternion(q: &[f64]) -> std::result::Result<Orientation, String> {
    let expected = format!(
        "a unit quaternion [qx, qy, qz, qw] (finite, norm within {MOUNT_NORM_TOLERANCE} of 1; it is normalised)"
    );
    let &[x, y, z, w] = q else {
        return Err(format!("{expected}, got {} numbers", q.len()));
    };
    let norm = (x * x + y * y + z * z + w * w).sqrt();
    match orientation_from_xyzw(x, y, z, w) {
        Some(o) if (norm - 1.0).abs() <= MOUNT_NORM_TOLERANCE => Ok(o),
        Some(_) => Err(format!("{expected}, got {} of norm {norm:.6}", numbers(q))),
        None => Err(format!("{expected}, got {}", numbers(q))),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn ang(a: &Orientation, b: &Orientation) -> f64 {
        crate::model::geometry::rotation_angle(&(a.inverse() * b)).0
    }

    fn parse(text: &str) -> Result<SensorSettings> {
        let raw: RawSensor = toml::from_str(text).unwrap();
        check(Some(raw), Path::new("s.toml"))
    }

    #[test]
    fn sensor_section_reads_both_forms_and_defaults_to_identity() {
        assert_eq!(
            check(None, Path::new("s.toml")).unwrap().mount,
            Orientation::identity()
        );
        assert_eq!(parse("").unwrap().mount, Orientation::identity());
        let q = parse("mount = [0, 0, 0.7071068, 0.7071068]").unwrap().mount;
        let a = parse("mount_axis = [0, 0, 2]\nmount_angle_deg = 90")
            .unwrap()
            .mount;
        assert!(ang(&q, &a) < 1e-6, "{q} {a}");
        assert!((q.quaternion().norm() - 1.0).abs() < 1e-15);
        let z = Vector3::z_axis();
        assert!(ang(&a, &Orientation::from_axis_angle(&z, 90f64.to_radians())) < 1e-15);
    }

    #[test]
    fn sensor_section_refuses_bad_values_naming_file_and_field() {
        for (text, field, says) in [
            ("mount = [0, 0, 0, 0]", "sensor.mount", "got [0, 0, 0, 0]"),
            ("mount = [0, 0, 1, 90]", "sensor.mount", "of norm 90.005"),
            ("mount = [0, 0, 1]", "sensor.mount", "got 3 numbers"),
            (
                "mount = [0, 0, nan, 1]",
                "sensor.mount",
                "got [0, 0, NaN, 1]",
            ),
            (
                "mount = [0, 0, 0, 1]\nmount_angle_deg = 3",
                "sensor.mount",
                "not both",
            ),
            (
                "mount_axis = [0, 0, 0]\nmount_angle_deg = 3",
                "sensor.mount_axis",
                "non-zero",
            ),
            (
                "mount_axis = [0, 1]\nmount_angle_deg = 3",
                "sensor.mount_axis",
                "[0, 1]",
            ),
            (
                "mount_axis = [0, 0, 1]\nmount_angle_deg = inf",
                "sensor.mount_angle_deg",
                "finite",
            ),
            (
                "mount_axis = [0, 0, 1]",
                "sensor.mount_angle_deg",
                "with sensor.mount_axis",
            ),
            (
                "mount_angle_deg = 4",
                "sensor.mount_axis",
                "with sensor.mount_angle_deg",
            ),
        ] {
            let e = parse(text).unwrap_err().to_string();
            assert!(
                e.starts_with(&format!("s.toml: field `{field}`: expected ")),
                "{text}: {e}"
            );
            assert!(e.contains(says), "{text}: {e}");
        }
    }
}
