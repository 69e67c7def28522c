//! The `[design]` section's checks (`spherestep design`): which packing is free, the counts,
//! the cap, the separations, the families and the search's size, each refusal naming the
//! field; the defaults come from the scenario's own packings.

use super::checked::Checker;
use super::raw::RawDesign;
use crate::error::Result;
use crate::model::geometry::{angular_distance, Degrees, Radians, UnitVec};
use crate::model::packing::{min_separation, Packing};
use crate::planning::design::{area_bound, DesignSpec, Family, Free};
use crate::text::shown;
use nalgebra::Vector3;

impl Checker<'_> {
    /// The `[design]` section, its defaults from the scenario's `stator` and `rotor`.
    pub(super) fn design(
        &self,
        raw: RawDesign,
        stator: &Packing,
        rotor: &Packing,
    ) -> Result<DesignSpec> {
        let free = match raw.free.as_deref().unwrap_or("stator") {
            "stator" => Free::Stator,
            "rotor" => Free::Rotor,
            "both" => Free::Both,
            other => {
                return Err(self.err(
                    "design.free",
                    format!("\"stator\", \"rotor\" or \"both\", got \"{other}\""),
                ))
            }
        };
        let coils = self.range(
            "coils",
            (raw.coils, raw.coils_min, raw.coils_max),
            stator.len(),
            free.stator(),
        )?;
        let magnets = self.range(
            "magnets",
            (raw.magnets, raw.magnets_min, raw.magnets_max),
            rotor.len(),
            free.rotor(),
        )?;
        let (cap_axis, cap) = self.cap(raw.cap_axis, raw.cap_deg, stator)?;
        let coil_separation = self.small_angle(
            "design.coil_separation_deg",
            raw.coil_separation_deg,
            min_separation(&stator.points),
        )?;
        let magnet_separation = self.small_angle(
            "design.magnet_separation_deg",
            raw.magnet_separation_deg,
            min_separation(&rotor.points),
        )?;
        self.fits("coil", coils.1, cap, coil_separation)?;
        self.fits(
            "magnet",
            magnets.1,
            Radians(std::f64::consts::PI),
            magnet_separation,
        )?;
        let spec = DesignSpec {
            free,
            coils,
            magnets,
            cap_axis,
            cap,
            coil_separation,
            magnet_separation,
            families: self.families(raw.families)?,
            axes: self.count("design.axes", raw.axes, 32)?,
            full_axes: self.count("design.full_axes", raw.full_axes, 128)?,
            axis_seed: raw.axis_seed.unwrap_or(1),
            population: self.count("design.population", raw.population, 16)?,
            generations: raw.generations.unwrap_or(10),
            angle: self.small_angle(
                "design.angle_deg",
                raw.angle_deg,
                Degrees(90.0).to_radians(),
            )?,
            rotation: self.bounded("design.rotation_deg", raw.rotation_deg, 10.0, 180.0)?,
            point_move: self.bounded("design.move_deg", raw.move_deg, 3.0, 90.0)?,
        };
        self.search_size(&spec)?;
        Ok(spec)
    }

    /// The cap the coils stay in: its axis (default -Z) and half-angle (default: the
    /// stator's furthest coil from the axis).
    fn cap(
        &self,
        axis: Option<[f64; 3]>,
        deg: Option<f64>,
        stator: &Packing,
    ) -> Result<(UnitVec, Radians)> {
        let cap_axis = match axis {
            Some(a) => self.unit("design.cap_axis", a)?,
            None => UnitVec::new_normalize(-Vector3::z()),
        };
        let own_cap = stator
            .points
            .iter()
            .map(|p| angular_distance(p, &cap_axis).0)
            .fold(0.0, f64::max);
        Ok((
            cap_axis,
            self.small_angle("design.cap_deg", deg, Radians(own_cap))?,
        ))
    }

    /// A count or a range of counts (`what`, `what_min`, `what_max`): `own` when none is
    /// given; a packing that is not free keeps its own count.
    fn range(
        &self,
        what: &str,
        (one, lo, hi): (Option<usize>, Option<usize>, Option<usize>),
        own: usize,
        free: bool,
    ) -> Result<(usize, usize)> {
        if one.is_some() && (lo.is_some() || hi.is_some()) {
            return Err(self.err(
                &format!("design.{what}"),
                format!("either `{what}` or `{what}_min`/`{what}_max`, not both"),
            ));
        }
        let (lo, hi) = match one {
            Some(n) => (n, n),
            None => (lo.unwrap_or(own), hi.unwrap_or(own.max(lo.unwrap_or(0)))),
        };
        let field = |k: &str| format!("design.{what}{k}");
        if lo == 0 {
            let k = if one.is_some() { "" } else { "_min" };
            return Err(self.err(&field(k), format!("at least 1 {what}, got 0")));
        }
        if lo > hi {
            return Err(self.err(
                &field("_max"),
                format!("a range that is not empty: at least {what}_min ({lo}), got {hi}"),
            ));
        }
        if !free && (lo, hi) != (own, own) {
            return Err(self.err(
                &field(if one.is_some() { "" } else { "_min" }),
                format!("the scenario's own {own} {what} (its packing is not free), got {lo}-{hi}"),
            ));
        }
        Ok((lo, hi))
    }

    /// Refuses more points than can fit at `sep` in the cap (see [`area_bound`]).
    fn fits(&self, what: &str, most: usize, cap: Radians, sep: Radians) -> Result<()> {
        let bound = area_bound(cap, sep);
        if most <= bound {
            return Ok(());
        }
        Err(self.err(
            &format!("design.{what}_separation_deg"),
            format!(
                "a separation at which {most} {what}s can fit (in a cap of {:.1} degrees at most \
                 {bound} {what}s fit {:.1} degrees apart), got {}",
                cap.0.to_degrees(),
                sep.0.to_degrees(),
                shown(sep.0.to_degrees())
            ),
        ))
    }

    /// The families to seed from: at least one, each known, none twice.
    fn families(&self, raw: Option<Vec<String>>) -> Result<Vec<Family>> {
        let Some(names) = raw else {
            return Ok(Family::ALL.to_vec());
        };
        if names.is_empty() {
            return Err(self.err("design.families", "at least one family"));
        }
        let known: Vec<&str> = Family::ALL.iter().map(|f| f.name()).collect();
        let mut out = Vec::new();
        for (i, n) in names.iter().enumerate() {
            let field = format!("design.families[{i}]");
            let f = Family::parse(n).ok_or_else(|| {
                self.err(&field, format!("one of {}, got \"{n}\"", known.join(", ")))
            })?;
            if out.contains(&f) {
                return Err(self.err(&field, format!("each family once, got \"{n}\" twice")));
            }
            out.push(f);
        }
        Ok(out)
    }

    /// An angle in [0, `max`] degrees.
    fn bounded(&self, field: &str, v: Option<f64>, default: f64, max: f64) -> Result<Radians> {
        match v.unwrap_or(default) {
            x if x.is_finite() && (0.0..=max).contains(&x) => Ok(Degrees(x).to_radians()),
            x => Err(self.err(
                field,
                format!("an angle in [0, {max}] degrees, got {}", shown(x)),
            )),
        }
    }

    /// The axes and the population: at least the coarse axes in the full set, at least four
    /// layouts a generation.
    fn search_size(&self, spec: &DesignSpec) -> Result<()> {
        if spec.full_axes < spec.axes {
            return Err(self.err(
                "design.full_axes",
                format!(
                    "at least design.axes ({}), got {}",
                    spec.axes, spec.full_axes
                ),
            ));
        }
        if spec.population < 4 {
            return Err(self.err(
                "design.population",
                format!("at least 4 layouts a generation, got {}", spec.population),
            ));
        }
        Ok(())
    }
}
