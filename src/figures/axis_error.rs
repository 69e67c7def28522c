//! Figures 7 and 8 of the paper ([`AxisErrorPlot`]): cumulative axis error against cumulative
//! rotation angle, one line per scheme, with an optional horizontal reference (the paper's
//! bound) and a vertical line at the target angle. A plan's own curve and batch's "schemes
//! compared" picture are both this figure; [`plan_series`] turns a plan into a line.

use crate::figures::chart::{axes, draw_legend, Chart2d};
use crate::figures::figure::{DrawError, DrawResult, Figure};
use crate::figures::style::{
    dash_path, marker_path, series_style, text, tick, tick_decimals, SeriesStyle, REFERENCE_COLOR,
    TARGET_COLOR,
};
use crate::planning::plan::PlanRow;
use plotters::coord::Shift;
use plotters::prelude::*;
use plotters::style::text_anchor::{HPos, Pos, VPos};
use plotters::style::{RGBColor, ShapeStyle};
use std::ops::Range;

/// One line of an [`AxisErrorPlot`]: a scheme's (cum_angle_deg, cum_axis_error_deg) points.
#[derive(Debug, Clone, PartialEq)]
pub struct ErrorSeries {
    /// The series' name in the legend (the scheme's).
    pub name: String,
    /// (cumulative angle, deg; cumulative axis error, deg), one point per step, in plan order.
    pub points: Vec<(f64, f64)>,
}

/// A horizontal reference line, e.g. the paper's bound (3 deg about Z, 15 deg about Y).
#[derive(Debug, Clone, PartialEq)]
pub struct ReferenceLine {
    /// Its label in the plot.
    pub label: String,
    /// Its height: an axis error, degrees.
    pub value_deg: f64,
}

/// Figures 7/8: cumulative axis error (deg) against cumulative rotation angle (deg), one series
/// per scheme: a mark at each step (the motion is discrete), thin lines joining them, each
/// series in its own colour, marker and dash ([`series_style`]); markers shrink from the first
/// series to the last, so identical series stay visible one inside the other.
#[derive(Debug, Clone, PartialEq)]
pub struct AxisErrorPlot {
    /// The title drawn above the plot.
    pub title: String,
    /// The series, drawn in order, each in the style [`series_style`] gives its index.
    pub series: Vec<ErrorSeries>,
    /// A horizontal reference line, if any.
    pub reference: Option<ReferenceLine>,
    /// The target rotation angle (deg), marked by a vertical line.
    pub target_deg: Option<f64>,
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

/// Widens a range outwards to a "nice" one starting at `lo` (callers pass 0 or a negative
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

/// The nice start of a range whose smallest value is `min`: 0, or below a negative minimum.
fn nice_min(min: f64) -> f64 {
    if min < 0.0 {
        -nice_max(-min)
    } else {
        0.0
    }
}

impl AxisErrorPlot {
    fn points(&self) -> impl Iterator<Item = &(f64, f64)> {
        self.series.iter().flat_map(|s| s.points.iter())
    }

    fn min_error(&self) -> f64 {
        self.points().map(|p| p.1).fold(0.0f64, f64::min)
    }

    /// The rotation angle range drawn: from 0 (or the negative minimum) up past the largest
    /// angle and the target.
    fn x_range(&self) -> Range<f64> {
        let (amin, amax) = self
            .points()
            .fold((0.0f64, 0.0f64), |(lo, hi), p| (lo.min(p.0), hi.max(p.0)));
        let amax = amax.max(self.target_deg.unwrap_or(0.0) * 1.05);
        nice_min(amin)..nice_max(amax)
    }

    /// The axis error range drawn: from 0 (or the negative minimum) up past the largest error
    /// and the reference; a zero-error series sits a little above the frame, never on it.
    pub fn y_range(&self) -> Range<f64> {
        let emax = self
            .points()
            .map(|p| p.1)
            .chain(self.reference.iter().map(|r| r.value_deg))
            .fold(0.0f64, f64::max);
        let top = nice_max(emax * 1.15);
        let bottom = nice_min(self.min_error());
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

    /// The axes and the grid; below zero is only the margin that lifts a zero series off the
    /// frame: no ticks there.
    fn draw_axes<'a, DB: DrawingBackend + 'a>(&self, chart: &mut Chart2d<'a, DB>) -> DrawResult {
        let no_negative = self.min_error() >= 0.0;
        let (xd, yd) = (
            tick_decimals(chart.x_range().end - chart.x_range().start),
            tick_decimals(chart.y_range().end - chart.y_range().start),
        );
        axes(
            chart,
            "cumulative rotation angle (deg)",
            "cumulative axis error (deg)",
        )
        .x_label_formatter(&|v| tick(*v, xd))
        .y_label_formatter(&|v| {
            if no_negative && *v < 0.0 {
                String::new()
            } else {
                tick(*v, yd)
            }
        })
        .light_line_style(RGBColor(238, 238, 238))
        .bold_line_style(RGBColor(215, 215, 215))
        .draw()?;
        Ok(())
    }

    /// The reference line across the chart, dashed, with its legend entry.
    fn draw_reference<'a, DB: DrawingBackend + 'a>(
        &self,
        chart: &mut Chart2d<'a, DB>,
    ) -> DrawResult {
        let Some(r) = &self.reference else {
            return Ok(());
        };
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
        Ok(())
    }

    /// The target angle: a dashed vertical line, named at its top.
    fn draw_target<'a, DB: DrawingBackend + 'a>(&self, chart: &mut Chart2d<'a, DB>) -> DrawResult {
        let Some(t) = self.target_deg else {
            return Ok(());
        };
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
        Ok(())
    }

    /// Series `k`: its line (solid or dashed), then a mark at each point, with its legend
    /// entry.
    fn draw_series<'a, DB: DrawingBackend + 'a>(
        &self,
        chart: &mut Chart2d<'a, DB>,
        k: usize,
        s: &ErrorSeries,
    ) -> DrawResult {
        let n = self.series.len() as i32;
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
            .draw_series(
                s.points.iter().map(|p| {
                    EmptyElement::at(*p) + PathElement::new(marker_path(st.marker, r), mark)
                }),
            )?
            .label(s.name.clone())
            .legend(move |(x, y)| series_key((x, y), st, line, mark));
        Ok(())
    }
}

/// The legend's sample of a series at (x, y): its dash pattern with its marker in the middle.
fn series_key<'a, DB: DrawingBackend + 'a>(
    at: (i32, i32),
    st: SeriesStyle,
    line: ShapeStyle,
    mark: ShapeStyle,
) -> impl IntoDynElement<'a, DB, (i32, i32)> {
    let [a, b, c, d] = dash_path(st.dash);
    EmptyElement::at(at)
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
}

impl Figure for AxisErrorPlot {
    fn size(&self) -> (u32, u32) {
        (900, 600)
    }

    fn draw<DB: DrawingBackend>(&self, root: &DrawingArea<DB, Shift>) -> DrawResult {
        self.check()?;
        let area = root.margin(10, 25, 10, 10);
        let mut chart = ChartBuilder::on(&area)
            .caption(&self.title, text(24))
            .x_label_area_size(55)
            .y_label_area_size(70)
            .build_cartesian_2d(self.x_range(), self.y_range())?;
        self.draw_axes(&mut chart)?;
        self.draw_reference(&mut chart)?;
        self.draw_target(&mut chart)?;
        for (k, s) in self.series.iter().enumerate() {
            self.draw_series(&mut chart, k, s)?;
        }
        draw_legend(&mut chart, SeriesLabelPosition::UpperLeft, 16, 0.9)
    }
}
