//! A plan through waypoints (`plan --waypoints`), drawn by `spherestep plot`: the ball's path
//! and the waypoints, each orientation drawn as its rotation vector (the axis scaled by the
//! angle, degrees) projected on the two world axes along which the waypoints spread most; the
//! rows that reach a waypoint marked, with the waypoint's number and how far from it they end.

use crate::figures::chart::{axes, draw_legend, line_key, titled};
use crate::figures::figure::{DrawError, DrawResult, Figure};
use crate::figures::style::{text, tick, tick_decimals, SERIES_COLORS, TARGET_COLOR};
use plotters::chart::SeriesLabelPosition;
use plotters::coord::Shift;
use plotters::prelude::*;

/// A waypoint plan, as drawn: rotation vectors in degrees (world frame), x, y, z.
#[derive(Debug, Clone, PartialEq)]
pub struct WaypointPlot {
    /// The title drawn above the plot.
    pub title: String,
    /// Each row's orientation, in step order.
    pub path: Vec<[f64; 3]>,
    /// Each waypoint: its orientation, the row that reaches it (an index into `path`) and how
    /// far from it that row ends, degrees.
    pub waypoints: Vec<([f64; 3], usize, f64)>,
}

const AXIS_NAMES: [&str; 3] = ["X", "Y", "Z"];

impl WaypointPlot {
    fn check(&self) -> DrawResult {
        if self.path.is_empty() || self.waypoints.is_empty() {
            return Err(DrawError(
                "waypoint plot: expected at least one row and one waypoint".into(),
            ));
        }
        let finite = |v: &[f64; 3]| v.iter().all(|x| x.is_finite());
        if !self.path.iter().all(finite) || !self.waypoints.iter().all(|w| finite(&w.0)) {
            return Err(DrawError(
                "waypoint plot: expected finite orientations".into(),
            ));
        }
        if let Some(w) = self.waypoints.iter().find(|w| w.1 >= self.path.len()) {
            return Err(DrawError(format!(
                "waypoint plot: a waypoint reached at row {}, past the last row {}",
                w.1,
                self.path.len() - 1
            )));
        }
        Ok(())
    }

    /// The two world axes (indices) along which the waypoints spread most, the wider first.
    pub fn projection(&self) -> (usize, usize) {
        let spread = |k: usize| {
            let v = self.waypoints.iter().map(|w| w.0[k]);
            v.clone().fold(f64::NEG_INFINITY, f64::max) - v.fold(f64::INFINITY, f64::min)
        };
        let mut order = [0usize, 1, 2];
        // a stable sort: on a tie the lower axis first
        order.sort_by(|&a, &b| spread(b).total_cmp(&spread(a)));
        (order[0], order[1])
    }

    /// The drawn range along `k`: the path and the waypoints with a margin, at least 10 deg.
    fn range(&self, k: usize) -> (f64, f64) {
        let all = self.path.iter().chain(self.waypoints.iter().map(|w| &w.0));
        let (lo, hi) = all.fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), v| {
            (lo.min(v[k]), hi.max(v[k]))
        });
        let mid = 0.5 * (lo + hi);
        let half = (0.5 * (hi - lo) * 1.15).max(5.0);
        (mid - half, mid + half)
    }
}

impl Figure for WaypointPlot {
    fn size(&self) -> (u32, u32) {
        (900, 640)
    }

    fn draw<DB: DrawingBackend>(&self, root: &DrawingArea<DB, Shift>) -> DrawResult {
        self.check()?;
        let (a, b) = self.projection();
        let area = titled(root, &self.title, (10, 30, 10, 10))?;
        let ((x0, x1), (y0, y1)) = (self.range(a), self.range(b));
        let mut chart = ChartBuilder::on(&area)
            .x_label_area_size(50)
            .y_label_area_size(70)
            .build_cartesian_2d(x0..x1, y0..y1)?;
        let (xd, yd) = (tick_decimals(x1 - x0), tick_decimals(y1 - y0));
        let desc = |k: usize| format!("rotation vector, {} (deg)", AXIS_NAMES[k]);
        axes(&mut chart, &desc(a), &desc(b))
            .x_label_formatter(&|v| tick(*v, xd))
            .y_label_formatter(&|v| tick(*v, yd))
            .light_line_style(RGBColor(238, 238, 238))
            .bold_line_style(RGBColor(215, 215, 215))
            .draw()?;
        let at = |v: &[f64; 3]| (v[a], v[b]);
        let line = SERIES_COLORS[0].stroke_width(2);
        chart
            .draw_series(LineSeries::new(self.path.iter().map(at), line))?
            .label("the ball, step by step")
            .legend(line_key(line));
        chart.draw_series(
            self.path
                .iter()
                .map(|v| Circle::new(at(v), 3, SERIES_COLORS[0].filled())),
        )?;
        let mark = TARGET_COLOR.stroke_width(2);
        chart
            .draw_series(self.waypoints.iter().map(|w| Cross::new(at(&w.0), 8, mark)))?
            .label("waypoint")
            .legend(move |(x, y)| Cross::new((x + 10, y), 6, mark));
        let reach = SERIES_COLORS[1].stroke_width(2);
        chart
            .draw_series(
                self.waypoints
                    .iter()
                    .map(|w| Circle::new(at(&self.path[w.1]), 7, reach)),
            )?
            .label("where each is reached")
            .legend(move |(x, y)| Circle::new((x + 10, y), 6, reach));
        chart.draw_series(self.waypoints.iter().enumerate().map(|(k, w)| {
            let (x, y) = at(&w.0);
            Text::new(
                format!("{} ({:.1})", k + 1, w.2),
                (x, y),
                text(14).pos(plotters::style::text_anchor::Pos::new(
                    plotters::style::text_anchor::HPos::Left,
                    plotters::style::text_anchor::VPos::Bottom,
                )),
            )
        }))?;
        draw_legend(&mut chart, SeriesLabelPosition::LowerRight, 15, 0.9)?;
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_projection_is_on_the_axes_the_waypoints_spread_along() {
        let p = WaypointPlot {
            title: "t".into(),
            path: vec![[0.0; 3]],
            waypoints: vec![
                ([1.0, -20.0, 0.5], 0, 0.0),
                ([-1.0, 20.0, 0.0], 0, 0.0),
                ([10.0, 0.0, 0.0], 0, 0.0),
            ],
        };
        assert_eq!(p.projection(), (1, 0));
        let svg = crate::figures::render_svg(&p).unwrap();
        assert!(svg.contains("rotation vector, Y (deg)"));
        assert!(svg.contains("rotation vector, X (deg)"));
    }

    #[test]
    fn a_waypoint_reached_past_the_last_row_is_refused() {
        let p = WaypointPlot {
            title: "t".into(),
            path: vec![[0.0; 3]],
            waypoints: vec![([1.0, 0.0, 0.0], 3, 0.0)],
        };
        assert!(crate::figures::render_svg(&p).is_err());
    }
}
