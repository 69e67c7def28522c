//! A run on a plant (`spherestep run`, `simulate --closed-loop`), drawn by `spherestep plot`:
//! the ball's true distance to the goal after each step, the steps whose measurement was
//! replanned from marked, and the true cumulative rotation angle on the same steps.

use crate::figures::chart::{axes, draw_legend, line_key, titled};
use crate::figures::figure::{DrawError, DrawResult, Figure};
use crate::figures::style::{text, tick, tick_decimals, SERIES_COLORS, TARGET_COLOR};
use plotters::chart::SeriesLabelPosition;
use plotters::coord::Shift;
use plotters::prelude::*;

/// One run's rows, as drawn.
#[derive(Debug, Clone, PartialEq)]
pub struct LoopPlot {
    /// The title drawn above the plot.
    pub title: String,
    /// (step, true distance to the goal, deg; true cumulative angle, deg; replanned).
    pub rows: Vec<(usize, f64, f64, bool)>,
}

impl LoopPlot {
    fn check(&self) -> DrawResult {
        if self.rows.is_empty() {
            return Err(DrawError("loop plot: expected at least one step".into()));
        }
        if let Some(r) = self
            .rows
            .iter()
            .find(|r| !r.1.is_finite() || !r.2.is_finite())
        {
            return Err(DrawError(format!(
                "loop plot: step {}: expected finite angles, got {} and {}",
                r.0, r.1, r.2
            )));
        }
        Ok(())
    }

    fn y_top(&self) -> f64 {
        let top = self
            .rows
            .iter()
            .map(|r| r.1.max(r.2.abs()))
            .fold(1.0f64, f64::max);
        top * 1.1
    }
}

impl Figure for LoopPlot {
    fn size(&self) -> (u32, u32) {
        (900, 560)
    }

    fn draw<DB: DrawingBackend>(&self, root: &DrawingArea<DB, Shift>) -> DrawResult {
        self.check()?;
        let area = titled(root, &self.title, (10, 30, 10, 10))?;
        // steps are whole numbers: an integer axis labels each step once (a real one labelled
        // 0, 0.2, ... rounded to 0, 0, ... for few steps)
        let step = |k: usize| i32::try_from(k).unwrap_or(i32::MAX);
        let last = step(self.rows.iter().map(|r| r.0).max().unwrap_or(0).max(1));
        let (lo, top) = (
            self.rows
                .iter()
                .map(|r| r.2)
                .fold(0.0f64, f64::min)
                .min(0.0),
            self.y_top(),
        );
        let mut chart = ChartBuilder::on(&area)
            .x_label_area_size(50)
            .y_label_area_size(70)
            .build_cartesian_2d(0..last, lo..top)?;
        let yd = tick_decimals(top - lo);
        axes(&mut chart, "step", "degrees")
            .x_labels(
                usize::try_from(last)
                    .unwrap_or(10)
                    .saturating_add(1)
                    .min(10),
            )
            .x_label_formatter(&|v| v.to_string())
            .y_label_formatter(&|v| tick(*v, yd))
            .light_line_style(RGBColor(238, 238, 238))
            .bold_line_style(RGBColor(215, 215, 215))
            .draw()?;
        let err = SERIES_COLORS[0].stroke_width(2);
        chart
            .draw_series(LineSeries::new(
                self.rows.iter().map(|r| (step(r.0), r.1)),
                err,
            ))?
            .label("true distance to the goal")
            .legend(line_key(err));
        let cum = SERIES_COLORS[1].stroke_width(1);
        chart
            .draw_series(LineSeries::new(
                self.rows.iter().map(|r| (step(r.0), r.2)),
                cum,
            ))?
            .label("true cumulative rotation angle")
            .legend(line_key(cum));
        let mark = TARGET_COLOR.stroke_width(2);
        chart
            .draw_series(
                self.rows
                    .iter()
                    .filter(|r| r.3)
                    .map(|r| Circle::new((step(r.0), r.1), 5, mark)),
            )?
            .label("replanned after this step")
            .legend(move |(x, y)| Circle::new((x + 10, y), 5, mark));
        chart.draw_series(std::iter::once(Text::new(
            format!("{:.2} deg from the goal", self.rows[self.rows.len() - 1].1),
            (last, top),
            text(14).pos(plotters::style::text_anchor::Pos::new(
                plotters::style::text_anchor::HPos::Right,
                plotters::style::text_anchor::VPos::Top,
            )),
        )))?;
        draw_legend(&mut chart, SeriesLabelPosition::MiddleRight, 15, 0.9)?;
        Ok(())
    }
}
