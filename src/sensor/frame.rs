//! The sensor's frames: where it sits in the ball (the mounting) and where its reference is
//! (the tare).
//!
//! A sensor reports its own orientation `s`, from its own body frame to its own reference
//! frame. With the ball's orientation `q` (body to world, docs/model.md), the mounting `M` (the
//! sensor's frame in the ball's body frame: sensor to body) and `W` (world to the sensor's
//! reference, unknown: a BNO055 in IMU mode starts its heading anywhere), the three compose
//! as `s = W * q * M` (Hamilton products, the rightmost applied first: sensor -> body -> world
//! -> reference).
//!
//! The tare: with the ball at rest at a known orientation `q0` (the plan's start), one reading
//! `s0` gives `W = s0 * M^-1 * q0^-1`; every later reading maps back to the ball as
//! `q = W^-1 * s * M^-1`. [`Tared`] wraps any [`OrientationSensor`] so that its readings are
//! the ball's orientation (the raw bytes kept as they came).

use super::{Cancel, OrientationSensor, Reading, SensorError};
use crate::model::geometry::{rotation_angle, Orientation};

/// A tare offset smaller than this (radians) is none: it is the rounding of a reading that is
/// the start itself (a sensor already in the ball's frame, its line printed and parsed back),
/// eight orders of magnitude below any sensor's resolution; such a sensor's readings then pass
/// through bit for bit.
pub const NO_OFFSET: f64 = 1e-12;

/// The mounting and the reference of a sensor, once tared.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Frame {
    /// `M`: the sensor's frame in the ball's body frame (sensor to body).
    pub mount: Orientation,
    /// `W`: world to the sensor's reference frame (the tare's offset).
    pub reference: Orientation,
}

impl Frame {
    /// The frame of a sensor mounted `mount` that reads `reading` while the ball is at rest at
    /// `start`: `W = s0 * M^-1 * q0^-1` (normalised).
    /// An offset under [`NO_OFFSET`] is taken as none (the identity).
    pub fn tare(mount: Orientation, start: &Orientation, reading: &Orientation) -> Frame {
        let w = reading.quaternion() * mount.inverse().quaternion() * start.inverse().quaternion();
        let w = Orientation::new_normalize(w);
        let reference = if rotation_angle(&w).0 < NO_OFFSET {
            Orientation::identity()
        } else {
            w
        };
        Frame { mount, reference }
    }

    /// The ball's orientation from a reading: `q = W^-1 * s * M^-1`.
    pub fn ball(&self, reading: &Orientation) -> Orientation {
        self.reference.inverse() * reading * self.mount.inverse()
    }

    /// What the sensor reads when the ball is at `ball`: `s = W * q * M` (for emulated
    /// sensors and the tests).
    pub fn sensor(&self, ball: &Orientation) -> Orientation {
        self.reference * ball * self.mount
    }
}

/// A rotation as words: `12.34 deg about [0.0000, 0.0000, 1.0000]` (`0.00 deg` for none).
pub fn axis_angle_text(q: &Orientation) -> String {
    let angle = rotation_angle(q).0.to_degrees();
    match q.axis() {
        // nalgebra's axis is that of the rotation within [0, 180] degrees (w >= 0)
        Some(a) if angle > 0.0 => {
            format!("{angle:.2} deg about [{:.4}, {:.4}, {:.4}]", a.x, a.y, a.z)
        }
        _ => format!("{angle:.2} deg"),
    }
}

/// A sensor whose readings are mapped to the ball's orientation through a tared [`Frame`].
pub struct Tared {
    inner: Box<dyn OrientationSensor>,
    frame: Frame,
}

impl Tared {
    /// Takes the tare reading of `inner` (mounted `mount`, the ball at rest at `start`) and
    /// wraps it: the tare reading itself (as the sensor sent it) and the tared sensor.
    ///
    /// # Errors
    ///
    /// The reading's error, as the driver gives it.
    pub fn tare(
        mut inner: Box<dyn OrientationSensor>,
        mount: Orientation,
        start: &Orientation,
    ) -> Result<(Tared, Reading), SensorError> {
        let reading = inner.read()?;
        let frame = Frame::tare(mount, start, &reading.orientation);
        Ok((Tared { inner, frame }, reading))
    }

    /// Wraps `inner` with a frame known already.
    pub fn with_frame(inner: Box<dyn OrientationSensor>, frame: Frame) -> Tared {
        Tared { inner, frame }
    }

    /// The mounting and reference offset its readings are mapped through.
    pub fn frame(&self) -> Frame {
        self.frame
    }
}

impl OrientationSensor for Tared {
    /// The inner sensor's reading mapped to the ball (`W^-1 * s * M^-1`), its raw bytes kept.
    fn read(&mut self) -> Result<Reading, SensorError> {
        let r = self.inner.read()?;
        Ok(Reading {
            orientation: self.frame.ball(&r.orientation),
            raw: r.raw,
        })
    }

    fn describe(&self) -> String {
        self.inner.describe()
    }

    fn ready(&mut self) -> Result<Option<super::bno055::Calibration>, SensorError> {
        self.inner.ready()
    }

    fn set_cancel(&mut self, cancel: Cancel) {
        self.inner.set_cancel(cancel);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sensor::Raw;
    use nalgebra::{Unit, Vector3};

    /// The angle between two orientations, radians (the crate's `rotation_angle`).
    fn ang(a: &Orientation, b: &Orientation) -> f64 {
        rotation_angle(&(a.inverse() * b)).0
    }

    fn rot(axis: [f64; 3], deg: f64) -> Orientation {
        let a = Unit::new_normalize(Vector3::new(axis[0], axis[1], axis[2]));
        Orientation::from_axis_angle(&a, deg.to_radians())
    }

    /// A sensor that reports `W * q * M` of a list of ball orientations, in turn.
    struct Scripted {
        frame: Frame,
        balls: Vec<Orientation>,
        k: usize,
    }

    impl OrientationSensor for Scripted {
        fn read(&mut self) -> Result<Reading, SensorError> {
            let q = self.balls[self.k];
            self.k += 1;
            Ok(Reading {
                orientation: self.frame.sensor(&q),
                raw: Raw::Line(format!("reading {}", self.k)),
            })
        }
        fn describe(&self) -> String {
            "scripted".into()
        }
        fn set_cancel(&mut self, _: Cancel) {}
    }

    fn truth() -> Frame {
        Frame {
            mount: rot([1.0, 2.0, -0.5], 37.0),
            reference: rot([-0.3, 0.2, 1.0], 143.0),
        }
    }

    #[test]
    fn frame_tare_recovers_the_ball_in_a_rotated_frame() {
        let t = truth();
        let q0 = rot([0.0, 1.0, 1.0], 25.0);
        let f = Frame::tare(t.mount, &q0, &t.sensor(&q0));
        assert!(ang(&f.reference, &t.reference) < 1e-12);
        for (axis, deg) in [([1.0, 0.0, 0.0], 90.0), ([0.3, -1.0, 0.2], 171.0)] {
            let q = rot(axis, deg) * q0;
            let back = f.ball(&t.sensor(&q));
            assert!(ang(&back, &q) < 1e-12, "{}", ang(&back, &q));
        }
    }

    #[test]
    fn frame_composition_order_matters_and_is_the_documented_one() {
        // the other orders do not recover the ball: the test would see a swap
        let t = truth();
        let q0 = rot([0.0, 1.0, 1.0], 25.0);
        let q = rot([0.3, -1.0, 0.2], 71.0) * q0;
        let s0 = t.reference * q0 * t.mount;
        let s = t.reference * q * t.mount;
        // W = s0 M^-1 q0^-1, q = W^-1 s M^-1
        let w = s0 * t.mount.inverse() * q0.inverse();
        assert!(ang(&(w.inverse() * s * t.mount.inverse()), &q) < 1e-12);
        // mounting on the world side, reference on the body side: wrong
        let w_swapped = q0.inverse() * t.mount.inverse() * s0;
        let wrong = t.mount.inverse() * s * w_swapped.inverse();
        assert!(ang(&wrong, &q) > 0.1, "{}", ang(&wrong, &q));
        // a mounting applied as M^-1 on the left is not the same either
        let f = Frame::tare(t.mount.inverse(), &q0, &s0);
        assert!(ang(&f.ball(&s), &q) > 0.1);
        // the model's convention: q maps body to world, so the sensor's x axis in the world
        // is q * (M * x)
        let x = Vector3::x();
        let in_world = q * (t.mount * x);
        let via_sensor = t.reference.inverse() * (s * x);
        assert!((in_world - via_sensor).norm() < 1e-12);
    }

    #[test]
    fn frame_identity_passes_readings_through_bit_for_bit() {
        let q0 = rot([0.2, 0.1, 1.0], 33.0);
        let f = Frame::tare(Orientation::identity(), &q0, &q0);
        assert_eq!(f.reference, Orientation::identity());
        let s = rot([1.0, -2.0, 0.5], 80.0);
        assert_eq!(f.ball(&s), s);
    }

    #[test]
    fn frame_offset_of_rounding_is_none() {
        let q0 = rot([0.2, 0.1, 1.0], 33.0);
        let tiny = rot([1.0, 0.0, 0.0], 1e-14f64.to_degrees()) * q0;
        let f = Frame::tare(Orientation::identity(), &q0, &tiny);
        assert_eq!(f.reference, Orientation::identity());
        let small = rot([1.0, 0.0, 0.0], 1e-9f64.to_degrees()) * q0;
        let f = Frame::tare(Orientation::identity(), &q0, &small);
        assert!((ang(&f.reference, &Orientation::identity()) - 1e-9).abs() < 1e-15);
    }

    #[test]
    fn frame_tared_sensor_maps_its_readings_and_keeps_the_raw_bytes() {
        let t = truth();
        let q0 = rot([1.0, 1.0, 0.0], 10.0);
        let q1 = rot([0.0, 0.0, 1.0], 45.0) * q0;
        let inner = Scripted {
            frame: t,
            balls: vec![q0, q1],
            k: 0,
        };
        let (mut tared, first) = Tared::tare(Box::new(inner), t.mount, &q0).unwrap();
        assert_eq!(first.raw, Raw::Line("reading 1".into()));
        assert!(ang(&tared.frame().reference, &t.reference) < 1e-12);
        let r = tared.read().unwrap();
        assert!(ang(&r.orientation, &q1) < 1e-12);
        assert_eq!(r.raw, Raw::Line("reading 2".into()));
        assert_eq!(tared.describe(), "scripted");
    }

    #[test]
    fn frame_axis_angle_text() {
        assert_eq!(axis_angle_text(&Orientation::identity()), "0.00 deg");
        assert_eq!(
            axis_angle_text(&rot([0.0, 0.0, -1.0], 30.0)),
            "30.00 deg about [0.0000, 0.0000, -1.0000]"
        );
        let minus = Orientation::new_unchecked(-*rot([0.0, 1.0, 0.0], 30.0).quaternion());
        assert_eq!(
            axis_angle_text(&minus),
            "30.00 deg about [0.0000, 1.0000, 0.0000]"
        );
    }
}
