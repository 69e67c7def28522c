//! The sweep map ([`SweepMap`]): a value for each axis of a sweep (e.g. the worst axis error of
//! a 90 degree move) as coloured disks on an equirectangular longitude/latitude map of the
//! sphere of axes, with a colour bar, grey rings for axes without a result, crosses for those
//! not reached and a '+' at both ends of each coil's axis.

use crate::figures::chart::{axes, plot_dims, titled, Chart2d};
use crate::figures::figure::{normalise, DrawError, DrawResult, Figure};
use crate::figures::style::{
    plus, text, tick, tick_decimals, COIL_COLOR, NO_RESULT_COLOR, UNREACHED_COLOR,
};
use plotters::coord::Shift;
use plotters::prelude::*;
use plotters::style::text_anchor::{HPos, Pos, VPos};
use plotters::style::RGBColor;

/// A value over the sphere of axes, drawn on a longitude/latitude map with a colour bar.
/// Longitude = atan2(y, x), latitude = asin(z), in degrees. Non-finite values are drawn as grey
/// rings ("no result").
#[derive(Debug, Clone, PartialEq)]
pub struct SweepMap {
    /// The title drawn above the map.
    pub title: String,
    /// What the colour means, e.g. "worst axis error (deg)".
    pub value_label: String,
    /// (axis, value): the axis need not be normalised but must not be zero.
    pub points: Vec<([f64; 3], f64)>,
    /// The colour scale's range (low, high); `None`: the points' own. Maps to be compared (a
    /// sweep's schemes) share one.
    pub range: Option<(f64, f64)>,
    /// Axes of the cases that did not reach their target, marked with a cross.
    pub unreached: Vec<[f64; 3]>,
    /// Stator coil directions: a coil's line through the centre is an axis the ball turns
    /// about easily, drawn as a '+' at both of its ends.
    pub coils: Vec<[f64; 3]>,
}

/// Stops of the colour scale of a [`SweepMap`] (viridis, low to high).
const SCALE: [(u8, u8, u8); 5] = [
    (68, 1, 84),
    (59, 82, 139),
    (33, 145, 140),
    (94, 201, 98),
    (253, 231, 37),
];

/// The colour of `t` in [0, 1] on the map's scale.
pub fn scale_color(t: f64) -> RGBColor {
    let t = if t.is_finite() {
        t.clamp(0.0, 1.0)
    } else {
        0.0
    };
    let x = t * (SCALE.len() - 1) as f64;
    let k = (x.floor() as usize).min(SCALE.len() - 2);
    let f = x - k as f64;
    let (a, b) = (SCALE[k], SCALE[k + 1]);
    let mix = |u: u8, v: u8| (u as f64 + (v as f64 - u as f64) * f).round() as u8;
    RGBColor(mix(a.0, b.0), mix(a.1, b.1), mix(a.2, b.2))
}

/// The map's coordinates count longitude in units of 45 degrees and latitude in units of
/// 30 degrees, so that plotters' ticks (steps of 1, 2 or 5 units) fall on those multiples.
const LON_UNIT: f64 = 45.0;
const LAT_UNIT: f64 = 30.0;

/// The label areas of the map and of the colour bar (pixels): left of the map, below both.
const LEFT: u32 = 60;
const BOTTOM: u32 = 50;
/// The width of the colour bar's area at the right of the map, pixels.
const BAR_WIDTH: i32 = 140;

/// A point of the map: longitude / LON_UNIT, latitude / LAT_UNIT.
type MapPoint = (f64, f64);

/// Map coordinates of a non-zero axis.
fn lon_lat(v: &[f64; 3]) -> Option<MapPoint> {
    let n = normalise(v)?;
    Some((
        n[1].atan2(n[0]).to_degrees() / LON_UNIT,
        n[2].clamp(-1.0, 1.0).asin().to_degrees() / LAT_UNIT,
    ))
}

/// The finite values' minimum and maximum, widened if equal ((0, 1) without any).
pub(crate) fn value_range(vals: impl Iterator<Item = f64>) -> (f64, f64) {
    let (lo, hi) = vals
        .filter(|v| v.is_finite())
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), v| {
            (lo.min(v), hi.max(v))
        });
    if !lo.is_finite() {
        (0.0, 1.0)
    } else if hi - lo < 1e-9 {
        (lo - 0.5, hi + 0.5)
    } else {
        (lo, hi)
    }
}

/// The kinds of mark a map may show besides its disks, each explained under the colour bar
/// when the map has one.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Key {
    NoResult,
    NotReached,
    CoilAxis,
}

impl SweepMap {
    fn check(&self) -> DrawResult {
        if let Some((a, _)) = self.points.iter().find(|(a, _)| normalise(a).is_none()) {
            return Err(DrawError(format!(
                "sweep map: expected finite, non-zero axes, got {a:?}"
            )));
        }
        // The colour scale must span a finite range (a span of inf never finishes its ticks).
        if let Some((_, v)) = self.points.iter().find(|(_, v)| v.is_infinite()) {
            return Err(DrawError(format!(
                "sweep map: expected finite values (or NaN: no result), got {v}"
            )));
        }
        let (lo, hi) = self.value_range();
        if !(hi - lo).is_finite() || lo.abs().max(hi.abs()) > 1e12 {
            return Err(DrawError(format!(
                "sweep map: expected values within +-1e12, got {} to {}",
                crate::text::shown(lo),
                crate::text::shown(hi)
            )));
        }
        Ok(())
    }

    /// The colour scale's range: the given one, else the finite values' minimum and maximum
    /// (widened if equal).
    fn value_range(&self) -> (f64, f64) {
        let own = value_range(self.points.iter().map(|p| p.1));
        match self.range {
            Some((lo, hi)) => value_range([lo, hi, own.0, own.1].into_iter()),
            None => own,
        }
    }

    /// The disks' radius in pixels: about as wide as the axes' mean spacing at the equator.
    fn disk_radius<DB: DrawingBackend>(&self, map_area: &DrawingArea<DB, Shift>) -> i32 {
        let (pw, _) = plot_dims(map_area, LEFT + 15, BOTTOM);
        let n = self.points.len().max(1) as f64;
        let spacing_deg = (41_253.0 / n).sqrt();
        (0.5 * spacing_deg * pw / 360.0).clamp(2.0, 14.0).round() as i32
    }

    /// A disk in the scale's colour for each finite value, the worst on top.
    fn draw_disks<'a, DB: DrawingBackend + 'a>(
        &self,
        chart: &mut Chart2d<'a, DB>,
        radius: i32,
    ) -> DrawResult {
        let (lo, hi) = self.value_range();
        let mut finite: Vec<_> = self
            .points
            .iter()
            .filter(|p| p.1.is_finite())
            .filter_map(|(a, v)| lon_lat(a).map(|ll| (ll, *v)))
            .collect();
        finite.sort_by(|a, b| a.1.total_cmp(&b.1));
        chart.draw_series(
            finite.iter().map(|(ll, v)| {
                Circle::new(*ll, radius, scale_color((v - lo) / (hi - lo)).filled())
            }),
        )?;
        Ok(())
    }

    /// Map points of the axes without a result, of those not reached, and of both ends of
    /// each coil's axis.
    fn marked_axes(&self) -> [Vec<MapPoint>; 3] {
        let missing = self.points.iter().filter(|p| !p.1.is_finite());
        let coil_ends = self.coils.iter().flat_map(|c| [*c, [-c[0], -c[1], -c[2]]]);
        [
            missing.filter_map(|(a, _)| lon_lat(a)).collect(),
            self.unreached.iter().filter_map(lon_lat).collect(),
            coil_ends.filter_map(|c| lon_lat(&c)).collect(),
        ]
    }

    /// Everything on the map after its axes: the disks, then a grey ring for each missing
    /// value, a cross on each axis not reached and a '+' at both ends of each coil's axis
    /// (white under the blue, so that it shows on any disk). Returns the kinds of mark shown.
    fn draw_marks<'a, DB: DrawingBackend + 'a>(
        &self,
        chart: &mut Chart2d<'a, DB>,
        radius: i32,
    ) -> Result<Vec<Key>, DrawError> {
        self.draw_disks(chart, radius)?;
        let [missing, unreached, coils] = self.marked_axes();
        chart.draw_series(
            missing
                .iter()
                .map(|ll| Circle::new(*ll, radius, NO_RESULT_COLOR.stroke_width(2))),
        )?;
        let cross = (radius - 1).max(3);
        chart.draw_series(
            unreached
                .iter()
                .map(|ll| Cross::new(*ll, cross, UNREACHED_COLOR.stroke_width(2))),
        )?;
        for (r, style) in [(8, WHITE.stroke_width(5)), (7, COIL_COLOR.stroke_width(2))] {
            chart.draw_series(coils.iter().map(|ll| plus!(*ll, r, style)))?;
        }
        let shown = [
            (missing, Key::NoResult),
            (unreached, Key::NotReached),
            (coils, Key::CoilAxis),
        ];
        Ok(shown
            .into_iter()
            .filter_map(|(at, k)| (!at.is_empty()).then_some(k))
            .collect())
    }
}

/// The map's chart on `map_area`, its axes in degrees of longitude and latitude.
fn map_chart<DB: DrawingBackend>(
    map_area: &DrawingArea<DB, Shift>,
) -> Result<Chart2d<'_, DB>, DrawError> {
    let mut chart = ChartBuilder::on(map_area)
        .margin_right(15)
        .x_label_area_size(BOTTOM)
        .y_label_area_size(LEFT)
        .build_cartesian_2d(-4.0..4.0, -3.0..3.0)?;
    axes(
        &mut chart,
        "axis longitude atan2(y, x) (deg)",
        "axis latitude asin(z) (deg)",
    )
    .x_labels(9)
    .y_labels(7)
    .x_label_formatter(&|v| tick(*v * LON_UNIT, 0))
    .y_label_formatter(&|v| tick(*v * LAT_UNIT, 0))
    .light_line_style(TRANSPARENT)
    .bold_line_style(RGBColor(225, 225, 225))
    .draw()?;
    Ok(chart)
}

/// What the marks mean, under the colour bar (in the bar's area, where they hide no disk),
/// one row per kind of mark shown.
fn draw_keys<DB: DrawingBackend>(bar_area: &DrawingArea<DB, Shift>, keys: &[Key]) -> DrawResult {
    let h = bar_area.dim_in_pixel().1 as i32;
    for (row, key) in keys.iter().enumerate() {
        let at = (14, h - BOTTOM as i32 + 8 + 15 * row as i32);
        let name = match key {
            Key::NoResult => "no result",
            Key::NotReached => "not reached",
            Key::CoilAxis => "coil axis",
        };
        let label = Text::new(
            name,
            (12, 0),
            text(12).pos(Pos::new(HPos::Left, VPos::Center)),
        );
        match key {
            Key::NoResult => bar_area.draw(
                &(EmptyElement::at(at)
                    + Circle::new((0, 0), 5, NO_RESULT_COLOR.stroke_width(2))
                    + label),
            )?,
            Key::NotReached => bar_area.draw(
                &(EmptyElement::at(at)
                    + Cross::new((0, 0), 4, UNREACHED_COLOR.stroke_width(2))
                    + label),
            )?,
            Key::CoilAxis => bar_area.draw(
                &(EmptyElement::at(at)
                    + PathElement::new(vec![(-5, 0), (5, 0)], COIL_COLOR.stroke_width(2))
                    + PathElement::new(vec![(0, -5), (0, 5)], COIL_COLOR.stroke_width(2))
                    + label),
            )?,
        }
    }
    Ok(())
}

/// The colour bar from `lo` to `hi`, its plotting area level with the map's, described by
/// `value_label`.
fn draw_colour_bar<DB: DrawingBackend>(
    bar_area: &DrawingArea<DB, Shift>,
    (lo, hi): (f64, f64),
    value_label: &str,
) -> DrawResult {
    let mut bar = ChartBuilder::on(bar_area)
        .margin_left(5)
        .margin_right(5)
        .x_label_area_size(BOTTOM)
        .right_y_label_area_size(70)
        .build_cartesian_2d(0.0..1.0, lo..hi)?;
    let bd = tick_decimals(hi - lo);
    bar.configure_mesh()
        .disable_mesh()
        .disable_x_axis()
        .y_labels(8)
        .y_label_formatter(&|v| tick(*v, bd))
        .y_desc(value_label)
        .label_style(text(14))
        .axis_desc_style(text(16))
        .draw()?;
    let steps = 128;
    bar.draw_series((0..steps).map(|k| {
        let (a, b) = (k as f64 / steps as f64, (k + 1) as f64 / steps as f64);
        Rectangle::new(
            [(0.0, lo + a * (hi - lo)), (1.0, lo + b * (hi - lo))],
            scale_color((a + b) / 2.0).filled(),
        )
    }))?;
    Ok(())
}

impl Figure for SweepMap {
    fn size(&self) -> (u32, u32) {
        (1100, 600)
    }

    fn draw<DB: DrawingBackend>(&self, root: &DrawingArea<DB, Shift>) -> DrawResult {
        self.check()?;
        let area = titled(root, &self.title, (5, 15, 10, 10))?;
        let (map_area, bar_area) =
            area.split_horizontally(area.dim_in_pixel().0 as i32 - BAR_WIDTH);
        let mut chart = map_chart(&map_area)?;
        let keys = self.draw_marks(&mut chart, self.disk_radius(&map_area))?;
        draw_keys(&bar_area, &keys)?;
        draw_colour_bar(&bar_area, self.value_range(), &self.value_label)
    }
}
