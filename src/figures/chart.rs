//! The steps of drawing a chart that the figures share: the area under a title, the size of a
//! chart's plotting area, the labelled axes of a 2-D chart, the legend box and the legend's
//! line sample.

use crate::figures::figure::DrawError;
use crate::figures::style::text;
use plotters::chart::{MeshStyle, SeriesLabelPosition};
use plotters::coord::ranged1d::ValueFormatter;
use plotters::coord::types::RangedCoordf64;
use plotters::coord::{CoordTranslate, Shift};
use plotters::prelude::*;
use plotters::style::ShapeStyle;

/// A 2-D chart with real axes (every 2-D figure's).
pub(crate) type Chart2d<'a, DB> = ChartContext<'a, DB, Cartesian2d<RangedCoordf64, RangedCoordf64>>;

/// The area under a figure's title: the title (24 px) 8 pixels below the top, then margins
/// (top, right, bottom, left) in pixels.
pub(crate) fn titled<DB: DrawingBackend>(
    root: &DrawingArea<DB, Shift>,
    title: &str,
    (top, right, bottom, left): (u32, u32, u32, u32),
) -> Result<DrawingArea<DB, Shift>, DrawError> {
    Ok(root
        .margin(8, 0, 0, 0)
        .titled(title, text(24))?
        .margin(top, right, bottom, left))
}

/// Pixel size of the plotting area a chart will get on `area` with the given label areas.
pub(crate) fn plot_dims<DB: DrawingBackend>(
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

/// The axes of a 2-D chart (real axes, or whole numbers along x) with their descriptions, tick
/// labels in 16 px and descriptions in 18 px; the caller sets the rest (formatters, grid) and
/// draws.
pub(crate) fn axes<'a, 'b, DB, X, Y>(
    chart: &'b mut ChartContext<'a, DB, Cartesian2d<X, Y>>,
    x_desc: &str,
    y_desc: &str,
) -> MeshStyle<'a, 'b, X, Y, DB>
where
    DB: DrawingBackend,
    X: Ranged + ValueFormatter<X::ValueType>,
    Y: Ranged + ValueFormatter<Y::ValueType>,
{
    let mut mesh = chart.configure_mesh();
    mesh.x_desc(x_desc)
        .y_desc(y_desc)
        .label_style(text(16))
        .axis_desc_style(text(18));
    mesh
}

/// Draws the legend of the chart's labelled series at `position`: text of `font_size`, a black
/// border, a white background of the given opacity.
pub(crate) fn draw_legend<'a, DB: DrawingBackend + 'a, CT: CoordTranslate>(
    chart: &mut ChartContext<'a, DB, CT>,
    position: SeriesLabelPosition,
    font_size: u32,
    opacity: f64,
) -> Result<(), DrawError> {
    chart
        .configure_series_labels()
        .position(position)
        .label_font(text(font_size))
        .background_style(WHITE.mix(opacity))
        .border_style(BLACK)
        .draw()?;
    Ok(())
}

/// A legend's sample of a plain line: 20 pixels in `style`.
pub(crate) fn line_key(style: ShapeStyle) -> impl Fn((i32, i32)) -> PathElement<(i32, i32)> {
    move |(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], style)
}
