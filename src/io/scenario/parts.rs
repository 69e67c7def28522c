//! The `[magnets]` section's physical parts (shape = "dipole"), checked field by field: the
//! magnet (a point, a disc or a block; by its moment, or its remanence and size), the coil (a
//! thin loop or a winding; by its ampere-turns, or turns and current), the gap, the core's gain,
//! and the well they make.

use super::raw::*;
use super::{Checker, DEFAULT_BALL_RADIUS_M};
use crate::error::{Error, Result};
use crate::model::geometry::{Degrees, Radians};
use crate::physics::magnetics::{
    disc_volume, magnet_moment_from_remanence, DipoleParts, DipoleWell,
};
use crate::physics::real_parts::{check_winding, MagnetShape, RealParts, Winding};
use crate::physics::torque::{Interaction, Well, WellShape};

impl Checker<'_> {
    /// shape = "dipole": the parts, the well they make (attracting out to where its pull
    /// ends, unless `max_attraction_deg` says otherwise) and the interaction ("coils" unless
    /// given: every energised coil acts on every magnet).
    pub(super) fn dipole_magnets(&self, raw: &RawMagnets) -> Result<(Well, Interaction)> {
        for (k, v) in [("strength_j", raw.strength_j), ("width_deg", raw.width_deg)] {
            if v.is_some() {
                return Err(self.err(
                    &format!("magnets.{k}"),
                    "no well strength or width with shape = \"dipole\" (the parts make the well)",
                ));
            }
        }
        let real = self.real_parts(raw)?;
        let well = DipoleWell::real(real).map_err(|m| self.dipole_err(&m))?;
        let max = match raw.max_attraction_deg {
            // where the pull ends (g falls to 0): beyond, the coil repels weakly
            None => Radians(well.reach(0.0)),
            Some(d) => Degrees(d).to_radians(),
        };
        Ok((
            Well::new(WellShape::Dipole(well), max),
            raw.interaction.unwrap_or(Interaction::Coils),
        ))
    }

    /// A message of `magnetics` ("field: expected ...") as a scenario error on `magnets.field`.
    pub(super) fn dipole_err(&self, m: &str) -> Error {
        match m.split_once(": expected ") {
            Some((field, rest)) if !field.contains(' ') => {
                // the parts' ampere-turns are the scenario's coil_ampere_turns (or turns x current)
                let field = field.replace("coil_turns_amps", "coil_ampere_turns");
                self.err(&format!("magnets.{field}"), rest.to_string())
            }
            _ => self.err("magnets", m.to_string()),
        }
    }

    /// A field `magnets.{k}` that shape = "dipole" needs: a finite number > 0.
    fn dipole_required(&self, k: &str, v: Option<f64>, what: &str) -> Result<f64> {
        let field = format!("magnets.{k}");
        match v {
            None => Err(self.err(&field, format!("{what} when shape = \"dipole\""))),
            Some(x) => self.positive(&field, Some(x), 0.0),
        }
    }

    /// A product of valid values, which may still overflow (or vanish): named by what was
    /// given (`parts`).
    fn dipole_finite(&self, field: &str, what: &str, v: f64, parts: String) -> Result<f64> {
        if v.is_finite() && v > 0.0 {
            Ok(v)
        } else {
            Err(self.err(
                field,
                format!(
                    "a magnet whose {what} is a finite number > 0, got {} from {parts}",
                    crate::text::shown(v)
                ),
            ))
        }
    }

    /// The magnet's moment (A m^2): given, or from its remanence and volume (or disc size, or
    /// a block's sides).
    fn dipole_moment(&self, raw: &RawMagnets, shape: &MagnetShape) -> Result<f64> {
        let required = |k: &str, v: Option<f64>, what: &str| self.dipole_required(k, v, what);
        let finite = |field: &str, what: &str, v: f64, parts: String| {
            self.dipole_finite(field, what, v, parts)
        };
        Ok(match (raw.magnet_moment_am2, raw.remanence_t) {
            (Some(m), None) => self.positive("magnets.magnet_moment_am2", Some(m), 0.0)?,
            (None, Some(br)) => {
                let br = self.positive("magnets.remanence_t", Some(br), 0.0)?;
                let (volume, size) = match (raw.magnet_volume_m3, shape) {
                    (_, MagnetShape::Cuboid { size_m }) => (
                        finite(
                            "magnets.magnet_size_m",
                            "volume (m^3)",
                            size_m[0] * size_m[1] * size_m[2],
                            format!("magnet_size_m = {size_m:?}"),
                        )?,
                        "magnets.magnet_size_m",
                    ),
                    (Some(v), _) => (
                        self.positive("magnets.magnet_volume_m3", Some(v), 0.0)?,
                        "magnets.magnet_volume_m3",
                    ),
                    (None, _) => {
                        let d = required("magnet_diameter_m", raw.magnet_diameter_m, "a disc's diameter (m), or magnet_volume_m3,")?;
                        let t = required("magnet_thickness_m", raw.magnet_thickness_m, "a disc's thickness (m), or magnet_volume_m3,")?;
                        let v = finite(
                            "magnets.magnet_diameter_m",
                            "volume (m^3)",
                            disc_volume(d, t),
                            format!(
                                "magnet_diameter_m = {} and magnet_thickness_m = {}",
                                crate::text::shown(d),
                                crate::text::shown(t)
                            ),
                        )?;
                        (v, "magnets.magnet_diameter_m")
                    }
                };
                finite(
                    size,
                    "moment Br V / mu0 (A m^2)",
                    magnet_moment_from_remanence(br, volume),
                    format!(
                        "remanence_t = {} and a volume of {} m^3",
                        crate::text::shown(br),
                        crate::text::shown(volume)
                    ),
                )?
            }
            (Some(_), Some(_)) => {
                return Err(self.err(
                    "magnets.magnet_moment_am2",
                    "either the moment or remanence_t (with the magnet's size), not both",
                ))
            }
            (None, None) => {
                return Err(self.err(
                    "magnets.magnet_moment_am2",
                    "the magnet's moment (A m^2), or remanence_t (T) with its size, when shape = \"dipole\"",
                ))
            }
        })
    }

    /// The coil's ampere-turns (A): given, or its turns times its current.
    fn dipole_ampere_turns(&self, raw: &RawMagnets) -> Result<f64> {
        Ok(
            match (raw.coil_ampere_turns, raw.coil_turns, raw.coil_current_a) {
                (Some(ni), None, None) => ni,
                (None, Some(n), Some(i)) => {
                    let n = self.positive("magnets.coil_turns", Some(n), 0.0)?;
                    if !(i.is_finite() && i > 0.0) {
                        return Err(self.err(
                            "magnets.coil_current_a",
                            format!(
                                "a finite current > 0 (A; a well is a coil that attracts), got {}",
                                crate::text::shown(i)
                            ),
                        ));
                    }
                    let ni = n * i;
                    if !(ni.is_finite() && ni > 0.0) {
                        return Err(self.err(
                            "magnets.coil_turns",
                            format!(
                                "coil_turns x coil_current_a finite and > 0, got {} x {} A = {} A",
                                crate::text::shown(n),
                                crate::text::shown(i),
                                crate::text::shown(ni)
                            ),
                        ));
                    }
                    ni
                }
                _ => {
                    return Err(self.err(
                        "magnets.coil_ampere_turns",
                        "the coil's ampere-turns (A), or coil_turns and coil_current_a, when \
                     shape = \"dipole\"",
                    ))
                }
            },
        )
    }

    /// The thin-loop parts of shape = "dipole": the magnet by its moment, or by its remanence
    /// and volume (or disc diameter and thickness); the coil by its ampere-turns, or turns and
    /// current; the ball's radius (default the prototype's) and the core's gain (default 1).
    fn dipole_parts(
        &self,
        raw: &RawMagnets,
        shape: &MagnetShape,
        winding: Option<&Winding>,
    ) -> Result<DipoleParts> {
        let required = |k: &str, v: Option<f64>, what: &str| self.dipole_required(k, v, what);
        let moment = self.dipole_moment(raw, shape)?;
        let turns_amps = self.dipole_ampere_turns(raw)?;
        let parts =
            DipoleParts {
                ball_radius_m: self.positive(
                    "magnets.ball_radius_m",
                    raw.ball_radius_m,
                    DEFAULT_BALL_RADIUS_M,
                )?,
                magnet_moment_am2: moment,
                coil_turns_amps: turns_amps,
                coil_radius_m: match winding {
                    Some(w) => 0.5 * (w.inner_radius_m + w.outer_radius_m),
                    None => required(
                        "coil_radius_m",
                        raw.coil_radius_m,
                        "the mean radius of a coil's winding (m), or the winding's \
                         coil_inner_radius_m, coil_outer_radius_m and coil_length_m,",
                    )?,
                },
                gap_m: match raw.gap_m {
                    None => return Err(self.err(
                        "magnets.gap_m",
                        "the distance (m) from the magnets' centres (at ball_radius_m) out to a \
                         coil's loop (or its winding's face) when shape = \"dipole\"",
                    )),
                    Some(g) => self.non_negative("magnets.gap_m", Some(g), 0.0)?,
                },
                core_gain: raw.core_gain.unwrap_or(1.0),
            };
        parts.validate().map_err(|m| self.dipole_err(&m))?;
        Ok(parts)
    }

    /// The real parts: the thin-loop parts, the magnet's shape and the winding, if any (then
    /// `gap_m` is measured to its face).
    fn real_parts(&self, raw: &RawMagnets) -> Result<RealParts> {
        let shape = self.magnet_shape(raw)?;
        let winding = self.winding(raw)?;
        let parts = self.dipole_parts(raw, &shape, winding.as_ref())?;
        RealParts::new(parts, shape, winding.map(|w| (w, parts.gap_m)))
            .map_err(|m| self.dipole_err(&m))
    }

    /// `magnet_shape` (default "point") and the sizes it needs: a cylinder's diameter and
    /// thickness, a cuboid's three sides; a size the shape does not use is refused.
    fn magnet_shape(&self, raw: &RawMagnets) -> Result<MagnetShape> {
        let kind = raw.magnet_shape.unwrap_or(RawMagnetShape::Point);
        if kind != RawMagnetShape::Cuboid && raw.magnet_size_m.is_some() {
            return Err(self.err(
                "magnets.magnet_size_m",
                "no block's sides unless magnet_shape = \"cuboid\"",
            ));
        }
        let required = |k: &str, v: Option<f64>, what: &str| self.dipole_required(k, v, what);
        Ok(match kind {
            RawMagnetShape::Point => MagnetShape::Point,
            RawMagnetShape::Cylinder => {
                if raw.magnet_volume_m3.is_some() {
                    return Err(self.err(
                        "magnets.magnet_volume_m3",
                        "no volume with magnet_shape = \"cylinder\" (its diameter and \
                         thickness give it)",
                    ));
                }
                let what = "a disc's diameter (m) with magnet_shape = \"cylinder\",";
                let diameter_m = required("magnet_diameter_m", raw.magnet_diameter_m, what)?;
                let what = "a disc's thickness (m) with magnet_shape = \"cylinder\",";
                let thickness_m = required("magnet_thickness_m", raw.magnet_thickness_m, what)?;
                MagnetShape::Cylinder {
                    diameter_m,
                    thickness_m,
                }
            }
            RawMagnetShape::Cuboid => self.cuboid(raw)?,
        })
    }

    /// magnet_shape = "cuboid": its three sides, no disc size or volume.
    fn cuboid(&self, raw: &RawMagnets) -> Result<MagnetShape> {
        for (k, v) in [
            ("magnet_diameter_m", raw.magnet_diameter_m),
            ("magnet_thickness_m", raw.magnet_thickness_m),
            ("magnet_volume_m3", raw.magnet_volume_m3),
        ] {
            if v.is_some() {
                return Err(self.err(
                    &format!("magnets.{k}"),
                    "no disc size or volume with magnet_shape = \"cuboid\" (magnet_size_m \
                     gives it)",
                ));
            }
        }
        let sides = raw.magnet_size_m.ok_or_else(|| {
            self.err(
                "magnets.magnet_size_m",
                "a block's three sides [a, b, c] (m), c along the ball's radius, when \
                 magnet_shape = \"cuboid\"",
            )
        })?;
        let mut size_m = [0.0; 3];
        for (k, side) in sides.iter().enumerate() {
            size_m[k] = self.positive(&format!("magnets.magnet_size_m[{k}]"), Some(*side), 0.0)?;
        }
        Ok(MagnetShape::Cuboid { size_m })
    }

    /// The winding: its inner and outer radius and its length, all three or none (then the
    /// coil is the thin loop of `coil_radius_m`, which a winding refuses).
    fn winding(&self, raw: &RawMagnets) -> Result<Option<Winding>> {
        let keys = [
            ("coil_inner_radius_m", raw.coil_inner_radius_m),
            ("coil_outer_radius_m", raw.coil_outer_radius_m),
            ("coil_length_m", raw.coil_length_m),
        ];
        if keys.iter().all(|(_, v)| v.is_none()) {
            return Ok(None);
        }
        if let Some((k, _)) = keys.iter().find(|(_, v)| v.is_none()) {
            return Err(self.err(
                &format!("magnets.{k}"),
                "a winding's coil_inner_radius_m, coil_outer_radius_m and coil_length_m (m), \
                 all three",
            ));
        }
        if raw.coil_radius_m.is_some() {
            return Err(self.err(
                "magnets.coil_radius_m",
                "no loop radius with a winding (its inner and outer radius give the coil)",
            ));
        }
        let w = Winding {
            inner_radius_m: raw.coil_inner_radius_m.unwrap_or_default(),
            outer_radius_m: raw.coil_outer_radius_m.unwrap_or_default(),
            length_m: raw.coil_length_m.unwrap_or_default(),
        };
        check_winding(&w).map_err(|m| self.dipole_err(&m))?;
        Ok(Some(w))
    }
}
