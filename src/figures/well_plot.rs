//! The well of a scenario (`spherestep wells`): the torque on one magnet as it passes one
//! energised coil, against the angle between them, with the well's cut-off marked.

use crate::figures::chart::{axes, titled};
use crate::figures::figure::{DrawError, DrawResult, Figure};
use crate::figures::style::{text, tick, tick_decimals, SERIES_COLORS, TARGET_COLOR};
use plotters::coord::Shift;
use plotters::prelude::*;
use plotters::style::text_anchor::{HPos, Pos, VPos};

/// A torque curve g(d) to draw.
#[derive(Debug, Clone, PartialEq)]
pub struct WellPlot {
    /// The title drawn above the plot.
    pub title: String,
    /// (angle, deg; torque, N m), by increasing angle.
    pub points: Vec<(f64, f64)>,
    /// The maximum attraction distance, deg (a dashed line), if within the curve.
    pub cutoff_deg: Option<f64>,
}

impl WellPlot {
    fn check(&self) -> DrawResult {
        if self.points.len() < 2 {
            return Err(DrawError("well plot: expected at least two points".into()));
        }
        if let Some(p) = self
            .points
            .iter()
            .find(|(a, g)| !a.is_finite() || !g.is_finite())
        {
            return Err(DrawError(format!(
                "well plot: expected finite points, got {p:?}"
            )));
        }
        Ok(())
    }

    /// The torque range drawn: from the lowest value (0 unless the curve repels) to 10% above
    /// the highest.
    fn y_range(&self) -> std::ops::Range<f64> {
        let (lo, hi) = self
            .points
            .iter()
            .fold((0.0f64, 0.0f64), |(lo, hi), p| (lo.min(p.1), hi.max(p.1)));
        let span = (hi - lo).max(1e-12);
        (lo - 0.03 * span)..(hi + 0.1 * span)
    }
}

impl Figure for WellPlot {
    fn size(&self) -> (u32, u32) {
        (900, 560)
    }

    fn draw<DB: DrawingBackend>(&self, root: &DrawingArea<DB, Shift>) -> DrawResult {
        self.check()?;
        let area = titled(root, &self.title, (10, 30, 10, 10))?;
        let x0 = self.points[0].0;
        let x1 = self.points[self.points.len() - 1].0;
        let y = self.y_range();
        let mut chart = ChartBuilder::on(&area)
            .x_label_area_size(50)
            .y_label_area_size(70)
            .build_cartesian_2d(x0..x1, y.clone())?;
        let (xd, yd) = (tick_decimals(x1 - x0), tick_decimals(y.end - y.start));
        axes(
            &mut chart,
            "angle between magnet and coil (deg)",
            "torque (N m)",
        )
        .x_label_formatter(&|v| tick(*v, xd))
        .y_label_formatter(&|v| tick(*v, yd))
        .light_line_style(RGBColor(238, 238, 238))
        .bold_line_style(RGBColor(215, 215, 215))
        .draw()?;
        chart.draw_series(LineSeries::new(
            self.points.iter().copied(),
            SERIES_COLORS[0].stroke_width(2),
        ))?;
        if let Some(c) = self.cutoff_deg.filter(|c| *c >= x0 && *c <= x1) {
            let style = TARGET_COLOR.stroke_width(1);
            chart.draw_series(DashedLineSeries::new(
                vec![(c, y.start), (c, y.end)],
                6,
                4,
                style,
            ))?;
            chart.draw_series(std::iter::once(Text::new(
                format!(
                    "cut-off {} deg",
                    tick(c, if c.fract() == 0.0 { 0 } else { 1 })
                ),
                (c, y.end),
                text(14)
                    .color(&TARGET_COLOR)
                    .pos(Pos::new(HPos::Right, VPos::Top)),
            )))?;
        }
        Ok(())
    }
}
