//! Figure 5 of the paper ([`CommutationPlot`]): a commutation state projected on the X-Y plane,
//! seen from +Z through the ball: stator coils '+', the rotor magnets of the bottom hemisphere
//! '*', candidate pairs joined by thin lines, chosen pairs by thick ones and boxed, every coil
//! and magnet numbered.

use crate::figures::chart::{axes, draw_legend, line_key, plot_dims, titled, Chart2d};
use crate::figures::figure::{
    check_finite_points, magnet_at, shows_magnet, DrawError, DrawResult, Figure,
};
use crate::figures::labels::{draw_labels, Mark, PointLabel, LABEL_SIZE};
use crate::figures::style::{
    plus, star, tick, CANDIDATE_COLOR, CHOSEN_COLOR, COIL_COLOR, GUIDE_COLOR, MAGNET_COLOR,
};
use crate::model::geometry::Pair;
use plotters::coord::Shift;
use plotters::prelude::*;

/// Figure 5: the commutation state projected on the X-Y plane.
#[derive(Debug, Clone, PartialEq)]
pub struct CommutationPlot {
    /// The title drawn above the plot.
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

/// The label areas of the chart (pixels): left of it and below it.
const LEFT: u32 = 60;
const BOTTOM: u32 = 50;

impl CommutationPlot {
    fn check(&self) -> DrawResult {
        check_finite_points("Figure 5", &self.coils, &self.magnets)?;
        for (what, pairs) in [("candidate", &self.candidates), ("chosen", &self.chosen)] {
            for p in pairs.iter() {
                if p.coil.0 >= self.coils.len() {
                    return Err(DrawError(format!(
                        "Figure 5: {what} pair {p}: expected a coil below {}",
                        self.coils.len()
                    )));
                }
                if !shows_magnet(&self.magnets, p.magnet.0) {
                    return Err(DrawError(format!(
                        "Figure 5: {what} pair {p}: magnet {} is not among the magnets shown",
                        p.magnet.0
                    )));
                }
            }
        }
        Ok(())
    }

    /// The two ends of a pair: its coil's point and its magnet's.
    fn pair_ends(&self, p: &Pair) -> [(f64, f64); 2] {
        let c = self.coils[p.coil.0];
        let m = magnet_at(&self.magnets, p.magnet.0);
        [(c[0], c[1]), (m[0], m[1])]
    }

    /// The chart on `area`, with equal scales on both axes (the unit circle stays a circle)
    /// and room for every point.
    fn chart<'a, DB: DrawingBackend>(
        &self,
        area: &'a DrawingArea<DB, Shift>,
    ) -> Result<Chart2d<'a, DB>, DrawError> {
        let (pw, ph) = plot_dims(area, LEFT, BOTTOM);
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
        Ok(ChartBuilder::on(area)
            .x_label_area_size(BOTTOM)
            .y_label_area_size(LEFT)
            .build_cartesian_2d(-rx..rx, -ry..ry)?)
    }

    /// The candidate pairs (thin lines), the chosen ones (thick lines) and the boxes around
    /// the chosen pairs' ends.
    fn draw_pairs<'a, DB: DrawingBackend + 'a>(&self, chart: &mut Chart2d<'a, DB>) -> DrawResult {
        let line = |p: &Pair, style: ShapeStyle| PathElement::new(self.pair_ends(p), style);
        chart
            .draw_series(
                self.candidates
                    .iter()
                    .map(|p| line(p, CANDIDATE_COLOR.stroke_width(1))),
            )?
            .label("candidate pair")
            .legend(line_key(CANDIDATE_COLOR.stroke_width(1)));
        chart
            .draw_series(
                self.chosen
                    .iter()
                    .map(|p| line(p, CHOSEN_COLOR.stroke_width(2))),
            )?
            .label("chosen pair (boxed)")
            .legend(|(x, y)| {
                EmptyElement::at((x, y))
                    + PathElement::new(vec![(0, 0), (20, 0)], CHOSEN_COLOR.stroke_width(2))
                    + Rectangle::new([(14, -6), (26, 6)], CHOSEN_COLOR.stroke_width(1))
            });
        let boxed = self.chosen.iter().flat_map(|p| self.pair_ends(p));
        chart.draw_series(boxed.map(|at| {
            EmptyElement::at(at) + Rectangle::new([(-9, -9), (9, 9)], CHOSEN_COLOR.stroke_width(1))
        }))?;
        Ok(())
    }

    /// The coils ('+') and the magnets ('*').
    fn draw_points<'a, DB: DrawingBackend + 'a>(&self, chart: &mut Chart2d<'a, DB>) -> DrawResult {
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
        Ok(())
    }

    /// The numbers of the coils first, then the magnets', each where it meets no label and no
    /// mark (the points' marks and the boxes of the chosen pairs).
    fn draw_numbers<'a, DB: DrawingBackend + 'a>(&self, chart: &mut Chart2d<'a, DB>) -> DrawResult {
        let label = |n: usize, p: &[f64; 2], color| {
            PointLabel::new(n.to_string(), (p[0], p[1]), LABEL_SIZE, color)
        };
        let labels: Vec<PointLabel<(f64, f64)>> = self
            .coils
            .iter()
            .enumerate()
            .map(|(i, c)| label(i, c, COIL_COLOR))
            .chain(self.magnets.iter().map(|(j, p)| label(*j, p, MAGNET_COLOR)))
            .collect();
        let px = |q: &(f64, f64)| chart.backend_coord(q);
        let marks: Vec<Mark> = labels
            .iter()
            .map(|l| (px(&l.at), 7))
            .chain(
                self.chosen
                    .iter()
                    .flat_map(|p| self.pair_ends(p))
                    .map(|q| (px(&q), 10)),
            )
            .collect();
        draw_labels(chart, &labels, &marks)
    }
}

/// The ball's outline (its equator), as a path in world (x, y).
fn equator() -> Vec<(f64, f64)> {
    (0..=180)
        .map(|k| {
            let a = k as f64 * std::f64::consts::TAU / 180.0;
            (a.cos(), a.sin())
        })
        .collect()
}

impl Figure for CommutationPlot {
    fn size(&self) -> (u32, u32) {
        (820, 880)
    }

    fn draw<DB: DrawingBackend>(&self, root: &DrawingArea<DB, Shift>) -> DrawResult {
        self.check()?;
        let area = titled(root, &self.title, (5, 15, 15, 15))?;
        let mut chart = self.chart(&area)?;
        axes(
            &mut chart,
            "world x (seen from +Z, above the ball, through it)",
            "world y",
        )
        .disable_mesh()
        .x_label_formatter(&|v| tick(*v, 1))
        .y_label_formatter(&|v| tick(*v, 1))
        .draw()?;
        chart.draw_series(std::iter::once(PathElement::new(
            equator(),
            GUIDE_COLOR.stroke_width(1),
        )))?;
        self.draw_pairs(&mut chart)?;
        self.draw_points(&mut chart)?;
        self.draw_numbers(&mut chart)?;
        draw_legend(&mut chart, SeriesLabelPosition::UpperRight, 14, 0.85)
    }
}
