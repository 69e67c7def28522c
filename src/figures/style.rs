//! How every figure looks: the bundled font and its text styles, the colours, the style of
//! each series of an axis error plot (colour, marker, dash), the '+' and '*' marks of coils and
//! magnets, and the tick labels.

use plotters::prelude::*;
use plotters::style::RGBColor;

/// The bundled font (DejaVu Sans; license in `assets/fonts/LICENSE-DejaVu.txt`).
pub(crate) const FONT_BYTES: &[u8] = include_bytes!("../../assets/fonts/DejaVuSans.ttf");
/// The family name every text style of the figures uses: the bundled font by name (so an SVG
/// viewer that has it shows the same text as the PNG), then a generic fallback.
pub(crate) const FONT: &str = "DejaVu Sans, sans-serif";

pub(crate) const COIL_COLOR: RGBColor = RGBColor(31, 119, 180);
pub(crate) const MAGNET_COLOR: RGBColor = RGBColor(200, 30, 30);
pub(crate) const MAGNET_BACK_COLOR: RGBColor = RGBColor(235, 170, 170);
pub(crate) const CANDIDATE_COLOR: RGBColor = RGBColor(150, 150, 150);
pub(crate) const CHOSEN_COLOR: RGBColor = RGBColor(0, 0, 0);
pub(crate) const ACTIVE_COLOR: RGBColor = RGBColor(30, 150, 60);
pub(crate) const DESIRED_COLOR: RGBColor = RGBColor(0, 0, 0);
pub(crate) const ACTUAL_COLOR: RGBColor = RGBColor(230, 120, 0);
pub(crate) const GUIDE_COLOR: RGBColor = RGBColor(205, 205, 205);
pub(crate) const REFERENCE_COLOR: RGBColor = RGBColor(120, 120, 120);
pub(crate) const TARGET_COLOR: RGBColor = RGBColor(90, 90, 90);
pub(crate) const NO_RESULT_COLOR: RGBColor = RGBColor(128, 128, 128);
pub(crate) const UNREACHED_COLOR: RGBColor = RGBColor(0, 0, 0);
/// Colours of the schemes of an [`AxisErrorPlot`](super::AxisErrorPlot), in order (then
/// repeated): the Okabe-Ito palette, told apart with any colour vision (its yellow left out:
/// too pale on white).
pub const SERIES_COLORS: [RGBColor; 7] = [
    RGBColor(0, 114, 178),
    RGBColor(213, 94, 0),
    RGBColor(0, 158, 115),
    RGBColor(204, 121, 167),
    RGBColor(230, 159, 0),
    RGBColor(86, 180, 233),
    RGBColor(0, 0, 0),
];

/// The marker of a series of an [`AxisErrorPlot`](super::AxisErrorPlot) (drawn hollow).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Marker {
    /// A circle.
    Circle,
    /// A square.
    Square,
    /// A triangle, point up.
    Triangle,
    /// A square turned 45 degrees.
    Diamond,
    /// A diagonal cross.
    Cross,
}

const MARKERS: [Marker; 5] = [
    Marker::Circle,
    Marker::Square,
    Marker::Triangle,
    Marker::Diamond,
    Marker::Cross,
];

/// Dash patterns (dash, gap in pixels; (0, 0) is a solid line) of the series' lines.
const DASHES: [(u32, u32); 4] = [(0, 0), (10, 5), (3, 4), (16, 4)];

/// How series `k` of an [`AxisErrorPlot`](super::AxisErrorPlot) is drawn: colour, marker and
/// dash each differ from those of every other of the first seven series.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SeriesStyle {
    /// The line's and the markers' colour.
    pub color: RGBColor,
    /// The marker drawn at each point.
    pub marker: Marker,
    /// The line's dash pattern: (dash, gap) in pixels; (0, 0) is solid.
    pub dash: (u32, u32),
}

/// The style of series `k`.
pub fn series_style(k: usize) -> SeriesStyle {
    SeriesStyle {
        color: SERIES_COLORS[k % SERIES_COLORS.len()],
        marker: MARKERS[k % MARKERS.len()],
        dash: DASHES[k % DASHES.len()],
    }
}

/// A marker's outline as a closed path of pixel offsets around its point, `r` pixels out.
pub(crate) fn marker_path(m: Marker, r: i32) -> Vec<(i32, i32)> {
    match m {
        Marker::Circle => (0..=16)
            .map(|k| {
                let a = k as f64 * std::f64::consts::PI / 8.0;
                (
                    (r as f64 * a.cos()).round() as i32,
                    (r as f64 * a.sin()).round() as i32,
                )
            })
            .collect(),
        Marker::Square => vec![(-r, -r), (r, -r), (r, r), (-r, r), (-r, -r)],
        Marker::Triangle => vec![(0, -r - 1), (r + 1, r), (-r - 1, r), (0, -r - 1)],
        Marker::Diamond => vec![
            (0, -r - 1),
            (r + 1, 0),
            (0, r + 1),
            (-r - 1, 0),
            (0, -r - 1),
        ],
        Marker::Cross => vec![(-r, -r), (r, r), (0, 0), (r, -r), (-r, r)],
    }
}

/// A series' line sample for the legend: the dash pattern over 24 pixels, as four segments
/// (the unused ones empty).
pub(crate) fn dash_path(dash: (u32, u32)) -> [Vec<(i32, i32)>; 4] {
    let mut out: [Vec<(i32, i32)>; 4] = Default::default();
    if dash.0 == 0 {
        out[0] = vec![(0, 0), (24, 0)];
        return out;
    }
    let (d, g) = (dash.0.min(12) as i32, dash.1.max(1) as i32);
    for (k, seg) in out.iter_mut().enumerate() {
        let x = k as i32 * (d + g);
        if x < 24 {
            *seg = vec![(x, 0), ((x + d).min(24), 0)];
        }
    }
    out
}

/// The strokes of a '*' of half-size `r` pixels (a rotor magnet), in pixel offsets.
pub(crate) fn star_strokes(r: i32) -> [Vec<(i32, i32)>; 3] {
    let d = (r as f64 * 0.866).round() as i32;
    let h = (r as f64 * 0.5).round() as i32;
    [
        vec![(0, -r), (0, r)],
        vec![(-d, -h), (d, h)],
        vec![(-d, h), (d, -h)],
    ]
}

/// A '+' marker (a stator coil) of half-size `$r` pixels at `$at`: two strokes (two SVG
/// polylines). A macro, as the element's type cannot be named outside plotters.
macro_rules! plus {
    ($at:expr, $r:expr, $style:expr) => {{
        let (r, style) = ($r, $style);
        ::plotters::element::EmptyElement::at($at)
            + ::plotters::element::PathElement::new(vec![(-r, 0), (r, 0)], style)
            + ::plotters::element::PathElement::new(vec![(0, -r), (0, r)], style)
    }};
}
pub(crate) use plus;

/// A '*' marker (a rotor magnet) of half-size `$r` pixels at `$at`: three strokes.
macro_rules! star {
    ($at:expr, $r:expr, $style:expr) => {{
        let ([a, b, c], style) = ($crate::figures::style::star_strokes($r), $style);
        ::plotters::element::EmptyElement::at($at)
            + ::plotters::element::PathElement::new(a, style)
            + ::plotters::element::PathElement::new(b, style)
            + ::plotters::element::PathElement::new(c, style)
    }};
}
pub(crate) use star;

/// The text style of a given size. Sizes are even: plotters' ab_glyph renderer snaps half a
/// size, and an odd size puts some glyphs (the decimal point) one pixel off the baseline.
pub(crate) fn text(size: u32) -> TextStyle<'static> {
    (FONT, size & !1).into_font().color(&BLACK)
}

/// A tick label: `decimals` places, and no "-0".
pub(crate) fn tick(v: f64, decimals: usize) -> String {
    let s = format!("{v:.decimals$}");
    if s.trim_start_matches('-')
        .chars()
        .all(|c| c == '0' || c == '.')
    {
        s.trim_start_matches('-').to_string()
    } else {
        s
    }
}

/// Decimals enough for ticks over a range of width `span`.
pub(crate) fn tick_decimals(span: f64) -> usize {
    if span >= 8.0 {
        0
    } else if span >= 0.8 {
        1
    } else {
        2
    }
}
