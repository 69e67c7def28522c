//! What a reader looks at: the pictures, drawn with plotters' pure-Rust backends and written
//! both as SVG and as PNG (text rendered with ab_glyph and the DejaVu Sans font kept in
//! `assets/fonts/`, so nothing depends on the system's fonts), the self-contained 3-D page and
//! what a batch draws. One file per figure; the figures follow the paper (Stein & Chirikjian,
//! DETC2000/MECH-14115, sections 3.3, 4.1):
//!
//! - [`commutation_plot`]: Figure 5, coils '+' and the magnets '*' of the bottom hemisphere
//!   projected on the X-Y plane, candidate pairs joined by lines, chosen pairs boxed;
//! - [`view_3d`]: Figure 6, a still 3-D view of the ball with its magnets, the coils, the
//!   active pairs and the actual and desired rotation axes, under one fixed projection;
//! - [`axis_error`]: Figures 7/8, cumulative axis error against rotation angle, one line per
//!   scheme (a plan's own curve, and the schemes of one motion compared), with the paper's
//!   bound as a reference line;
//! - [`sweep_map`]: a value (e.g. the worst axis error of a 90 degree move) for each axis of a
//!   sweep, on a longitude/latitude map of the sphere of axes;
//! - [`loop_plot`]: a run on a plant (open or closed loop): the distance to the goal by step,
//!   the replans marked;
//! - [`waypoint_plot`]: a plan through waypoints: the ball's path and the waypoints, as
//!   rotation vectors projected on the two world axes the waypoints spread along most;
//! - [`plot_csv`](mod@plot_csv): `spherestep plot`, the figure that suits an existing result
//!   CSV, with [`sweep_csv`] reading a sweep CSV's points;
//! - [`view`]: `spherestep view`, the interactive 3-D page of a plan;
//! - [`batch_pictures`]: the pictures and page `batch --plots` draws for each result;
//! - [`well_plot`]: `spherestep wells`, the torque on one magnet passing one coil against the
//!   angle, with the well's cut-off.
//!
//! Shared by the figures: [`figure`] (the [`Figure`] trait, writing SVG and PNG atomically),
//! [`style`] (font, colours, series styles, marks, ticks), `chart` (title, axes and legend
//! steps) and [`labels`] (placing point labels clear of each other and of the marks).
//!
//! The figures take plain data (no planner types), implement [`Figure`], and are written with
//! [`write_figure`] (a temporary file, then a rename) or rendered to an SVG string with
//! [`render_svg`]. Indices are 0-based, angles in degrees.

pub mod axis_error;
pub mod batch_pictures;
mod chart;
pub mod commutation_plot;
pub mod figure;
pub mod labels;
pub mod loop_plot;
pub mod plot_csv;
pub mod style;
pub mod sweep_csv;
pub mod sweep_map;
pub mod view;
pub mod view_3d;
pub mod waypoint_plot;
pub mod well_plot;

pub use axis_error::{plan_series, AxisErrorPlot, ErrorSeries, ReferenceLine};
pub use commutation_plot::CommutationPlot;
pub use figure::{render_svg, write_figure, DrawError, Figure};
pub use labels::{label_size, place_labels};
pub use loop_plot::LoopPlot;
pub use plot_csv::{plot_csv, plot_csv_with_coils};
pub use style::{series_style, Marker, SeriesStyle, SERIES_COLORS};
pub use sweep_csv::{
    parse_sweep, parse_sweep_column, parse_unreached, SweepPoints, FLOOR_COLUMN, SWEEP_COLUMNS,
};
pub use sweep_map::{scale_color, SweepMap};
pub use view_3d::View3d;
pub use waypoint_plot::WaypointPlot;
pub use well_plot::WellPlot;
