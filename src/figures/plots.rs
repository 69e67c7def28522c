//! Pictures of commutation plans and sweeps, drawn with plotters' pure-Rust backends: every
//! figure is written both as SVG and as PNG (text rendered with ab_glyph and the DejaVu Sans
//! font kept in `assets/fonts/`, so nothing depends on the system's fonts).
//!
//! The figures follow the paper (Stein & Chirikjian, DETC2000/MECH-14115, sections 3.3, 4.1):
//! - [`CommutationPlot`] (Figure 5): stator coils '+' and rotor magnets '*' of the bottom
//!   hemisphere projected on the X-Y plane, candidate pairs joined by lines, chosen pairs boxed;
//! - [`View3d`] (Figure 6): a 3-D view of the ball with its magnets, the coils, the active pairs
//!   and the actual and desired rotation axes, under one fixed projection;
//! - [`AxisErrorPlot`] (Figures 7/8): cumulative axis error against rotation angle, one line per
//!   scheme, with an optional horizontal reference line (the paper's bound);
//! - [`SweepMap`]: a value (e.g. the worst axis error of a 90 degree move) for each axis of a
//!   sweep, drawn on an equirectangular longitude/latitude map of the sphere of axes.
//!
//! The figures take plain data (no planner types), implement [`Figure`], and are written with
//! [`write_figure`] (atomically: temporary file, then rename) or rendered to an SVG string with
//! [`render_svg`]. [`plot_csv`] draws the figure that suits an existing result CSV (a plan or a
//! sweep), for `spherestep plot`. Indices are 0-based, angles in degrees.

use crate::error::{Error, Result};
use crate::io::planfile;
use crate::io::table::Table;
use crate::model::geometry::Pair;
use crate::planning::plan::PlanRow;
use plotters::coord::{CoordTranslate, Shift};
use plotters::prelude::*;
use plotters::style::text_anchor::{HPos, Pos, VPos};
use plotters::style::{FontStyle, RGBColor};
use std::fmt;
use std::path::{Path, PathBuf};
use std::sync::OnceLock;

/// The bundled font (DejaVu Sans; license in `assets/fonts/LICENSE-DejaVu.txt`).
const FONT_BYTES: &[u8] = include_bytes!("../../assets/fonts/DejaVuSans.ttf");
/// The family name every text style of this module uses: the bundled font by name (so an SVG
/// viewer that has it shows the same text as the PNG), then a generic fallback.
const FONT: &str = "DejaVu Sans, sans-serif";

const COIL_COLOR: RGBColor = RGBColor(31, 119, 180);
const MAGNET_COLOR: RGBColor = RGBColor(200, 30, 30);
const MAGNET_BACK_COLOR: RGBColor = RGBColor(235, 170, 170);
const CANDIDATE_COLOR: RGBColor = RGBColor(150, 150, 150);
const CHOSEN_COLOR: RGBColor = RGBColor(0, 0, 0);
const ACTIVE_COLOR: RGBColor = RGBColor(30, 150, 60);
const DESIRED_COLOR: RGBColor = RGBColor(0, 0, 0);
const ACTUAL_COLOR: RGBColor = RGBColor(230, 120, 0);
const GUIDE_COLOR: RGBColor = RGBColor(205, 205, 205);
const REFERENCE_COLOR: RGBColor = RGBColor(120, 120, 120);
const TARGET_COLOR: RGBColor = RGBColor(90, 90, 90);
const NO_RESULT_COLOR: RGBColor = RGBColor(128, 128, 128);
const UNREACHED_COLOR: RGBColor = RGBColor(0, 0, 0);
/// Colours of the schemes of an [`AxisErrorPlot`], in order (then repeated): the Okabe-Ito
/// palette, told apart with any colour vision (its yellow left out: too pale on white).
pub const SERIES_COLORS: [RGBColor; 7] = [
    RGBColor(0, 114, 178),
    RGBColor(213, 94, 0),
    RGBColor(0, 158, 115),
    RGBColor(204, 121, 167),
    RGBColor(230, 159, 0),
    RGBColor(86, 180, 233),
    RGBColor(0, 0, 0),
];

/// The marker of a series of an [`AxisErrorPlot`] (drawn hollow).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Marker {
    Circle,
    Square,
    Triangle,
    Diamond,
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

/// How series `k` of an [`AxisErrorPlot`] is drawn: colour, marker and dash each differ from
/// those of every other of the first seven series.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SeriesStyle {
    pub color: RGBColor,
    pub marker: Marker,
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
fn marker_path(m: Marker, r: i32) -> Vec<(i32, i32)> {
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
fn dash_path(dash: (u32, u32)) -> [Vec<(i32, i32)>; 4] {
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
/// Stops of the colour scale of a [`SweepMap`] (viridis, low to high).
const SCALE: [(u8, u8, u8); 5] = [
    (68, 1, 84),
    (59, 82, 139),
    (33, 145, 140),
    (94, 201, 98),
    (253, 231, 37),
];

/// A drawing failure (the backend's error, or data a figure cannot show), as a message.
#[derive(Debug, Clone, PartialEq)]
pub struct DrawError(pub String);

impl fmt::Display for DrawError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(&self.0)
    }
}

impl<E: std::error::Error + Send + Sync> From<DrawingAreaErrorKind<E>> for DrawError {
    fn from(e: DrawingAreaErrorKind<E>) -> Self {
        DrawError(e.to_string())
    }
}

type DrawResult = std::result::Result<(), DrawError>;

/// A picture that can be drawn on any plotters backend.
pub trait Figure {
    /// Width and height in pixels (of the PNG; the SVG's view box).
    fn size(&self) -> (u32, u32);
    /// Draws the figure on `root` (already filled white).
    fn draw<DB: DrawingBackend>(&self, root: &DrawingArea<DB, Shift>) -> DrawResult;
}

/// Figure 5: the commutation state projected on the X-Y plane.
#[derive(Debug, Clone, PartialEq)]
pub struct CommutationPlot {
    pub title: String,
    /// Stator coil i at `coils[i]`: world (x, y).
    pub coils: Vec<[f64; 2]>,
    /// Rotor magnets shown (those with world z < 0): (magnet index, world (x, y)).
    pub magnets: Vec<(usize, [f64; 2])>,
    /// Candidate pairs, joined by thin lines.
    pub candidates: Vec<Pair>,
    /// Chosen pairs, joined by thick lines and boxed.
    pub chosen: Vec<Pair>,
}

/// Figure 6: a 3-D view of the rotor, the stator coils and the rotation axes.
#[derive(Debug, Clone, PartialEq)]
pub struct View3d {
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

/// One line of an [`AxisErrorPlot`]: a scheme's (cum_angle_deg, cum_axis_error_deg) points.
#[derive(Debug, Clone, PartialEq)]
pub struct ErrorSeries {
    pub name: String,
    pub points: Vec<(f64, f64)>,
}

/// A horizontal reference line, e.g. the paper's bound (3 deg about Z, 15 deg about Y).
#[derive(Debug, Clone, PartialEq)]
pub struct ReferenceLine {
    pub label: String,
    pub value_deg: f64,
}

/// Figures 7/8: cumulative axis error (deg) against cumulative rotation angle (deg), one series
/// per scheme: a mark at each step (the motion is discrete), thin lines joining them, each
/// series in its own colour, marker and dash ([`series_style`]); markers shrink from the first
/// series to the last, so identical series stay visible one inside the other.
#[derive(Debug, Clone, PartialEq)]
pub struct AxisErrorPlot {
    pub title: String,
    pub series: Vec<ErrorSeries>,
    pub reference: Option<ReferenceLine>,
    /// The target rotation angle (deg), marked by a vertical line.
    pub target_deg: Option<f64>,
}

/// A value over the sphere of axes, drawn on a longitude/latitude map with a colour bar.
/// Longitude = atan2(y, x), latitude = asin(z), in degrees. Non-finite values are drawn as grey
/// rings ("no result").
#[derive(Debug, Clone, PartialEq)]
pub struct SweepMap {
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

fn font_registered() -> bool {
    static REGISTERED: OnceLock<bool> = OnceLock::new();
    *REGISTERED
        .get_or_init(|| plotters::style::register_font(FONT, FontStyle::Normal, FONT_BYTES).is_ok())
}

fn ensure_font() -> DrawResult {
    if font_registered() {
        Ok(())
    } else {
        Err(DrawError(
            "the bundled font assets/fonts/DejaVuSans.ttf could not be loaded".into(),
        ))
    }
}

/// The text style of a given size. Sizes are even: plotters' ab_glyph renderer rounds half a
/// size, and an odd size puts some glyphs (the decimal point) one pixel off the baseline.
fn text(size: u32) -> TextStyle<'static> {
    (FONT, size & !1).into_font().color(&BLACK)
}

/// A tick label: `decimals` places, and no "-0".
fn tick(v: f64, decimals: usize) -> String {
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
fn tick_decimals(span: f64) -> usize {
    if span >= 8.0 {
        0
    } else if span >= 0.8 {
        1
    } else {
        2
    }
}

fn plot_err(path: &Path, e: DrawError) -> Error {
    Error::Plot {
        path: path.to_path_buf(),
        message: e.0,
    }
}

/// Renders a figure to an SVG document.
pub fn render_svg<F: Figure>(fig: &F) -> std::result::Result<String, DrawError> {
    ensure_font()?;
    let mut s = String::new();
    {
        let root = SVGBackend::with_string(&mut s, fig.size()).into_drawing_area();
        root.fill(&WHITE)?;
        fig.draw(&root)?;
        root.present()?;
    }
    Ok(s)
}

fn write_png<F: Figure>(fig: &F, path: &Path) -> Result<()> {
    crate::io::output::write_via_temp(path, |tmp| {
        (|| -> DrawResult {
            let root = BitMapBackend::new(tmp, fig.size()).into_drawing_area();
            root.fill(&WHITE)?;
            fig.draw(&root)?;
            root.present()?;
            Ok(())
        })()
        .map_err(|e| plot_err(path, e))
    })
}

/// Writes `stem.svg` and `stem.png` (each to a temporary file first, then renamed, so no
/// half-written picture is left behind). Returns the two paths written.
pub fn write_figure<F: Figure>(fig: &F, stem: &Path) -> Result<Vec<PathBuf>> {
    let svg_path = with_ext(stem, "svg");
    let png_path = with_ext(stem, "png");
    let svg = render_svg(fig).map_err(|e| plot_err(&svg_path, e))?;
    crate::io::output::write_atomic(&svg_path, svg.as_bytes())?;
    write_png(fig, &png_path)?;
    Ok(vec![svg_path, png_path])
}

/// `stem` with `.ext` appended (not replacing: a stem may contain dots).
fn with_ext(stem: &Path, ext: &str) -> PathBuf {
    let mut s = stem.as_os_str().to_owned();
    s.push(".");
    s.push(ext);
    PathBuf::from(s)
}

fn finite2(p: &[f64; 2]) -> bool {
    p.iter().all(|v| v.is_finite())
}

fn finite3(p: &[f64; 3]) -> bool {
    p.iter().all(|v| v.is_finite())
}

fn normalise(v: &[f64; 3]) -> Option<[f64; 3]> {
    let n = (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt();
    (finite3(v) && n > 1e-12).then(|| [v[0] / n, v[1] / n, v[2] / n])
}

/// Pixel size of the plotting area a chart will get on `area` with the given label areas.
fn plot_dims<DB: DrawingBackend>(
    area: &DrawingArea<DB, Shift>,
    left: u32,
    bottom: u32,
) -> (f64, f64) {
    let (w, h) = area.dim_in_pixel();
    (
        (w.saturating_sub(left)).max(1) as f64,
        (h.saturating_sub(bottom)).max(1) as f64,
    )
}

/// The strokes of a '*' of half-size `r` pixels (a rotor magnet), in pixel offsets.
fn star_strokes(r: i32) -> [Vec<(i32, i32)>; 3] {
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
        EmptyElement::at($at)
            + PathElement::new(vec![(-r, 0), (r, 0)], style)
            + PathElement::new(vec![(0, -r), (0, r)], style)
    }};
}

/// A '*' marker (a rotor magnet) of half-size `$r` pixels at `$at`: three strokes.
macro_rules! star {
    ($at:expr, $r:expr, $style:expr) => {{
        let ([a, b, c], style) = (star_strokes($r), $style);
        EmptyElement::at($at)
            + PathElement::new(a, style)
            + PathElement::new(b, style)
            + PathElement::new(c, style)
    }};
}

impl CommutationPlot {
    fn check(&self) -> DrawResult {
        if let Some(p) = self.coils.iter().find(|p| !finite2(p)) {
            return Err(DrawError(format!(
                "Figure 5: expected finite coil coordinates, got {p:?}"
            )));
        }
        if let Some((j, p)) = self.magnets.iter().find(|(_, p)| !finite2(p)) {
            return Err(DrawError(format!(
                "Figure 5: expected finite coordinates for magnet {j}, got {p:?}"
            )));
        }
        for (what, pairs) in [("candidate", &self.candidates), ("chosen", &self.chosen)] {
            for p in pairs.iter() {
                if p.coil.0 >= self.coils.len() {
                    return Err(DrawError(format!(
                        "Figure 5: {what} pair {p}: expected a coil below {}",
                        self.coils.len()
                    )));
                }
                if !self.magnets.iter().any(|(j, _)| *j == p.magnet.0) {
                    return Err(DrawError(format!(
                        "Figure 5: {what} pair {p}: magnet {} is not among the magnets shown",
                        p.magnet.0
                    )));
                }
            }
        }
        Ok(())
    }

    fn magnet_xy(&self, j: usize) -> (f64, f64) {
        self.magnets
            .iter()
            .find(|(k, _)| *k == j)
            .map(|(_, p)| (p[0], p[1]))
            .unwrap_or((0.0, 0.0))
    }
}

impl Figure for CommutationPlot {
    fn size(&self) -> (u32, u32) {
        (820, 880)
    }

    fn draw<DB: DrawingBackend>(&self, root: &DrawingArea<DB, Shift>) -> DrawResult {
        self.check()?;
        let area = root
            .margin(8, 0, 0, 0)
            .titled(&self.title, text(24))?
            .margin(5, 15, 15, 15);
        let (left, bottom) = (60, 50);
        let (pw, ph) = plot_dims(&area, left, bottom);
        // Equal scales on both axes: the unit circle stays a circle.
        let r = self
            .coils
            .iter()
            .chain(self.magnets.iter().map(|(_, p)| p))
            .flat_map(|p| [p[0].abs(), p[1].abs()])
            .fold(1.0f64, f64::max)
            * 1.08;
        let (rx, ry) = if pw >= ph {
            (r * pw / ph, r)
        } else {
            (r, r * ph / pw)
        };
        let mut chart = ChartBuilder::on(&area)
            .x_label_area_size(bottom)
            .y_label_area_size(left)
            .build_cartesian_2d(-rx..rx, -ry..ry)?;
        chart
            .configure_mesh()
            .disable_mesh()
            .x_label_formatter(&|v| tick(*v, 1))
            .y_label_formatter(&|v| tick(*v, 1))
            .x_desc("world x (seen from +Z, above the ball, through it)")
            .y_desc("world y")
            .label_style(text(16))
            .axis_desc_style(text(18))
            .draw()?;
        // The ball's outline (its equator).
        chart.draw_series(std::iter::once(PathElement::new(
            (0..=180)
                .map(|k| {
                    let a = k as f64 * std::f64::consts::TAU / 180.0;
                    (a.cos(), a.sin())
                })
                .collect::<Vec<_>>(),
            GUIDE_COLOR.stroke_width(1),
        )))?;
        chart
            .draw_series(self.candidates.iter().map(|p| {
                let c = self.coils[p.coil.0];
                PathElement::new(
                    vec![(c[0], c[1]), self.magnet_xy(p.magnet.0)],
                    CANDIDATE_COLOR.stroke_width(1),
                )
            }))?
            .label("candidate pair")
            .legend(|(x, y)| {
                PathElement::new(vec![(x, y), (x + 20, y)], CANDIDATE_COLOR.stroke_width(1))
            });
        chart
            .draw_series(self.chosen.iter().map(|p| {
                let c = self.coils[p.coil.0];
                PathElement::new(
                    vec![(c[0], c[1]), self.magnet_xy(p.magnet.0)],
                    CHOSEN_COLOR.stroke_width(2),
                )
            }))?
            .label("chosen pair (boxed)")
            .legend(|(x, y)| {
                EmptyElement::at((x, y))
                    + PathElement::new(vec![(0, 0), (20, 0)], CHOSEN_COLOR.stroke_width(2))
                    + Rectangle::new([(14, -6), (26, 6)], CHOSEN_COLOR.stroke_width(1))
            });
        let boxed = self.chosen.iter().flat_map(|p| {
            let c = self.coils[p.coil.0];
            [(c[0], c[1]), self.magnet_xy(p.magnet.0)]
        });
        chart.draw_series(boxed.map(|at| {
            EmptyElement::at(at) + Rectangle::new([(-9, -9), (9, 9)], CHOSEN_COLOR.stroke_width(1))
        }))?;
        let label = text(LABEL_SIZE);
        chart
            .draw_series(
                self.coils
                    .iter()
                    .map(|c| plus!((c[0], c[1]), 7, COIL_COLOR.stroke_width(2))),
            )?
            .label("stator coil (+)")
            .legend(|(x, y)| plus!((x + 10, y), 7, COIL_COLOR.stroke_width(2)));
        chart
            .draw_series(
                self.magnets
                    .iter()
                    .map(|(_, p)| star!((p[0], p[1]), 6, MAGNET_COLOR.stroke_width(1))),
            )?
            .label("rotor magnet, z < 0 (*)")
            .legend(|(x, y)| star!((x + 10, y), 6, MAGNET_COLOR.stroke_width(1)));
        // Coil labels first, then the magnets', each where it meets no label and no mark.
        let labels: Vec<(String, (f64, f64), RGBColor)> = self
            .coils
            .iter()
            .enumerate()
            .map(|(i, c)| (i.to_string(), (c[0], c[1]), COIL_COLOR))
            .chain(
                self.magnets
                    .iter()
                    .map(|(j, p)| (j.to_string(), (p[0], p[1]), MAGNET_COLOR)),
            )
            .collect();
        let at: Vec<(i32, i32)> = labels.iter().map(|l| chart.backend_coord(&l.1)).collect();
        let chosen_at: Vec<(i32, i32)> = self
            .chosen
            .iter()
            .flat_map(|p| {
                let c = self.coils[p.coil.0];
                [(c[0], c[1]), self.magnet_xy(p.magnet.0)]
            })
            .map(|q| chart.backend_coord(&q))
            .collect();
        let marks: Vec<((i32, i32), i32)> = at
            .iter()
            .map(|p| (*p, 7))
            .chain(chosen_at.iter().map(|p| (*p, 10)))
            .collect();
        let sizes: Vec<(i32, i32)> = labels
            .iter()
            .map(|l| label_size(&l.0, LABEL_SIZE))
            .collect();
        let offsets = place_labels(&at, &sizes, &marks);
        chart.draw_series(labels.iter().zip(offsets).map(|((t, xy, color), off)| {
            EmptyElement::at(*xy)
                + Text::new(
                    t.clone(),
                    off,
                    label.color(color).pos(Pos::new(HPos::Left, VPos::Top)),
                )
        }))?;
        chart
            .configure_series_labels()
            .position(SeriesLabelPosition::UpperRight)
            .label_font(text(14))
            .background_style(WHITE.mix(0.85))
            .border_style(BLACK)
            .draw()?;
        Ok(())
    }
}

/// World (x, y, z) to the 3-D chart's (x, y, z): plotters draws its y axis upwards and its frame
/// is right-handed, so world z goes to the chart's y and world y to the chart's -z.
fn to_chart(p: [f64; 3]) -> (f64, f64, f64) {
    (p[0], p[2], -p[1])
}

fn scaled(p: [f64; 3], s: f64) -> [f64; 3] {
    [p[0] * s, p[1] * s, p[2] * s]
}

/// The fixed view of Figure 6: from a little below the equator (the stator cap is at the
/// bottom), turned about the vertical.
const VIEW_YAW: f64 = 0.6;
const VIEW_PITCH: f64 = -0.5;
const COIL_RADIUS: f64 = 1.1;
const AXIS_LENGTH: f64 = 1.45;

impl View3d {
    fn check(&self) -> DrawResult {
        if let Some(p) = self.coils.iter().find(|p| !finite3(p)) {
            return Err(DrawError(format!(
                "Figure 6: expected finite coil coordinates, got {p:?}"
            )));
        }
        if let Some((j, p)) = self.magnets.iter().find(|(_, p)| !finite3(p)) {
            return Err(DrawError(format!(
                "Figure 6: expected finite coordinates for magnet {j}, got {p:?}"
            )));
        }
        for p in &self.active {
            if p.coil.0 >= self.coils.len() || !self.magnets.iter().any(|(j, _)| *j == p.magnet.0) {
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
}

impl Figure for View3d {
    fn size(&self) -> (u32, u32) {
        (880, 860)
    }

    fn draw<DB: DrawingBackend>(&self, root: &DrawingArea<DB, Shift>) -> DrawResult {
        self.check()?;
        let area = root
            .margin(8, 0, 0, 0)
            .titled(&self.title, text(24))?
            .margin(0, 10, 10, 10);
        let lim = 1.6;
        let mut chart =
            ChartBuilder::on(&area).build_cartesian_3d(-lim..lim, -lim..lim, -lim..lim)?;
        chart.with_projection(|mut pb| {
            pb.yaw = VIEW_YAW;
            pb.pitch = VIEW_PITCH;
            pb.scale = 1.45;
            pb.into_matrix()
        });
        let spec = chart.as_coord_spec().clone();
        let centre_depth = spec.projected_depth(&0.0, &0.0, &0.0);
        let front = |p: [f64; 3]| {
            let (x, y, z) = to_chart(p);
            spec.projected_depth(&x, &y, &z) <= centre_depth
        };
        // The ball: latitude circles and meridians.
        let circle = |f: &dyn Fn(f64) -> [f64; 3]| -> Vec<(f64, f64, f64)> {
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
        // Labels are placed last, all together, where they meet no other label and no mark:
        // (text, point, size, colour), the arrows' first.
        let mut labels: Vec<Label3d> = Vec::new();
        // World axes, labelled beside their tips (a rotation axis may lie along one).
        for (name, v) in [
            ("x", [1.0, 0.0, 0.0]),
            ("y", [0.0, 1.0, 0.0]),
            ("z", [0.0, 0.0, 1.0]),
        ] {
            chart.draw_series(std::iter::once(PathElement::new(
                vec![to_chart([0.0; 3]), to_chart(scaled(v, 1.3))],
                REFERENCE_COLOR.stroke_width(1),
            )))?;
            labels.push((
                format!("world {name}"),
                to_chart(scaled(v, 1.3)),
                16,
                REFERENCE_COLOR,
            ));
        }
        // Magnets behind the ball first (faded), then the active pairs, then those in front.
        let back: Vec<_> = self.magnets.iter().filter(|(_, p)| !front(*p)).collect();
        let fore: Vec<_> = self.magnets.iter().filter(|(_, p)| front(*p)).collect();
        chart.draw_series(
            back.iter()
                .map(|(_, p)| Circle::new(to_chart(*p), 4, MAGNET_BACK_COLOR.filled())),
        )?;
        let magnet = |j: usize| {
            self.magnets
                .iter()
                .find(|(k, _)| *k == j)
                .map(|(_, p)| *p)
                .unwrap_or([0.0; 3])
        };
        chart
            .draw_series(self.active.iter().map(|p| {
                PathElement::new(
                    vec![
                        to_chart(scaled(self.coils[p.coil.0], COIL_RADIUS)),
                        to_chart(magnet(p.magnet.0)),
                    ],
                    ACTIVE_COLOR.stroke_width(3),
                )
            }))?
            .label("active pair")
            .legend(|(x, y)| {
                PathElement::new(vec![(x, y), (x + 20, y)], ACTIVE_COLOR.stroke_width(3))
            });
        chart
            .draw_series(
                fore.iter()
                    .map(|(_, p)| Circle::new(to_chart(*p), 4, MAGNET_COLOR.filled())),
            )?
            .label("rotor magnet (faded: far side)")
            .legend(|(x, y)| Circle::new((x + 10, y), 4, MAGNET_COLOR.filled()));
        chart
            .draw_series(self.coils.iter().map(|c| {
                plus!(
                    to_chart(scaled(*c, COIL_RADIUS)),
                    6,
                    COIL_COLOR.stroke_width(2)
                )
            }))?
            .label("stator coil (+)")
            .legend(|(x, y)| plus!((x + 10, y), 6, COIL_COLOR.stroke_width(2)));
        let coil_labels = self.coils.iter().enumerate().map(|(i, c)| {
            (
                i.to_string(),
                to_chart(scaled(*c, COIL_RADIUS)),
                LABEL_SIZE,
                COIL_COLOR,
            )
        });
        labels.extend(coil_labels);
        // The axes as arrows from the centre; the heads are drawn in pixels along the
        // projected direction.
        let mut arrows = vec![(
            "desired axis",
            normalise(&self.desired_axis).unwrap_or([0.0, 0.0, 1.0]),
            DESIRED_COLOR,
        )];
        if let Some(a) = self.actual_axis.as_ref().and_then(normalise) {
            arrows.push(("actual axis", a, ACTUAL_COLOR));
        }
        let n_arrows = arrows.len();
        for (k, (name, n, color)) in arrows.into_iter().enumerate() {
            let tip = to_chart(scaled(n, AXIS_LENGTH));
            let (x0, y0) = spec.translate(&to_chart([0.0; 3]));
            let (x1, y1) = spec.translate(&tip);
            let (dx, dy) = ((x1 - x0) as f64, (y1 - y0) as f64);
            let len = dx.hypot(dy);
            let head = if len > 1.0 {
                let (ux, uy) = (dx / len, dy / len);
                let (hl, hw) = (16.0, 7.0);
                let pt = |a: f64| {
                    (
                        (-ux * hl + a * uy * hw).round() as i32,
                        (-uy * hl - a * ux * hw).round() as i32,
                    )
                };
                vec![pt(1.0), (0, 0), pt(-1.0)]
            } else {
                Vec::new()
            };
            let style = color.stroke_width(3);
            labels.insert(k, (name.to_string(), tip, 16, color));
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
        }
        let at: Vec<(i32, i32)> = labels.iter().map(|l| spec.translate(&l.1)).collect();
        let sizes: Vec<(i32, i32)> = labels.iter().map(|l| label_size(&l.0, l.2)).collect();
        let marks: Vec<((i32, i32), i32)> = self
            .coils
            .iter()
            .map(|c| (spec.translate(&to_chart(scaled(*c, COIL_RADIUS))), 7))
            .chain(at.iter().take(n_arrows).map(|p| (*p, 9)))
            .collect();
        let offsets = place_labels(&at, &sizes, &marks);
        chart.draw_series(
            labels
                .iter()
                .zip(offsets)
                .map(|((t, p, size, color), off)| {
                    EmptyElement::at(*p)
                        + Text::new(
                            t.clone(),
                            off,
                            text(*size)
                                .color(color)
                                .pos(Pos::new(HPos::Left, VPos::Top)),
                        )
                }),
        )?;
        chart
            .configure_series_labels()
            .position(SeriesLabelPosition::UpperLeft)
            .label_font(text(14))
            .background_style(WHITE.mix(0.85))
            .border_style(BLACK)
            .draw()?;
        Ok(())
    }
}

/// A label of [`View3d`]: text, chart point, font size, colour.
type Label3d = (String, (f64, f64, f64), u32, RGBColor);

/// The font size of point labels (coil and magnet numbers).
const LABEL_SIZE: u32 = 12;

/// The box (width, height) in pixels that `text` takes at font size `size` (DejaVu Sans: digits
/// are 0.64 em wide; a little generous for letters).
pub fn label_size(text: &str, size: u32) -> (i32, i32) {
    let w = (0.64 * size as f64 * text.chars().count() as f64).ceil() as i32;
    (w, size as i32)
}

/// Where labels go: top-left offsets (pixels, from each label's point at `at`) for boxes of
/// `sizes`, chosen in turn as the first of eight places around the point (then the same
/// further out) whose box meets neither a label placed before nor a mark (`marks`: centre and
/// half-size of each drawn symbol); where every place is taken, the least crowded one.
pub fn place_labels(
    at: &[(i32, i32)],
    sizes: &[(i32, i32)],
    marks: &[((i32, i32), i32)],
) -> Vec<(i32, i32)> {
    type Box2 = (i32, i32, i32, i32);
    let overlap = |a: &Box2, b: &Box2| -> i64 {
        let w = (a.2.min(b.2) - a.0.max(b.0)).max(0) as i64;
        let h = (a.3.min(b.3) - a.1.max(b.1)).max(0) as i64;
        w * h
    };
    let mark_boxes: Vec<Box2> = marks
        .iter()
        .map(|((x, y), r)| (x - r, y - r, x + r, y + r))
        .collect();
    let mut placed: Vec<Box2> = Vec::new();
    let mut out = Vec::new();
    for (&(x, y), &(w, h)) in at.iter().zip(sizes) {
        let mut best: Option<(i64, (i32, i32), Box2)> = None;
        for g in [9, 16, 26] {
            let places = [
                (g, -h / 2),
                (g, -h - 2),
                (g, 2),
                (-w / 2, -h - g),
                (-w / 2, g),
                (-w - g, -h / 2),
                (-w - g, -h - 2),
                (-w - g, 2),
            ];
            for (dx, dy) in places {
                let b = (x + dx, y + dy, x + dx + w, y + dy + h);
                let cost: i64 = placed
                    .iter()
                    .chain(&mark_boxes)
                    .map(|o| overlap(&b, o))
                    .sum();
                if best.as_ref().is_none_or(|(c, _, _)| cost < *c) {
                    best = Some((cost, (dx, dy), b));
                }
                if cost == 0 {
                    break;
                }
            }
            if best.as_ref().is_some_and(|(c, _, _)| *c == 0) {
                break;
            }
        }
        let (_, off, b) = best.unwrap_or((0, (9, -h / 2), (x, y, x + w, y + h)));
        placed.push(b);
        out.push(off);
    }
    out
}

/// Rounds a range outwards to a "nice" one starting at `lo` (callers pass 0 or a negative
/// minimum).
fn nice_max(v: f64) -> f64 {
    if v <= 0.0 || !v.is_finite() {
        return 1.0;
    }
    let mag = 10f64.powf(v.log10().floor());
    for m in [1.0, 1.2, 1.5, 2.0, 2.5, 3.0, 4.0, 5.0, 6.0, 8.0, 9.0, 10.0] {
        if m * mag >= v {
            return m * mag;
        }
    }
    10.0 * mag
}

impl AxisErrorPlot {
    fn min_error(&self) -> f64 {
        self.series
            .iter()
            .flat_map(|s| s.points.iter())
            .map(|p| p.1)
            .fold(0.0f64, f64::min)
    }

    /// The axis error range drawn: from 0 (or the negative minimum) up past the largest error
    /// and the reference; a zero-error series sits a little above the frame, never on it.
    pub fn y_range(&self) -> std::ops::Range<f64> {
        let emax = self
            .series
            .iter()
            .flat_map(|s| s.points.iter())
            .map(|p| p.1)
            .chain(self.reference.iter().map(|r| r.value_deg))
            .fold(0.0f64, f64::max);
        let top = nice_max(emax * 1.15);
        let emin = self.min_error();
        let bottom = if emin < 0.0 { -nice_max(-emin) } else { 0.0 };
        (bottom - 0.03 * (top - bottom))..top
    }

    fn check(&self) -> DrawResult {
        for s in &self.series {
            if let Some(p) = s
                .points
                .iter()
                .find(|(a, e)| !a.is_finite() || !e.is_finite())
            {
                return Err(DrawError(format!(
                    "axis error plot: series `{}`: expected finite points, got {p:?}",
                    s.name
                )));
            }
        }
        if let Some(r) = &self.reference {
            if !r.value_deg.is_finite() {
                return Err(DrawError(format!(
                    "axis error plot: reference `{}`: expected a finite value",
                    r.label
                )));
            }
        }
        Ok(())
    }
}

impl Figure for AxisErrorPlot {
    fn size(&self) -> (u32, u32) {
        (900, 600)
    }

    fn draw<DB: DrawingBackend>(&self, root: &DrawingArea<DB, Shift>) -> DrawResult {
        self.check()?;
        let pts = || self.series.iter().flat_map(|s| s.points.iter());
        let (amin, amax) = pts().fold((0.0f64, 0.0f64), |(lo, hi), p| (lo.min(p.0), hi.max(p.0)));
        let amax = amax.max(self.target_deg.unwrap_or(0.0) * 1.05);
        let xs = (if amin < 0.0 { -nice_max(-amin) } else { 0.0 })..nice_max(amax);
        let ys = self.y_range();
        // Below zero is only the margin that lifts a zero series off the frame: no ticks there.
        let no_negative = self.min_error() >= 0.0;
        let area = root.margin(10, 25, 10, 10);
        let mut chart = ChartBuilder::on(&area)
            .caption(&self.title, text(24))
            .x_label_area_size(55)
            .y_label_area_size(70)
            .build_cartesian_2d(xs, ys)?;
        let (xd, yd) = (
            tick_decimals(chart.x_range().end - chart.x_range().start),
            tick_decimals(chart.y_range().end - chart.y_range().start),
        );
        chart
            .configure_mesh()
            .x_label_formatter(&|v| tick(*v, xd))
            .y_label_formatter(&|v| {
                if no_negative && *v < 0.0 {
                    String::new()
                } else {
                    tick(*v, yd)
                }
            })
            .x_desc("cumulative rotation angle (deg)")
            .y_desc("cumulative axis error (deg)")
            .label_style(text(16))
            .axis_desc_style(text(18))
            .light_line_style(RGBColor(238, 238, 238))
            .bold_line_style(RGBColor(215, 215, 215))
            .draw()?;
        if let Some(r) = &self.reference {
            let (x0, x1) = (chart.x_range().start, chart.x_range().end);
            let style = REFERENCE_COLOR.stroke_width(2);
            chart
                .draw_series(DashedLineSeries::new(
                    vec![(x0, r.value_deg), (x1, r.value_deg)],
                    10,
                    6,
                    style,
                ))?
                .label(r.label.clone())
                .legend(move |(x, y)| {
                    EmptyElement::at((x, y))
                        + PathElement::new(vec![(0, 0), (8, 0)], style)
                        + PathElement::new(vec![(12, 0), (20, 0)], style)
                });
        }
        if let Some(t) = self.target_deg {
            let (y0, y1) = (chart.y_range().start, chart.y_range().end);
            let style = TARGET_COLOR.stroke_width(1);
            chart.draw_series(DashedLineSeries::new(vec![(t, y0), (t, y1)], 6, 4, style))?;
            chart.draw_series(std::iter::once(Text::new(
                format!(
                    "target {} deg",
                    tick(t, if t.fract() == 0.0 { 0 } else { 1 })
                ),
                (t, y1),
                text(14)
                    .color(&TARGET_COLOR)
                    .pos(Pos::new(HPos::Right, VPos::Top)),
            )))?;
        }
        let n = self.series.len() as i32;
        for (k, s) in self.series.iter().enumerate() {
            let st = series_style(k);
            let line = st.color.stroke_width(1);
            let pts = s.points.iter().copied();
            if st.dash.0 == 0 {
                chart.draw_series(LineSeries::new(pts, line))?;
            } else {
                chart.draw_series(DashedLineSeries::new(pts, st.dash.0, st.dash.1, line))?;
            }
            let r = 3 + 2 * (n - 1 - k as i32).clamp(0, 4);
            let mark = st.color.stroke_width(2);
            chart
                .draw_series(s.points.iter().map(|p| {
                    EmptyElement::at(*p) + PathElement::new(marker_path(st.marker, r), mark)
                }))?
                .label(s.name.clone())
                .legend(move |(x, y)| {
                    let [a, b, c, d] = dash_path(st.dash);
                    EmptyElement::at((x, y))
                        + PathElement::new(a, line)
                        + PathElement::new(b, line)
                        + PathElement::new(c, line)
                        + PathElement::new(d, line)
                        + PathElement::new(
                            marker_path(st.marker, 4)
                                .into_iter()
                                .map(|(u, v)| (u + 12, v))
                                .collect::<Vec<_>>(),
                            mark,
                        )
                });
        }
        chart
            .configure_series_labels()
            .position(SeriesLabelPosition::UpperLeft)
            .label_font(text(16))
            .background_style(WHITE.mix(0.9))
            .border_style(BLACK)
            .draw()?;
        Ok(())
    }
}

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

/// Map coordinates (longitude / LON_UNIT, latitude / LAT_UNIT) of a non-zero axis.
fn lon_lat(v: &[f64; 3]) -> Option<(f64, f64)> {
    let n = normalise(v)?;
    Some((
        n[1].atan2(n[0]).to_degrees() / LON_UNIT,
        n[2].clamp(-1.0, 1.0).asin().to_degrees() / LAT_UNIT,
    ))
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
                "sweep map: expected values within +-1e12, got {lo} to {hi}"
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
}

/// The finite values' minimum and maximum, widened if equal ((0, 1) without any).
fn value_range(vals: impl Iterator<Item = f64>) -> (f64, f64) {
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

impl Figure for SweepMap {
    fn size(&self) -> (u32, u32) {
        (1100, 600)
    }

    fn draw<DB: DrawingBackend>(&self, root: &DrawingArea<DB, Shift>) -> DrawResult {
        self.check()?;
        let area = root
            .margin(8, 0, 0, 0)
            .titled(&self.title, text(24))?
            .margin(5, 15, 10, 10);
        let (map_area, bar_area) = area.split_horizontally(area.dim_in_pixel().0 as i32 - 140);
        let (left, bottom) = (60, 50);
        let mut chart = ChartBuilder::on(&map_area)
            .margin_right(15)
            .x_label_area_size(bottom)
            .y_label_area_size(left)
            .build_cartesian_2d(-4.0..4.0, -3.0..3.0)?;
        chart
            .configure_mesh()
            .x_labels(9)
            .y_labels(7)
            .x_label_formatter(&|v| tick(*v * LON_UNIT, 0))
            .y_label_formatter(&|v| tick(*v * LAT_UNIT, 0))
            .x_desc("axis longitude atan2(y, x) (deg)")
            .y_desc("axis latitude asin(z) (deg)")
            .label_style(text(16))
            .axis_desc_style(text(18))
            .light_line_style(TRANSPARENT)
            .bold_line_style(RGBColor(225, 225, 225))
            .draw()?;
        let (pw, _) = plot_dims(&map_area, left + 15, bottom);
        let n = self.points.len().max(1) as f64;
        // Disks about as wide as the axes' mean spacing at the equator.
        let spacing_deg = (41_253.0 / n).sqrt();
        let radius = (0.5 * spacing_deg * pw / 360.0).clamp(2.0, 14.0).round() as i32;
        let (lo, hi) = self.value_range();
        let mut finite: Vec<_> = self
            .points
            .iter()
            .filter(|p| p.1.is_finite())
            .filter_map(|(a, v)| lon_lat(a).map(|ll| (ll, *v)))
            .collect();
        // The worst on top.
        finite.sort_by(|a, b| a.1.total_cmp(&b.1));
        chart.draw_series(
            finite.iter().map(|(ll, v)| {
                Circle::new(*ll, radius, scale_color((v - lo) / (hi - lo)).filled())
            }),
        )?;
        let missing: Vec<_> = self
            .points
            .iter()
            .filter(|p| !p.1.is_finite())
            .filter_map(|(a, _)| lon_lat(a))
            .collect();
        chart.draw_series(
            missing
                .iter()
                .map(|ll| Circle::new(*ll, radius, NO_RESULT_COLOR.stroke_width(2))),
        )?;
        let unreached: Vec<_> = self.unreached.iter().filter_map(lon_lat).collect();
        let cross = (radius - 1).max(3);
        chart.draw_series(
            unreached
                .iter()
                .map(|ll| Cross::new(*ll, cross, UNREACHED_COLOR.stroke_width(2))),
        )?;
        let coils: Vec<_> = self
            .coils
            .iter()
            .flat_map(|c| [*c, [-c[0], -c[1], -c[2]]])
            .filter_map(|c| lon_lat(&c))
            .collect();
        // White under the blue, so that a '+' shows on any disk.
        for (r, style) in [(8, WHITE.stroke_width(5)), (7, COIL_COLOR.stroke_width(2))] {
            chart.draw_series(coils.iter().map(|ll| plus!(*ll, r, style)))?;
        }
        // What the marks mean, under the colour bar, where they hide no disk.
        let h = bar_area.dim_in_pixel().1 as i32;
        let keys: Vec<(&str, u8)> = [
            (!missing.is_empty(), ("no result", 0)),
            (!unreached.is_empty(), ("not reached", 1)),
            (!coils.is_empty(), ("coil axis", 2)),
        ]
        .into_iter()
        .filter_map(|(on, k)| on.then_some(k))
        .collect();
        for (row, (name, kind)) in keys.into_iter().enumerate() {
            let at = (14, h - bottom as i32 + 8 + 15 * row as i32);
            let label = Text::new(
                name,
                (12, 0),
                text(12).pos(Pos::new(HPos::Left, VPos::Center)),
            );
            match kind {
                0 => bar_area.draw(
                    &(EmptyElement::at(at)
                        + Circle::new((0, 0), 5, NO_RESULT_COLOR.stroke_width(2))
                        + label),
                )?,
                1 => bar_area.draw(
                    &(EmptyElement::at(at)
                        + Cross::new((0, 0), 4, UNREACHED_COLOR.stroke_width(2))
                        + label),
                )?,
                _ => bar_area.draw(
                    &(EmptyElement::at(at)
                        + PathElement::new(vec![(-5, 0), (5, 0)], COIL_COLOR.stroke_width(2))
                        + PathElement::new(vec![(0, -5), (0, 5)], COIL_COLOR.stroke_width(2))
                        + label),
                )?,
            }
        }
        // The colour bar, its plotting area level with the map's.
        let mut bar = ChartBuilder::on(&bar_area)
            .margin_left(5)
            .margin_right(5)
            .x_label_area_size(bottom)
            .right_y_label_area_size(70)
            .build_cartesian_2d(0.0..1.0, lo..hi)?;
        let bd = tick_decimals(hi - lo);
        bar.configure_mesh()
            .disable_mesh()
            .disable_x_axis()
            .y_labels(8)
            .y_label_formatter(&|v| tick(*v, bd))
            .y_desc(self.value_label.as_str())
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
}

/// The Figure 7-style series of a plan: its (cum_angle_deg, cum_axis_error_deg) points.
pub fn plan_series(name: &str, rows: &[PlanRow]) -> ErrorSeries {
    ErrorSeries {
        name: name.to_string(),
        points: rows
            .iter()
            .map(|r| (r.cum_angle_deg, r.cum_axis_error_deg))
            .collect(),
    }
}

/// The columns a sweep CSV must have (besides an optional `scheme`).
pub const SWEEP_COLUMNS: [&str; 4] = ["axis_x", "axis_y", "axis_z", "max_axis_error_deg"];

/// One scheme's points of a sweep CSV: (scheme, or None without a `scheme` column; points).
pub type SweepPoints = (Option<String>, Vec<([f64; 3], f64)>);

/// Reads a sweep CSV (columns [`SWEEP_COLUMNS`], optional `scheme`): the points of each scheme
/// in the order the schemes first appear. Values may be NaN ("no result"); axes must be finite
/// and non-zero.
pub fn parse_sweep(text: &str, path: &Path) -> Result<Vec<SweepPoints>> {
    parse_sweep_column(text, path, SWEEP_COLUMNS[3])
}

/// The column of a sweep CSV with the pivot model's floor per axis (see
/// [`crate::planning::commutation::pivot_floor`]).
pub const FLOOR_COLUMN: &str = "pivot_floor_deg";

/// Reads a sweep CSV like [`parse_sweep`], with the values of column `value` in place of
/// `max_axis_error_deg`.
pub fn parse_sweep_column(text: &str, path: &Path, value: &str) -> Result<Vec<SweepPoints>> {
    let t = Table::parse(text, path)?;
    let columns = [SWEEP_COLUMNS[0], SWEEP_COLUMNS[1], SWEEP_COLUMNS[2], value];
    let idx = columns
        .iter()
        .map(|c| t.require(c, ""))
        .collect::<Result<Vec<_>>>()?;
    let scheme_col = t.column("scheme");
    let mut out: Vec<SweepPoints> = Vec::new();
    for r in t.rows() {
        let num = |k: usize| r.number(idx[k], columns[k]);
        let axis = [num(0)?, num(1)?, num(2)?];
        if normalise(&axis).is_none() {
            return Err(r.error(format!(
                "columns `axis_x..axis_z`: expected a finite, non-zero axis, got {axis:?}"
            )));
        }
        let value = num(3)?;
        // An axis error is an angle: anything else (1e308, inf) would also give the colour
        // scale an infinite span, which the tick search never finishes.
        if !(value.is_nan() || (0.0..=180.0 + 1e-9).contains(&value)) {
            return Err(r.error(format!(
                "column `max_axis_error_deg`: expected an angle from 0 to 180 degrees (or NaN: no result), got {value}"
            )));
        }
        let scheme = scheme_col.map(|k| r.get(k).to_string());
        match out.iter_mut().find(|(s, _)| *s == scheme) {
            Some((_, pts)) => pts.push((axis, value)),
            None => out.push((scheme, vec![(axis, value)])),
        }
    }
    t.require_rows("sweep")?;
    Ok(out)
}

/// The axes of a sweep CSV's cases that did not reach their target (column `reached` is
/// `false`), with their scheme (or None without a `scheme` column); none without `reached`.
pub fn parse_unreached(text: &str, path: &Path) -> Result<Vec<(Option<String>, [f64; 3])>> {
    let t = Table::parse(text, path)?;
    let (Some(reached), Some(x), Some(y), Some(z)) = (
        t.column("reached"),
        t.column("axis_x"),
        t.column("axis_y"),
        t.column("axis_z"),
    ) else {
        return Ok(Vec::new());
    };
    let scheme = t.column("scheme");
    let mut out = Vec::new();
    for r in t.rows().filter(|r| r.get(reached) == "false") {
        let num = |k: usize| r.get(k).parse::<f64>().ok();
        if let (Some(a), Some(b), Some(c)) = (num(x), num(y), num(z)) {
            out.push((scheme.map(|k| r.get(k).to_string()), [a, b, c]));
        }
    }
    Ok(out)
}

/// A scheme name made safe for a file name.
fn file_safe(s: &str) -> String {
    crate::io::output::file_safe(s, "unnamed")
}

/// Draws an existing result CSV (for `spherestep plot`), recognised by its header:
/// - a plan CSV (the columns of [`planfile::HEADER`]): a Figure 7-style plot of its cumulative
///   axis error against rotation angle, written as `STEM.svg` and `STEM.png`;
/// - a sweep CSV (the columns [`SWEEP_COLUMNS`], optionally `scheme`): one map of the worst
///   axis error per scheme, `STEM_SCHEME.svg/.png` (or `STEM.svg/.png` without `scheme`).
///
/// STEM is the CSV's file stem; the pictures go to `out_dir` (created if missing), by default
/// next to the CSV. Returns the files written.
pub fn plot_csv(
    csv_path: &Path,
    out_dir: Option<&Path>,
    title: Option<&str>,
) -> Result<Vec<PathBuf>> {
    plot_csv_with_coils(csv_path, out_dir, title, &[])
}

/// [`plot_csv`], with the stator's coil directions drawn on a sweep's maps.
pub fn plot_csv_with_coils(
    csv_path: &Path,
    out_dir: Option<&Path>,
    title: Option<&str>,
    coils: &[[f64; 3]],
) -> Result<Vec<PathBuf>> {
    let text = std::fs::read_to_string(csv_path).map_err(|e| Error::io(csv_path, e))?;
    let stem = csv_path
        .file_stem()
        .map(|s| s.to_string_lossy().into_owned())
        .filter(|s| !s.is_empty())
        .unwrap_or_else(|| "plot".into());
    let dir = match out_dir {
        Some(d) => d.to_path_buf(),
        None => match csv_path.parent() {
            Some(p) if !p.as_os_str().is_empty() => p.to_path_buf(),
            _ => PathBuf::from("."),
        },
    };
    let header: Vec<String> = csv::ReaderBuilder::new()
        .has_headers(true)
        .trim(csv::Trim::All)
        .from_reader(text.as_bytes())
        .headers()
        .map(|h| h.iter().map(str::to_string).collect())
        .unwrap_or_default();
    let has = |c: &str| header.iter().any(|h| h == c);
    enum Kind {
        Plan,
        Sweep,
    }
    let kind = if planfile::HEADER.iter().all(|c| has(c)) {
        Kind::Plan
    } else if SWEEP_COLUMNS.iter().all(|c| has(c)) {
        Kind::Sweep
    } else {
        let found = if header.iter().all(|h| h.is_empty()) {
            "no columns".to_string()
        } else {
            format!("columns {}", header.join(", "))
        };
        return Err(Error::Parse {
            file: csv_path.to_path_buf(),
            message: format!(
                "not a plan or sweep CSV (found {found}); expected a plan CSV with the columns {} \
                 or a sweep CSV with the columns {} (and optionally scheme)",
                planfile::HEADER.join(", "),
                SWEEP_COLUMNS.join(", ")
            ),
        });
    };
    std::fs::create_dir_all(&dir).map_err(|e| Error::io(&dir, e))?;
    let mut written = Vec::new();
    match kind {
        Kind::Plan => {
            let rows = planfile::parse_plan(&text, csv_path)?;
            let fig = AxisErrorPlot {
                title: title
                    .map(str::to_string)
                    .unwrap_or_else(|| format!("axis error vs. rotation angle: {stem}")),
                series: vec![plan_series(&stem, &rows)],
                reference: None,
                target_deg: None,
            };
            written.extend(write_figure(&fig, &dir.join(&stem))?);
        }
        Kind::Sweep => {
            let groups = parse_sweep(&text, csv_path)?;
            let unreached = parse_unreached(&text, csv_path)?;
            // One colour scale for all the schemes' maps, so that they can be compared.
            let range = value_range(groups.iter().flat_map(|g| g.1.iter().map(|p| p.1)));
            for (scheme, points) in groups {
                let base = title
                    .map(str::to_string)
                    .unwrap_or_else(|| format!("worst axis error over the sphere of axes: {stem}"));
                let (title, file) = match &scheme {
                    Some(s) => (
                        format!("{base}, scheme {s}"),
                        format!("{stem}_{}", file_safe(s)),
                    ),
                    None => (base, stem.clone()),
                };
                let fig = SweepMap {
                    title,
                    value_label: "worst axis error (deg)".into(),
                    points,
                    range: Some(range),
                    unreached: unreached
                        .iter()
                        .filter(|u| u.0 == scheme)
                        .map(|u| u.1)
                        .collect(),
                    coils: coils.to_vec(),
                };
                written.extend(write_figure(&fig, &dir.join(file))?);
            }
            if has(FLOOR_COLUMN) {
                // the floor depends on the axis alone: one map, from the first scheme's cases
                let floor = parse_sweep_column(&text, csv_path, FLOOR_COLUMN)?;
                if let Some((_, points)) = floor.into_iter().next() {
                    let fig = SweepMap {
                        title: format!(
                            "pivot model's floor (nearest coil axis line) over the sphere of \
                             axes: {stem}"
                        ),
                        value_label: "floor of the worst axis error (deg)".into(),
                        points,
                        range: Some(range),
                        unreached: Vec::new(),
                        coils: coils.to_vec(),
                    };
                    written.extend(write_figure(
                        &fig,
                        &dir.join(format!("{stem}_pivot-floor")),
                    )?);
                }
            }
        }
    }
    Ok(written)
}
