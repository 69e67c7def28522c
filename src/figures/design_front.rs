//! The design search's front as a picture (`spherestep design`: `DIR/front.svg` and `.png`):
//! every fully planned layout's mean of the worst quarter of its axis errors (what the search
//! ranks on) against its median steps, the front's
//! layouts marked and named, each coloured by its coil count.

use crate::figures::chart::{axes, draw_legend, titled};
use crate::figures::figure::{DrawError, DrawResult, Figure};
use crate::figures::style::{text, tick, tick_decimals, SERIES_COLORS};
use plotters::chart::SeriesLabelPosition;
use plotters::coord::Shift;
use plotters::prelude::*;
use plotters::style::text_anchor::{HPos, Pos, VPos};

/// One fully planned layout.
#[derive(Debug, Clone, PartialEq)]
pub struct FrontPoint {
    /// Its name (`g003-017`).
    pub name: String,
    /// The mean of the worst quarter of its axis errors over the full axes, degrees.
    pub tail_axis_error_deg: f64,
    /// Its median steps.
    pub median_steps: f64,
    /// Its coils.
    pub coils: usize,
    /// Whether it is on the front.
    pub on_front: bool,
}

/// The picture of a design run's layouts.
#[derive(Debug, Clone, PartialEq)]
pub struct DesignFront {
    /// The title.
    pub title: String,
    /// The layouts (at least one, finite).
    pub points: Vec<FrontPoint>,
}

impl DesignFront {
    fn check(&self) -> DrawResult {
        if self.points.is_empty() {
            return Err(DrawError("no layout to draw".into()));
        }
        let finite =
            |p: &FrontPoint| p.tail_axis_error_deg.is_finite() && p.median_steps.is_finite();
        if !self.points.iter().all(finite) {
            return Err(DrawError("a layout's objectives are not finite".into()));
        }
        Ok(())
    }

    /// The coil counts, fewest first.
    fn counts(&self) -> Vec<usize> {
        let mut c: Vec<usize> = self.points.iter().map(|p| p.coils).collect();
        c.sort_unstable();
        c.dedup();
        c
    }
}

impl Figure for DesignFront {
    fn size(&self) -> (u32, u32) {
        (900, 600)
    }

    fn draw<DB: DrawingBackend>(&self, root: &DrawingArea<DB, Shift>) -> DrawResult {
        self.check()?;
        let area = titled(root, &self.title, (10, 30, 10, 10))?;
        let x1 = self
            .points
            .iter()
            .map(|p| p.tail_axis_error_deg)
            .fold(0.0, f64::max)
            * 1.15
            + 0.1;
        let y1 = self
            .points
            .iter()
            .map(|p| p.median_steps)
            .fold(0.0, f64::max)
            * 1.15
            + 1.0;
        let mut chart = ChartBuilder::on(&area)
            .x_label_area_size(50)
            .y_label_area_size(70)
            .build_cartesian_2d(0.0..x1, 0.0..y1)?;
        let (xd, yd) = (tick_decimals(x1), tick_decimals(y1));
        axes(
            &mut chart,
            "axis error, mean of the worst quarter of the axes (deg)",
            "median steps",
        )
        .x_label_formatter(&|v| tick(*v, xd))
        .y_label_formatter(&|v| tick(*v, yd))
        .light_line_style(RGBColor(238, 238, 238))
        .bold_line_style(RGBColor(215, 215, 215))
        .draw()?;
        for (k, coils) in self.counts().into_iter().enumerate() {
            let color = SERIES_COLORS[k % SERIES_COLORS.len()];
            let mine: Vec<&FrontPoint> = self.points.iter().filter(|p| p.coils == coils).collect();
            chart
                .draw_series(mine.iter().map(|p| {
                    let style = match p.on_front {
                        true => color.filled(),
                        false => color.stroke_width(1),
                    };
                    Circle::new((p.tail_axis_error_deg, p.median_steps), 5, style)
                }))?
                .label(format!("{coils} coils"))
                .legend(move |(x, y)| Circle::new((x + 10, y), 5, color.filled()));
            chart.draw_series(mine.iter().filter(|p| p.on_front).map(|p| {
                Text::new(
                    p.name.clone(),
                    (p.tail_axis_error_deg, p.median_steps),
                    text(12).pos(Pos::new(HPos::Left, VPos::Bottom)),
                )
            }))?;
        }
        draw_legend(&mut chart, SeriesLabelPosition::UpperRight, 16, 0.8)
    }
}
