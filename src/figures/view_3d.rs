//! Figure 6 of the paper ([`View3d`]): a still 3-D picture of the ball under one fixed
//! projection: its latitude and longitude lines, the world axes, the magnets (faded on the far
//! side), the coils, the energised pairs, and the desired and actual rotation axes as arrows.
//! (The interactive 3-D page is [`view`](super::view).)

use crate::figures::chart::{draw_legend, line_key, titled};
use crate::figures::figure::{
    check_finite_points, magnet_at, normalise, shows_magnet, DrawError, DrawResult, Figure,
};
use crate::figures::labels::{draw_labels, Mark, PointLabel, LABEL_SIZE};
use crate::figures::style::{
    plus, ACTIVE_COLOR, ACTUAL_COLOR, COIL_COLOR, DESIRED_COLOR, GUIDE_COLOR, MAGNET_BACK_COLOR,
    MAGNET_COLOR, REFERENCE_COLOR,
};
use crate::model::geometry::Pair;
use plotters::coord::cartesian::Cartesian3d;
use plotters::coord::types::RangedCoordf64;
use plotters::coord::Shift;
use plotters::prelude::*;
use plotters::style::RGBColor;

/// Figure 6: a 3-D view of the rotor, the stator coils and the rotation axes.
#[derive(Debug, Clone, PartialEq)]
pub struct View3d {
    /// The title drawn above the view.
    pub title: String,
    /// Stator coil i at `coils[i]`: world unit vector (drawn 10% outside the ball).
    pub coils: Vec<[f64; 3]>,
    /// Rotor magnets: (magnet index, world unit vector p_j = R r_j).
    pub magnets: Vec<(usize, [f64; 3])>,
    /// Energised pairs, joined by lines.
    pub active: Vec<Pair>,
    /// The desired rotation axis n.
    pub desired_axis: [f64; 3],
    /// The actual rotation axis of the step or of the cumulative rotation, if known.
    pub actual_axis: Option<[f64; 3]>,
}

/// The 3-D chart of Figure 6.
pub(super) type Chart3d<'a, DB> =
    ChartContext<'a, DB, Cartesian3d<RangedCoordf64, RangedCoordf64, RangedCoordf64>>;
/// A point in the chart's coordinates (see [`to_chart`]).
pub(super) type ChartPoint = (f64, f64, f64);

/// World (x, y, z) to the 3-D chart's (x, y, z): plotters draws its y axis upwards and its frame
/// is right-handed, so world z goes to the chart's y and world y to the chart's -z.
pub(super) fn to_chart(p: [f64; 3]) -> ChartPoint {
    (p[0], p[2], -p[1])
}

pub(super) fn scaled(p: [f64; 3], s: f64) -> [f64; 3] {
    [p[0] * s, p[1] * s, p[2] * s]
}

/// The fixed view of Figure 6: from a little below the equator (the stator cap is at the
/// bottom), turned about the vertical.
const VIEW_YAW: f64 = 0.6;
const VIEW_PITCH: f64 = -0.5;
pub(super) const COIL_RADIUS: f64 = 1.1;
const AXIS_LENGTH: f64 = 1.45;
const WORLD_AXIS_LENGTH: f64 = 1.3;

impl View3d {
    fn check(&self) -> DrawResult {
        check_finite_points("Figure 6", &self.coils, &self.magnets)?;
        for p in &self.active {
            if p.coil.0 >= self.coils.len() || !shows_magnet(&self.magnets, p.magnet.0) {
                return Err(DrawError(format!(
                    "Figure 6: active pair {p}: expected a coil below {} and a magnet shown",
                    self.coils.len()
                )));
            }
        }
        if normalise(&self.desired_axis).is_none() {
            return Err(DrawError(
                "Figure 6: expected a finite, non-zero desired axis".into(),
            ));
        }
        if let Some(a) = &self.actual_axis {
            if normalise(a).is_none() {
                return Err(DrawError(
                    "Figure 6: expected a finite, non-zero actual axis".into(),
                ));
            }
        }
        Ok(())
    }

    /// Where coil `i` is drawn: 10% outside the ball.
    fn coil_point(&self, i: usize) -> ChartPoint {
        to_chart(scaled(self.coils[i], COIL_RADIUS))
    }

    /// The magnets behind the ball first (faded), then the active pairs, then the magnets in
    /// front, then the coils.
    fn draw_ball_contents<'a, DB: DrawingBackend + 'a>(
        &self,
        chart: &mut Chart3d<'a, DB>,
    ) -> DrawResult {
        let spec = chart.as_coord_spec().clone();
        let centre_depth = spec.projected_depth(&0.0, &0.0, &0.0);
        let front = |p: [f64; 3]| {
            let (x, y, z) = to_chart(p);
            spec.projected_depth(&x, &y, &z) <= centre_depth
        };
        let back: Vec<_> = self.magnets.iter().filter(|(_, p)| !front(*p)).collect();
        let fore: Vec<_> = self.magnets.iter().filter(|(_, p)| front(*p)).collect();
        chart.draw_series(
            back.iter()
                .map(|(_, p)| Circle::new(to_chart(*p), 4, MAGNET_BACK_COLOR.filled())),
        )?;
        chart
            .draw_series(self.active.iter().map(|p| {
                PathElement::new(
                    vec![
                        self.coil_point(p.coil.0),
                        to_chart(magnet_at(&self.magnets, p.magnet.0)),
                    ],
                    ACTIVE_COLOR.stroke_width(3),
                )
            }))?
            .label("active pair")
            .legend(line_key(ACTIVE_COLOR.stroke_width(3)));
        chart
            .draw_series(
                fore.iter()
                    .map(|(_, p)| Circle::new(to_chart(*p), 4, MAGNET_COLOR.filled())),
            )?
            .label("rotor magnet (faded: far side)")
            .legend(|(x, y)| Circle::new((x + 10, y), 4, MAGNET_COLOR.filled()));
        chart
            .draw_series(
                (0..self.coils.len())
                    .map(|i| plus!(self.coil_point(i), 6, COIL_COLOR.stroke_width(2))),
            )?
            .label("stator coil (+)")
            .legend(|(x, y)| plus!((x + 10, y), 6, COIL_COLOR.stroke_width(2)));
        Ok(())
    }

    /// The rotation axes drawn as arrows: the desired one, and the actual one if known.
    fn arrows(&self) -> Vec<(&'static str, [f64; 3], RGBColor)> {
        let mut arrows = vec![(
            "desired axis",
            normalise(&self.desired_axis).unwrap_or([0.0, 0.0, 1.0]),
            DESIRED_COLOR,
        )];
        if let Some(a) = self.actual_axis.as_ref().and_then(normalise) {
            arrows.push(("actual axis", a, ACTUAL_COLOR));
        }
        arrows
    }

    /// The labels of the arrows' tips, the world axes' and the coils', in that order (the
    /// order they are placed in) and the marks they must not cover: the coils and the
    /// arrows' tips.
    fn labels(
        &self,
        spec: &Cartesian3d<RangedCoordf64, RangedCoordf64, RangedCoordf64>,
    ) -> (Vec<PointLabel<ChartPoint>>, Vec<Mark>) {
        let tips: Vec<_> = self
            .arrows()
            .into_iter()
            .map(|(name, n, color)| {
                PointLabel::new(name, to_chart(scaled(n, AXIS_LENGTH)), 16, color)
            })
            .collect();
        let marks = (0..self.coils.len())
            .map(|i| (spec.translate(&self.coil_point(i)), 7))
            .chain(tips.iter().map(|l| (spec.translate(&l.at), 9)))
            .collect();
        let world = WORLD_AXES.map(|(name, v)| {
            PointLabel::new(
                format!("world {name}"),
                to_chart(scaled(v, WORLD_AXIS_LENGTH)),
                16,
                REFERENCE_COLOR,
            )
        });
        let coils = (0..self.coils.len())
            .map(|i| PointLabel::new(i.to_string(), self.coil_point(i), LABEL_SIZE, COIL_COLOR));
        let labels = tips.into_iter().chain(world).chain(coils).collect();
        (labels, marks)
    }
}

/// The world axes drawn from the centre, with their names.
const WORLD_AXES: [(&str, [f64; 3]); 3] = [
    ("x", [1.0, 0.0, 0.0]),
    ("y", [0.0, 1.0, 0.0]),
    ("z", [0.0, 0.0, 1.0]),
];

/// The chart on `area`, under the fixed projection of Figure 6.
pub(super) fn projected_chart<DB: DrawingBackend>(
    area: &DrawingArea<DB, Shift>,
) -> Result<Chart3d<'_, DB>, DrawError> {
    let lim = 1.6;
    let mut chart = ChartBuilder::on(area).build_cartesian_3d(-lim..lim, -lim..lim, -lim..lim)?;
    chart.with_projection(|mut pb| {
        pb.yaw = VIEW_YAW;
        pb.pitch = VIEW_PITCH;
        pb.scale = 1.45;
        pb.into_matrix()
    });
    Ok(chart)
}

/// The ball: latitude circles and meridians.
pub(super) fn draw_guides<'a, DB: DrawingBackend + 'a>(chart: &mut Chart3d<'a, DB>) -> DrawResult {
    let circle = |f: &dyn Fn(f64) -> [f64; 3]| -> Vec<ChartPoint> {
        (0..=96)
            .map(|k| to_chart(f(k as f64 * std::f64::consts::TAU / 96.0)))
            .collect()
    };
    let mut guides = Vec::new();
    for lat in [-60.0f64, -30.0, 0.0, 30.0, 60.0] {
        let (s, c) = lat.to_radians().sin_cos();
        guides.push(circle(&|a: f64| [c * a.cos(), c * a.sin(), s]));
    }
    for lon in [0.0f64, 45.0, 90.0, 135.0] {
        let (s, c) = lon.to_radians().sin_cos();
        guides.push(circle(&|a: f64| [c * a.cos(), s * a.cos(), a.sin()]));
    }
    chart.draw_series(
        guides
            .into_iter()
            .map(|g| PathElement::new(g, GUIDE_COLOR.stroke_width(1))),
    )?;
    Ok(())
}

/// The world axes, from the centre to a little outside the coils (a rotation axis may lie
/// along one).
fn draw_world_axes<'a, DB: DrawingBackend + 'a>(chart: &mut Chart3d<'a, DB>) -> DrawResult {
    for (_, v) in WORLD_AXES {
        chart.draw_series(std::iter::once(PathElement::new(
            vec![to_chart([0.0; 3]), to_chart(scaled(v, WORLD_AXIS_LENGTH))],
            REFERENCE_COLOR.stroke_width(1),
        )))?;
    }
    Ok(())
}

/// An arrow's head at its tip, in pixel offsets: two strokes back from the tip along the
/// projected direction (dx, dy) from the centre to the tip (none for a point-on arrow).
fn arrow_head((dx, dy): (f64, f64)) -> Vec<(i32, i32)> {
    let len = dx.hypot(dy);
    if len <= 1.0 {
        return Vec::new();
    }
    let (ux, uy) = (dx / len, dy / len);
    let (hl, hw) = (16.0, 7.0);
    let pt = |a: f64| {
        (
            (-ux * hl + a * uy * hw).round() as i32,
            (-uy * hl - a * ux * hw).round() as i32,
        )
    };
    vec![pt(1.0), (0, 0), pt(-1.0)]
}

/// One rotation axis as an arrow from the centre along the unit vector `n`: its head (with
/// the legend's entry `name`), then its shaft.
fn draw_arrow<'a, DB: DrawingBackend + 'a>(
    chart: &mut Chart3d<'a, DB>,
    name: &'static str,
    n: [f64; 3],
    color: RGBColor,
) -> DrawResult {
    let spec = chart.as_coord_spec();
    let tip = to_chart(scaled(n, AXIS_LENGTH));
    let (x0, y0) = spec.translate(&to_chart([0.0; 3]));
    let (x1, y1) = spec.translate(&tip);
    let head = arrow_head(((x1 - x0) as f64, (y1 - y0) as f64));
    let style = color.stroke_width(3);
    chart
        .draw_series(std::iter::once(
            EmptyElement::at(tip) + PathElement::new(head, style),
        ))?
        .label(name)
        .legend(move |(x, y)| {
            EmptyElement::at((x, y))
                + PathElement::new(vec![(0, 0), (20, 0)], style)
                + PathElement::new(vec![(14, -5), (20, 0), (14, 5)], style)
        });
    chart.draw_series(std::iter::once(PathElement::new(
        vec![to_chart([0.0; 3]), tip],
        style,
    )))?;
    Ok(())
}

impl Figure for View3d {
    fn size(&self) -> (u32, u32) {
        (880, 860)
    }

    fn draw<DB: DrawingBackend>(&self, root: &DrawingArea<DB, Shift>) -> DrawResult {
        self.check()?;
        let area = titled(root, &self.title, (0, 10, 10, 10))?;
        let mut chart = projected_chart(&area)?;
        draw_guides(&mut chart)?;
        draw_world_axes(&mut chart)?;
        self.draw_ball_contents(&mut chart)?;
        for (name, n, color) in self.arrows() {
            draw_arrow(&mut chart, name, n, color)?;
        }
        // Labels are placed last, all together, where they meet no other label and no mark.
        let (labels, marks) = self.labels(chart.as_coord_spec());
        draw_labels(&mut chart, &labels, &marks)?;
        draw_legend(&mut chart, SeriesLabelPosition::UpperLeft, 14, 0.85)
    }
}
