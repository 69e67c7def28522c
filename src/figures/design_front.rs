//! The design search's front as a picture (`spherestep design`: `DIR/front.svg` and `.png`):
//! every fully planned layout's mean of the worst quarter of its axis errors (what the search
//! ranks on) against its median steps, each coloured by its coil count, the front's layouts
//! filled, the front's best at each median step count named, the scenario's own layout crossed
//! and named; the axes span the layouts, not zero.

use crate::figures::chart::{axes, draw_legend, titled};
use crate::figures::figure::{DrawError, DrawResult, Figure};
use crate::figures::labels::{draw_labels, Mark, PointLabel, LABEL_SIZE};
use crate::figures::style::{tick, tick_decimals, SERIES_COLORS};
use plotters::chart::SeriesLabelPosition;
use plotters::coord::Shift;
use plotters::prelude::*;

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
    /// Whether it is the scenario's own layout.
    pub own: bool,
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

    /// The points named: the front's best (least tail) at each median step count, and the
    /// scenario's own layout.
    fn named(&self) -> Vec<&FrontPoint> {
        let mut front: Vec<&FrontPoint> = self.points.iter().filter(|p| p.on_front).collect();
        front.sort_by(|a, b| {
            (a.median_steps.total_cmp(&b.median_steps))
                .then(a.tail_axis_error_deg.total_cmp(&b.tail_axis_error_deg))
                .then(a.name.cmp(&b.name))
        });
        front.dedup_by(|b, a| a.median_steps == b.median_steps);
        let own = self.points.iter().filter(|p| p.own && !front.contains(p));
        let mut named: Vec<&FrontPoint> = own.collect();
        named.extend(front);
        named
    }

    /// The chart's ranges: the layouts' own, with room around them (never from zero: the
    /// layouts differ by tenths of a degree).
    fn ranges(&self) -> ((f64, f64), (f64, f64)) {
        let span = |f: fn(&FrontPoint) -> f64| {
            let lo = self.points.iter().map(f).fold(f64::INFINITY, f64::min);
            let hi = self.points.iter().map(f).fold(f64::NEG_INFINITY, f64::max);
            (lo, hi)
        };
        let (x0, x1) = span(|p| p.tail_axis_error_deg);
        let pad = (0.08 * (x1 - x0)).max(0.1);
        let (y0, y1) = span(|p| p.median_steps);
        ((x0 - pad, x1 + 2.0 * pad), (y0 - 1.0, y1 + 1.0))
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
        let ((x0, x1), (y0, y1)) = self.ranges();
        let mut chart = ChartBuilder::on(&area)
            .x_label_area_size(50)
            .y_label_area_size(70)
            .build_cartesian_2d(x0..x1, y0..y1)?;
        let (xd, yd) = (tick_decimals(x1 - x0), tick_decimals(y1 - y0));
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
        let at = |p: &FrontPoint| (p.tail_axis_error_deg, p.median_steps);
        for (k, coils) in self.counts().into_iter().enumerate() {
            let color = SERIES_COLORS[k % SERIES_COLORS.len()];
            let mine = self.points.iter().filter(|p| p.coils == coils);
            chart
                .draw_series(mine.map(|p| {
                    let style = match p.on_front {
                        true => color.filled(),
                        false => color.stroke_width(1),
                    };
                    Circle::new(at(p), 5, style)
                }))?
                .label(format!("{coils} coils"))
                .legend(move |(x, y)| Circle::new((x + 10, y), 5, color.filled()));
        }
        let own = self.points.iter().filter(|p| p.own);
        if own.clone().next().is_some() {
            chart
                .draw_series(own.map(|p| Cross::new(at(p), 8, BLACK.stroke_width(2))))?
                .label("the scenario's own layout")
                .legend(|(x, y)| Cross::new((x + 10, y), 6, BLACK.stroke_width(2)));
        }
        let spec = chart.as_coord_spec();
        let marks: Vec<Mark> = self
            .points
            .iter()
            .map(|p| (spec.translate(&at(p)), 6))
            .collect();
        let labels: Vec<PointLabel<(f64, f64)>> = (self.named().into_iter())
            .map(|p| {
                let text = match p.own {
                    true => format!("{} (own)", p.name),
                    false => p.name.clone(),
                };
                PointLabel::new(text, at(p), LABEL_SIZE, BLACK)
            })
            .collect();
        draw_labels(&mut chart, &labels, &marks)?;
        draw_legend(&mut chart, SeriesLabelPosition::UpperRight, 16, 0.8)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn point(name: &str, tail: f64, steps: f64, on_front: bool, own: bool) -> FrontPoint {
        FrontPoint {
            name: name.into(),
            tail_axis_error_deg: tail,
            median_steps: steps,
            coils: 16,
            on_front,
            own,
        }
    }

    #[test]
    fn the_front_s_best_at_each_step_count_and_the_own_layout_are_named() {
        let front = DesignFront {
            title: "t".into(),
            points: vec![
                point("a", 3.6, 9.0, true, false),
                point("b", 3.4, 9.0, true, false),
                point("c", 3.5, 10.0, true, false),
                point("d", 3.3, 10.0, false, false),
                point("e", 3.9, 10.0, false, true),
                point("f", 3.45, 9.5, true, false),
            ],
        };
        let named: Vec<&str> = front.named().iter().map(|p| p.name.as_str()).collect();
        assert_eq!(named, ["e", "b", "f", "c"]);
        let ((x0, x1), (y0, y1)) = front.ranges();
        assert!(
            (x0 - 3.2).abs() < 1e-12 && (x1 - 4.1).abs() < 1e-12,
            "{x0} {x1}"
        );
        assert_eq!((y0, y1), (8.0, 11.0));
    }
}
