//! What every picture is and how it leaves the program: the [`Figure`] trait, its
//! [`DrawError`], [`render_svg`] (an SVG document in a string) and [`write_figure`] (`STEM.svg`
//! and `STEM.png`, each written atomically). Also the checks of a figure's data that several
//! figures share (finite points, non-zero axes) and the look-up of a magnet by its index.

use crate::error::{Error, Result};
use crate::figures::style::{FONT, FONT_BYTES};
use plotters::coord::Shift;
use plotters::prelude::*;
use plotters::style::FontStyle;
use std::fmt;
use std::path::{Path, PathBuf};
use std::sync::OnceLock;

/// A drawing failure (the backend's error, or data a figure cannot show), as a message.
#[derive(Debug, Clone, PartialEq)]
pub struct DrawError(pub String);

impl fmt::Display for DrawError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(&self.0)
    }
}

impl<E: std::error::Error + Send + Sync> From<DrawingAreaErrorKind<E>> for DrawError {
    fn from(e: DrawingAreaErrorKind<E>) -> Self {
        DrawError(e.to_string())
    }
}

pub(crate) type DrawResult = std::result::Result<(), DrawError>;

/// A picture that can be drawn on any plotters backend.
pub trait Figure {
    /// Width and height in pixels (of the PNG; the SVG's view box).
    fn size(&self) -> (u32, u32);
    /// Draws the figure on `root` (already filled white).
    fn draw<DB: DrawingBackend>(&self, root: &DrawingArea<DB, Shift>) -> DrawResult;
}

fn font_registered() -> bool {
    static REGISTERED: OnceLock<bool> = OnceLock::new();
    *REGISTERED
        .get_or_init(|| plotters::style::register_font(FONT, FontStyle::Normal, FONT_BYTES).is_ok())
}

fn ensure_font() -> DrawResult {
    if font_registered() {
        Ok(())
    } else {
        Err(DrawError(
            "the bundled font assets/fonts/DejaVuSans.ttf could not be loaded".into(),
        ))
    }
}

fn plot_err(path: &Path, e: DrawError) -> Error {
    Error::Plot {
        path: path.to_path_buf(),
        message: e.0,
    }
}

/// Renders a figure to an SVG document.
pub fn render_svg<F: Figure>(fig: &F) -> std::result::Result<String, DrawError> {
    ensure_font()?;
    let mut s = String::new();
    {
        let root = SVGBackend::with_string(&mut s, fig.size()).into_drawing_area();
        root.fill(&WHITE)?;
        fig.draw(&root)?;
        root.present()?;
    }
    Ok(s)
}

fn write_png<F: Figure>(fig: &F, path: &Path) -> Result<()> {
    crate::io::output::write_via_temp(path, |tmp| {
        (|| -> DrawResult {
            let root = BitMapBackend::new(tmp, fig.size()).into_drawing_area();
            root.fill(&WHITE)?;
            fig.draw(&root)?;
            root.present()?;
            Ok(())
        })()
        .map_err(|e| plot_err(path, e))
    })
}

/// Writes `stem.svg` and `stem.png` (each to a temporary file first, then renamed, so no
/// half-written picture is left behind). Returns the two paths written.
pub fn write_figure<F: Figure>(fig: &F, stem: &Path) -> Result<Vec<PathBuf>> {
    let svg_path = with_ext(stem, "svg");
    let png_path = with_ext(stem, "png");
    let svg = render_svg(fig).map_err(|e| plot_err(&svg_path, e))?;
    crate::io::output::write_atomic(&svg_path, svg.as_bytes())?;
    write_png(fig, &png_path)?;
    Ok(vec![svg_path, png_path])
}

/// `stem` with `.ext` appended (not replacing: a stem may contain dots).
fn with_ext(stem: &Path, ext: &str) -> PathBuf {
    let mut s = stem.as_os_str().to_owned();
    s.push(".");
    s.push(ext);
    PathBuf::from(s)
}

/// Whether every coordinate of `p` is finite.
pub(crate) fn finite<const N: usize>(p: &[f64; N]) -> bool {
    p.iter().all(|v| v.is_finite())
}

/// `v` as a unit vector, or `None` if it is not finite or (nearly) zero.
pub(crate) fn normalise(v: &[f64; 3]) -> Option<[f64; 3]> {
    let n = (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt();
    (finite(v) && n > 1e-12).then(|| [v[0] / n, v[1] / n, v[2] / n])
}

/// Checks that the coils and magnets of a figure (`name` in the message, e.g. "Figure 5") all
/// have finite coordinates.
pub(crate) fn check_finite_points<const N: usize>(
    name: &str,
    coils: &[[f64; N]],
    magnets: &[(usize, [f64; N])],
) -> DrawResult {
    if let Some(p) = coils.iter().find(|p| !finite(p)) {
        return Err(DrawError(format!(
            "{name}: expected finite coil coordinates, got {p:?}"
        )));
    }
    if let Some((j, p)) = magnets.iter().find(|(_, p)| !finite(p)) {
        return Err(DrawError(format!(
            "{name}: expected finite coordinates for magnet {j}, got {p:?}"
        )));
    }
    Ok(())
}

/// Whether magnet `j` is among a figure's `magnets` (index, point).
pub(crate) fn shows_magnet<const N: usize>(magnets: &[(usize, [f64; N])], j: usize) -> bool {
    magnets.iter().any(|(k, _)| *k == j)
}

/// The point of magnet `j` among a figure's `magnets` (the origin if it is not shown; the
/// figures' checks rule that out before drawing).
pub(crate) fn magnet_at<const N: usize>(magnets: &[(usize, [f64; N])], j: usize) -> [f64; N] {
    magnets
        .iter()
        .find(|(k, _)| *k == j)
        .map(|(_, p)| *p)
        .unwrap_or([0.0; N])
}
