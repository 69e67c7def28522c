//! Point labels (the numbers of coils and magnets, the names of axes) placed where they meet
//! no other label and no mark, on any chart: how big a label is, where each one goes, and
//! drawing them.

use crate::figures::figure::DrawResult;
use crate::figures::style::text;
use plotters::coord::CoordTranslate;
use plotters::prelude::*;
use plotters::style::text_anchor::{HPos, Pos, VPos};
use plotters::style::RGBColor;

/// The font size of point labels (coil and magnet numbers).
pub(crate) const LABEL_SIZE: u32 = 12;

/// A mark labels must not cover: its centre and half-size, in pixels.
pub(crate) type Mark = ((i32, i32), i32);

/// A label of a point of a chart with coordinates `C`.
#[derive(Debug, Clone)]
pub(crate) struct PointLabel<C> {
    pub text: String,
    /// The point labelled, in chart coordinates.
    pub at: C,
    /// The font size.
    pub size: u32,
    pub color: RGBColor,
}

impl<C> PointLabel<C> {
    pub(crate) fn new(text: impl Into<String>, at: C, size: u32, color: RGBColor) -> Self {
        PointLabel {
            text: text.into(),
            at,
            size,
            color,
        }
    }
}

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
    let mark_boxes: Vec<Box2> = marks
        .iter()
        .map(|((x, y), r)| (x - r, y - r, x + r, y + r))
        .collect();
    let mut placed: Vec<Box2> = Vec::new();
    let mut out = Vec::new();
    for (&point, &size) in at.iter().zip(sizes) {
        let (off, b) = least_crowded_place(point, size, &placed, &mark_boxes);
        placed.push(b);
        out.push(off);
    }
    out
}

/// A box in pixels: left, top, right, bottom.
type Box2 = (i32, i32, i32, i32);

/// The area two boxes share, in square pixels.
fn overlap(a: &Box2, b: &Box2) -> i64 {
    let w = (a.2.min(b.2) - a.0.max(b.0)).max(0) as i64;
    let h = (a.3.min(b.3) - a.1.max(b.1)).max(0) as i64;
    w * h
}

/// The place of one label of size (w, h) at pixel (x, y): its offset and its box, the first
/// free one of [`place_labels`]' candidates, else the least crowded.
fn least_crowded_place(
    (x, y): (i32, i32),
    (w, h): (i32, i32),
    placed: &[Box2],
    mark_boxes: &[Box2],
) -> ((i32, i32), Box2) {
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
                .chain(mark_boxes)
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
    (off, b)
}

/// Places `labels` (in turn, see [`place_labels`]) around the marks `marks` (centre and
/// half-size in pixels) and draws them on `chart`, each in its own size and colour.
pub(crate) fn draw_labels<'a, DB: DrawingBackend + 'a, CT: CoordTranslate>(
    chart: &mut ChartContext<'a, DB, CT>,
    labels: &[PointLabel<CT::From>],
    marks: &[Mark],
) -> DrawResult
where
    CT::From: Clone,
{
    let spec = chart.as_coord_spec();
    let at: Vec<(i32, i32)> = labels.iter().map(|l| spec.translate(&l.at)).collect();
    let sizes: Vec<(i32, i32)> = labels.iter().map(|l| label_size(&l.text, l.size)).collect();
    let offsets = place_labels(&at, &sizes, marks);
    chart.draw_series(labels.iter().zip(offsets).map(|(l, off)| {
        EmptyElement::at(l.at.clone())
            + Text::new(
                l.text.clone(),
                off,
                text(l.size)
                    .color(&l.color)
                    .pos(Pos::new(HPos::Left, VPos::Top)),
            )
    }))?;
    Ok(())
}
