//! The design search's best layouts in 3-D (`spherestep design`: `DIR/best-layouts.svg` and
//! `.png`): up to four panels, each a layout's coils ('+', a little outside the ball) and
//! magnets (dots, faded on the far side) on the sphere under Figure 6's fixed projection
//! ([`View3d`](super::View3d)'s), the rotor at rest (body frame = world frame), each panel
//! captioned with the layout's name and what it scored.

use crate::figures::chart::titled;
use crate::figures::figure::{check_finite_points, DrawError, DrawResult, Figure};
use crate::figures::style::{plus, text, COIL_COLOR, MAGNET_BACK_COLOR, MAGNET_COLOR};
use crate::figures::view_3d::{
    draw_guides, projected_chart, scaled, to_chart, Chart3d, COIL_RADIUS,
};
use plotters::coord::Shift;
use plotters::prelude::*;

/// The most panels a picture holds.
pub const MAX_PANELS: usize = 4;
/// A panel's side, pixels.
const PANEL: u32 = 560;
/// The height of the picture's title, pixels.
const TITLE: u32 = 44;

/// One layout drawn.
#[derive(Debug, Clone, PartialEq)]
pub struct LayoutPanel {
    /// The caption's first line (the layout's name and family).
    pub name: String,
    /// The caption's second line (what it scored).
    pub caption: String,
    /// The coils, world unit vectors.
    pub coils: Vec<[f64; 3]>,
    /// The magnets at rest, unit vectors.
    pub magnets: Vec<[f64; 3]>,
}

/// The picture of a design run's best layouts.
#[derive(Debug, Clone, PartialEq)]
pub struct DesignLayouts {
    /// The title.
    pub title: String,
    /// The layouts, one panel each (1 to [`MAX_PANELS`]), in reading order.
    pub panels: Vec<LayoutPanel>,
}

impl DesignLayouts {
    /// Panels across and down.
    fn grid(&self) -> (usize, usize) {
        let cols = self.panels.len().clamp(1, 2);
        (cols, self.panels.len().div_ceil(cols).max(1))
    }

    fn check(&self) -> DrawResult {
        if self.panels.is_empty() || self.panels.len() > MAX_PANELS {
            return Err(DrawError(format!(
                "design layouts: expected 1 to {MAX_PANELS} layouts, got {}",
                self.panels.len()
            )));
        }
        for p in &self.panels {
            let magnets: Vec<(usize, [f64; 3])> = p.magnets.iter().copied().enumerate().collect();
            check_finite_points(&format!("design layout {}", p.name), &p.coils, &magnets)?;
        }
        Ok(())
    }
}

/// One layout on `chart`: the magnets behind the ball (faded), those in front, then the coils.
fn draw_layout<'a, DB: DrawingBackend + 'a>(
    chart: &mut Chart3d<'a, DB>,
    panel: &LayoutPanel,
) -> DrawResult {
    let spec = chart.as_coord_spec().clone();
    let centre_depth = spec.projected_depth(&0.0, &0.0, &0.0);
    let front = |p: &[f64; 3]| {
        let (x, y, z) = to_chart(*p);
        spec.projected_depth(&x, &y, &z) <= centre_depth
    };
    let (fore, back): (Vec<&[f64; 3]>, Vec<&[f64; 3]>) =
        panel.magnets.iter().partition(|p| front(p));
    chart.draw_series(
        back.iter()
            .map(|p| Circle::new(to_chart(**p), 3, MAGNET_BACK_COLOR.filled())),
    )?;
    chart.draw_series(
        fore.iter()
            .map(|p| Circle::new(to_chart(**p), 3, MAGNET_COLOR.filled())),
    )?;
    chart.draw_series(panel.coils.iter().map(|c| {
        plus!(
            to_chart(scaled(*c, COIL_RADIUS)),
            6,
            COIL_COLOR.stroke_width(2)
        )
    }))?;
    Ok(())
}

impl Figure for DesignLayouts {
    fn size(&self) -> (u32, u32) {
        let (cols, rows) = self.grid();
        (PANEL * cols as u32, TITLE + PANEL * rows as u32)
    }

    fn draw<DB: DrawingBackend>(&self, root: &DrawingArea<DB, Shift>) -> DrawResult {
        self.check()?;
        let area = titled(root, &self.title, (4, 0, 0, 0))?;
        let (cols, rows) = self.grid();
        let cells = area.split_evenly((rows, cols));
        for (cell, panel) in cells.iter().zip(&self.panels) {
            let head = cell.titled(&panel.name, text(18))?;
            let body = head.titled(&panel.caption, text(14))?;
            let mut chart = projected_chart(&body)?;
            draw_guides(&mut chart)?;
            draw_layout(&mut chart, panel)?;
        }
        Ok(())
    }
}
