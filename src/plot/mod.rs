//! Figures of the paper reproduction and of the Pareto front, drawn with `plotters`.
//!
//! Data in, files out: each chart is a plain record (`LineChart`, `BarChart`, `ScatterChart`)
//! and each drawing function writes `<path>.svg` and `<path>.png` (900 x 600 px) and returns both
//! paths. Input is validated before anything is drawn: empty data, NaN or infinite values,
//! mismatched lengths and out-of-range indices give a typed [`PlotError`], never a panic.
//!
//! - Colours follow the series label, so one controller looks the same in every figure: labels
//!   whose first word is `mf`, `mb`, `rnd` or `ec` (any case) get fixed colours from the
//!   Okabe-Ito colour-blind-safe palette (several labels of one controller in a figure, such as
//!   `EC` and `EC, takeover`, get shades of it: the bare name keeps the colour); other labels
//!   take a palette colour chosen by a hash of the label (stable across figures unless two
//!   labels of one figure collide).
//! - Every file is written next to its target as `<name>.tmp.svg` / `<name>.tmp.png` and then
//!   renamed, so a killed process never leaves a truncated figure. Missing parent folders are
//!   created.
//! - The SVG is drawn once; the PNG is that SVG rendered by `resvg`, so the two always agree.
//!   Text is measured, and set in PNGs, with DejaVu Sans, embedded in the binary
//!   (`assets/DejaVuSans.ttf`, Bitstream Vera licence, see `assets/LICENSE-DejaVu.txt`). SVG
//!   files hold `<text>` elements in the viewer's `sans-serif` font at the same size.
//!
//! One module per concern: `axis` (ranges, ticks, number format), `colour` (label
//! colours), `text` (the text-measuring backend wrapper), `panel` (title, legend, mesh shared
//! by every chart), `line`, `bar` and `scatter` (one chart kind each) and `render` (the
//! SVG and PNG files).
//!
//! NOTE: `plotters`' own `ab_glyph` text measure takes the font size for the line height,
//! not for the em its SVG backend writes (`size / 1.24`), so labels would be laid out for text
//! about 6% too wide. The SVG backend is therefore wrapped in `Typeset`, which measures text
//! with the embedded font at the size the SVG declares.

use std::fs::{self, File};
use std::io::{self, Write};
use std::ops::Range;
use std::path::{Path, PathBuf};
use std::sync::OnceLock;

use ab_glyph::FontRef;
use plotters::coord::Shift;
use plotters::coord::ranged1d::{KeyPointHint, NoDefaultFormatting, Ranged, ValueFormatter};
use plotters::prelude::*;
use plotters::style::text_anchor::{HPos, Pos, VPos};
use plotters::style::{FontStyle, register_font};
use thiserror::Error;

mod axis;
mod bar;
mod colour;
mod front;
mod line;
mod panel;
mod place;
mod render;
mod scatter;
#[cfg(test)]
mod tests;
mod text;

use axis::*;
use bar::*;
use colour::*;
use front::*;
use line::*;
use panel::DrawResult;
use panel::*;
use render::*;
use scatter::*;
use text::Typeset;

/// Width of every figure, in pixels (the PNG size; the SVG uses the same user units).
pub const WIDTH: u32 = 900;
/// Height of every figure, in pixels.
pub const HEIGHT: u32 = 600;

/// DejaVu Sans: PNGs have no system fonts to fall back on.
static FONT_BYTES: &[u8] = include_bytes!("../assets/DejaVuSans.ttf");
/// The family name every text style here uses (and the SVG files name).
const FONT: &str = "sans-serif";
/// The embedded font's family name, which resvg resolves `sans-serif` to.
const FONT_FAMILY: &str = "DejaVu Sans";

/// `plotters` font size for an em of `px` pixels: its SVG backend writes `size / 1.24`.
const fn em(px: f64) -> f64 {
    px * 1.24
}
const TITLE_SIZE: f64 = em(22.0);
const DESC_SIZE: f64 = em(18.0);
const TICK_SIZE: f64 = em(16.0);
const LEGEND_SIZE: f64 = em(16.0);
const NOTE_SIZE: f64 = em(16.0);
const POINT_LABEL_SIZE: f64 = em(14.0);

const GRID: RGBColor = RGBColor(225, 225, 225);
const AXIS: RGBColor = RGBColor(60, 60, 60);

/// Failure to validate or write a figure. Each message names the figure (its path) and the bad
/// input.
#[derive(Debug, Error)]
pub enum PlotError {
    /// There is nothing to draw.
    #[error("figure '{figure}': {what} is empty; give at least one value")]
    Empty {
        /// The figure's path without extension.
        figure: String,
        /// Which input is empty.
        what: String,
    },
    /// A value is NaN, infinite, or (for a band or error bar) negative.
    #[error("figure '{figure}': {what}[{index}] is {value}; expected {expected}")]
    InvalidValue {
        /// The figure's path without extension.
        figure: String,
        /// Which input holds the value.
        what: String,
        /// Position of the value in that input.
        index: usize,
        /// The offending value.
        value: f64,
        /// What would be accepted.
        expected: &'static str,
    },
    /// Two inputs that go together have different lengths.
    #[error("figure '{figure}': {what} has {found} values but {expected} were expected")]
    LengthMismatch {
        /// The figure's path without extension.
        figure: String,
        /// Which input has the wrong length.
        what: String,
        /// The length it should have.
        expected: usize,
        /// The length it has.
        found: usize,
    },
    /// An index refers to no item.
    #[error("figure '{figure}': {what} refers to index {index} but there are only {len} items")]
    IndexOutOfRange {
        /// The figure's path without extension.
        figure: String,
        /// Which input holds the index.
        what: String,
        /// The offending index.
        index: usize,
        /// How many items there are.
        len: usize,
    },
    /// A logarithmic axis has no positive value left to draw.
    #[error(
        "figure '{figure}': the {axis} axis is logarithmic but no point has a positive {axis} \
         value; use a linear axis or give positive values"
    )]
    NoPositiveValues {
        /// The figure's path without extension.
        figure: String,
        /// `"x"` or `"y"`.
        axis: &'static str,
    },
    /// The embedded font could not be registered with `plotters`.
    #[error("registering the embedded DejaVu Sans font failed: {0}")]
    Font(String),
    /// `plotters` failed while drawing.
    #[error("drawing '{path}' failed: {message}")]
    Draw {
        /// The file being drawn.
        path: PathBuf,
        /// The backend's message.
        message: String,
    },
    /// Creating, writing or renaming a file failed.
    #[error("writing '{path}' failed: {source}")]
    Io {
        /// The file or folder concerned.
        path: PathBuf,
        /// The underlying error.
        source: io::Error,
    },
}

/// One curve of a [`LineChart`].
#[derive(Debug, Clone, PartialEq)]
pub struct Series {
    /// Legend text; also picks the colour (`mf`, `mb`, `rnd`, `ec` have fixed ones).
    pub label: String,
    /// Abscissae, drawn in the given order.
    pub x: Vec<f64>,
    /// Ordinates, one per `x`.
    pub y: Vec<f64>,
    /// Half-width of a translucent band drawn from `y - band` to `y + band` (e.g. a standard
    /// error), one per `x`, each finite and >= 0.
    pub band: Option<Vec<f64>>,
}

/// Curves sharing two axes, with a legend to the right of the plot.
#[derive(Debug, Clone, PartialEq)]
pub struct LineChart {
    /// Title above the plot (may be empty).
    pub title: String,
    /// Text under the x axis.
    pub x_label: String,
    /// Text beside the y axis.
    pub y_label: String,
    /// The curves, at least one.
    pub series: Vec<Series>,
    /// Logarithmic x axis: points with x <= 0 are left out.
    pub log_x: bool,
    /// Logarithmic y axis: points with y <= 0 are left out; bands are cut at the axis bottom.
    pub log_y: bool,
    /// Abscissae of thin vertical marks across the plot (e.g. the steps at which a run's world
    /// changes), each finite; marks outside the x axis are not drawn.
    pub x_marks: Vec<f64>,
}

/// One bar of a [`BarChart`].
#[derive(Debug, Clone, PartialEq)]
pub struct Bar {
    /// Text under the bar (or in the legend if the labels do not fit); also picks the colour.
    pub label: String,
    /// Height of the bar, from 0.
    pub value: f64,
    /// Half-length of an error bar centred on `value` (finite, >= 0).
    pub error: Option<f64>,
    /// Bars with the same group are drawn side by side, groups in order of first appearance,
    /// with the group name under them.
    pub group: String,
}

/// Grouped bars with error bars and significance brackets.
#[derive(Debug, Clone, PartialEq)]
pub struct BarChart {
    /// Title above the plot (may be empty).
    pub title: String,
    /// Text beside the y axis.
    pub y_label: String,
    /// The bars, at least one.
    pub bars: Vec<Bar>,
    /// Significance marks `(i, j, text)`: a bracket between bars `i` and `j` (indices into
    /// `bars`) with `text` above it, e.g. `"***"` or `"n.s."`; with `i == j` the text alone
    /// stands above bar `i`. Overlapping brackets are stacked.
    pub annotations: Vec<(usize, usize, String)>,
}

/// Bar charts side by side, one panel per group (e.g. the two-step task's stay probabilities
/// of each controller), all on one y axis so that heights compare across panels.
#[derive(Debug, Clone, PartialEq)]
pub struct BarPanels {
    /// Title above the panels (may be empty).
    pub title: String,
    /// The panels, at least one, each a bar chart with its own title; laid out in a grid.
    pub panels: Vec<BarChart>,
}

/// Points on two axes, with a highlighted subset (a Pareto front) and an optional marked point
/// (its knee).
#[derive(Debug, Clone, PartialEq)]
pub struct ScatterChart {
    /// Title above the plot (may be empty).
    pub title: String,
    /// Text under the x axis.
    pub x_label: String,
    /// Text beside the y axis.
    pub y_label: String,
    /// All points `(x, y)`, at least one.
    pub points: Vec<(f64, f64)>,
    /// Indices into `points` of the front: drawn larger and joined in order of x.
    pub highlighted: Vec<usize>,
    /// Index into `points` of the knee point: ringed and labelled "knee".
    pub marked: Option<usize>,
    /// Either empty or one text per point (e.g. its kappa); shown next to highlighted and
    /// marked points where there is room.
    pub point_labels: Vec<String>,
    /// Logarithmic x axis: points with x <= 0 are left out.
    pub log_x: bool,
    /// Logarithmic y axis: points with y <= 0 are left out.
    pub log_y: bool,
}

/// One panel of a [`FrontChart`]: the configurations of one group, on their own axes.
#[derive(Debug, Clone, PartialEq)]
pub struct FrontPanel {
    /// Text above the panel (e.g. `interaction=takeover`; may be empty).
    pub title: String,
    /// All points `(x, y)`, at least one.
    pub points: Vec<(f64, f64)>,
    /// With [`FrontChart::colour`], one value per point placing it on the colour scale (NaN:
    /// grey); otherwise ignored (may be empty).
    pub colour_values: Vec<f64>,
    /// Indices into `points` of the front: ringed (and joined in order of x with
    /// [`FrontChart::join_front`]).
    pub front: Vec<usize>,
    /// Index into `points` of the knee: ringed wider and labelled "knee".
    pub knee: Option<usize>,
    /// Either empty or one text per point; front points are labelled where a label fits
    /// without covering another label or a point, and left unlabelled otherwise.
    pub labels: Vec<String>,
}

/// Pareto fronts, one panel per group, sharing a colour scale.
#[derive(Debug, Clone, PartialEq)]
pub struct FrontChart {
    /// Title above the panels (may be empty).
    pub title: String,
    /// Text under each panel's x axis.
    pub x_label: String,
    /// Text beside each panel's y axis.
    pub y_label: String,
    /// Name of the number the points' `colour_values` hold, shown over a colour bar (viridis,
    /// shared by every panel); `None` draws every point grey.
    pub colour: Option<String>,
    /// The panels, at least one, laid out in a grid in order.
    pub panels: Vec<FrontPanel>,
    /// Join each front's points in order of x: right for a front over the two plotted
    /// objectives; over more, the front seen in two of them zigzags, so its points are only
    /// ringed.
    pub join_front: bool,
    /// Logarithmic x axes: points with x <= 0 are left out.
    pub log_x: bool,
    /// Logarithmic y axes: points with y <= 0 are left out.
    pub log_y: bool,
}

/// How the curves of a [`LineChart`] are coloured.
#[derive(Debug, Clone, PartialEq)]
pub enum LineColours {
    /// By label (controllers keep their colours), with a legend of at most a few entries and
    /// `+N more` for the rest.
    Labels,
    /// By a number per series on a continuous colour scale (viridis) with a colour bar titled
    /// `title` in place of the legend: for a swept parameter, where a legend of tens of values
    /// could not be read.
    Scale {
        /// Text over the colour bar (the swept column).
        title: String,
        /// One value per series.
        values: Vec<f64>,
    },
}

/// Writes `chart` to `path_without_ext` + `.svg` and `.png`; returns both paths.
///
/// # Errors
/// [`PlotError`] if there are no panels, a panel has no points, a coordinate is not finite, an
/// index is out of range, labels or colour values are neither empty nor one per point (colour
/// values: one per point whenever the chart has a colour scale), a logarithmic axis has no
/// positive value, or a file cannot be written.
pub fn front_chart(chart: &FrontChart, path_without_ext: &Path) -> Result<Vec<PathBuf>, PlotError> {
    let figure = FrontFigure::new(chart, &figure_name(path_without_ext))?;
    write_figure(&figure, path_without_ext)
}

/// [`line_chart`] with the curves coloured as `colours` says.
///
/// # Errors
/// As [`line_chart`], and if a scale does not have one finite value per series.
pub fn line_chart_coloured(
    chart: &LineChart,
    colours: &LineColours,
    path_without_ext: &Path,
) -> Result<Vec<PathBuf>, PlotError> {
    let figure = LineFigure::with_colours(chart, colours, &figure_name(path_without_ext))?;
    write_figure(&figure, path_without_ext)
}

/// Writes `chart` to `path_without_ext` + `.svg` and `.png`; returns both paths.
///
/// # Errors
/// [`PlotError`] if the chart has no series, a series is empty, lengths differ, a value is not
/// finite, a band is negative, a logarithmic axis has no positive value, or a file cannot be
/// written.
pub fn line_chart(chart: &LineChart, path_without_ext: &Path) -> Result<Vec<PathBuf>, PlotError> {
    let figure = LineFigure::new(chart, &figure_name(path_without_ext))?;
    write_figure(&figure, path_without_ext)
}

/// Writes `chart` to `path_without_ext` + `.svg` and `.png`; returns both paths.
///
/// # Errors
/// [`PlotError`] if there are no bars, a value or error is not finite, an error is negative,
/// an annotation names a missing bar, or a file cannot be written.
pub fn bar_chart(chart: &BarChart, path_without_ext: &Path) -> Result<Vec<PathBuf>, PlotError> {
    let figure = BarFigure::new(chart, &figure_name(path_without_ext))?;
    write_figure(&figure, path_without_ext)
}

/// Writes `chart` to `path_without_ext` + `.svg` and `.png`; returns both paths.
///
/// # Errors
/// [`PlotError`] if there are no panels, or as [`bar_chart`] for a panel.
pub fn bar_panels(chart: &BarPanels, path_without_ext: &Path) -> Result<Vec<PathBuf>, PlotError> {
    let figure = bar::PanelsFigure::new(chart, &figure_name(path_without_ext))?;
    write_figure(&figure, path_without_ext)
}

/// Writes `chart` to `path_without_ext` + `.svg` and `.png`; returns both paths.
///
/// # Errors
/// [`PlotError`] if there are no points, a coordinate is not finite, an index is out of range,
/// `point_labels` is neither empty nor one per point, a logarithmic axis has no positive
/// value, or a file cannot be written.
pub fn scatter_chart(
    chart: &ScatterChart,
    path_without_ext: &Path,
) -> Result<Vec<PathBuf>, PlotError> {
    let figure = ScatterFigure::new(chart, &figure_name(path_without_ext))?;
    write_figure(&figure, path_without_ext)
}

// ---------------------------------------------------------------------------------------------
// Validation

/// The name errors use for a figure: its path without extension.
fn figure_name(path: &Path) -> String {
    path.display().to_string()
}

/// Every value finite (and >= 0 if `non_negative`).
fn check_values(
    figure: &str,
    what: &str,
    values: &[f64],
    non_negative: bool,
) -> Result<(), PlotError> {
    let expected = if non_negative {
        "a finite number >= 0"
    } else {
        "a finite number"
    };
    match values
        .iter()
        .position(|v| !v.is_finite() || (non_negative && *v < 0.0))
    {
        Some(index) => Err(PlotError::InvalidValue {
            figure: figure.to_string(),
            what: what.to_string(),
            index,
            value: values[index],
            expected,
        }),
        None => Ok(()),
    }
}

fn check_len(figure: &str, what: &str, expected: usize, found: usize) -> Result<(), PlotError> {
    if expected == found {
        Ok(())
    } else {
        Err(PlotError::LengthMismatch {
            figure: figure.to_string(),
            what: what.to_string(),
            expected,
            found,
        })
    }
}

fn check_index(figure: &str, what: &str, index: usize, len: usize) -> Result<(), PlotError> {
    if index < len {
        Ok(())
    } else {
        Err(PlotError::IndexOutOfRange {
            figure: figure.to_string(),
            what: what.to_string(),
            index,
            len,
        })
    }
}

fn empty(figure: &str, what: &str) -> PlotError {
    PlotError::Empty {
        figure: figure.to_string(),
        what: what.to_string(),
    }
}

/// Whether a point can be drawn on the given axes (positive coordinates on log axes).
fn drawable(x: f64, y: f64, log_x: bool, log_y: bool) -> bool {
    (!log_x || x > 0.0) && (!log_y || y > 0.0)
}

/// The error for a log chart with no drawable point: names the axis that rules them all out.
fn no_positive(figure: &str, xs: &[f64], log_x: bool) -> PlotError {
    let axis = if log_x && xs.iter().all(|&x| x <= 0.0) {
        "x"
    } else {
        "y"
    };
    PlotError::NoPositiveValues {
        figure: figure.to_string(),
        axis,
    }
}

/// Smallest and largest of `values` (which must not be empty).
fn extent(values: impl Iterator<Item = f64>) -> (f64, f64) {
    values.fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), v| {
        (lo.min(v), hi.max(v))
    })
}
