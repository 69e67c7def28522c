//! What a reader looks at: the pictures, drawn with plotters' pure-Rust backends and written both
//! as SVG and as PNG (text rendered with ab_glyph and the DejaVu Sans font kept in `assets/fonts/`,
//! so nothing depends on the system's fonts), the self-contained 3-D page and what a batch draws.
//! One file per figure; the figures follow the paper (Stein & Chirikjian, DETC2000/MECH-14115,
//! sections 3.3, 4.1):
//!
//! - [`CommutationPlot`] (`commutation_plot.rs`): Figure 5, coils '+' and the magnets '*' of the
//!   bottom hemisphere projected on the X-Y plane, candidate pairs joined by lines, chosen pairs
//!   boxed;
//! - [`View3d`] (`view_3d.rs`): Figure 6, a still 3-D view of the ball with its magnets, the coils,
//!   the active pairs and the actual and desired rotation axes, under one fixed projection;
//! - [`AxisErrorPlot`] (`axis_error.rs`, the series of a plan by [`plan_series`]): Figures 7/8,
//!   cumulative axis error against rotation angle, one line per scheme (a plan's own curve, and the
//!   schemes of one motion compared), with the paper's bound as a reference line;
//! - [`SweepMap`] (`sweep_map.rs`): a value (e.g. the worst axis error of a 90 degree move) for
//!   each axis of a sweep, on a longitude/latitude map of the sphere of axes;
//! - [`LoopPlot`] (`loop_plot.rs`): a run on a plant (open or closed loop): the distance to the
//!   goal by step, the replans marked;
//! - [`WaypointPlot`] (`waypoint_plot.rs`): a plan through waypoints: the ball's path and the
//!   waypoints, as rotation vectors projected on the two world axes the waypoints spread along
//!   most;
//! - [`plot_csv()`] (`plot_csv.rs`): `spherestep plot`, the figure that suits an existing result
//!   CSV, with [`parse_sweep`] (`sweep_csv.rs`) reading a sweep CSV's points;
//! - [`view`]: `spherestep view`, the interactive 3-D page of a plan;
//! - [`batch_pictures`]: the pictures and page `batch --plots` draws for each result;
//! - [`WellPlot`] (`well_plot.rs`): `spherestep wells`, the torque on one magnet passing one coil
//!   against the angle, with the well's cut-off;
//! - [`DesignFront`] (`design_front.rs`): `spherestep design`, every fully planned layout's mean
//!   of the worst quarter of its axis errors against its median steps, coloured by coil count,
//!   the front's filled, its best at each median step count and the scenario's own named;
//! - [`DesignLayouts`] (`design_layouts.rs`): `spherestep design`, the best layouts' coils and
//!   magnets on the sphere, a panel each, under Figure 6's projection.
//!
//! Shared by the figures: `figure.rs` (the [`Figure`] trait, writing SVG and PNG atomically),
//! `style.rs` (font, colours, series styles: [`series_style`], marks, ticks), `chart.rs` (title,
//! axes and legend steps) and `labels.rs` (placing point labels clear of each other and of the
//! marks: [`place_labels`]).
//!
//! The files are private: the figures are used through the re-exports below; [`view`] and
//! [`batch_pictures`] are modules of their own.
//!
//! The figures take plain data (no planner types), implement [`Figure`], and are written with
//! [`write_figure`] (a temporary file, then a rename) or rendered to an SVG string with
//! [`render_svg`]. Indices are 0-based, angles in degrees.

mod axis_error;
pub mod batch_pictures;
mod chart;
mod commutation_plot;
mod design_front;
mod design_layouts;
mod figure;
mod labels;
mod loop_plot;
mod plot_csv;
mod style;
mod sweep_csv;
mod sweep_map;
pub mod view;
mod view_3d;
mod waypoint_plot;
mod well_plot;

pub use axis_error::{plan_series, AxisErrorPlot, ErrorSeries, ReferenceLine};
pub use commutation_plot::CommutationPlot;
pub use design_front::{DesignFront, FrontPoint};
pub use design_layouts::{DesignLayouts, LayoutPanel, MAX_PANELS};
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
