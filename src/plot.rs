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
//! - Text is measured and (in PNGs) rasterised with DejaVu Sans, embedded in the binary
//!   (`assets/DejaVuSans.ttf`, Bitstream Vera licence, see `assets/LICENSE-DejaVu.txt`). SVG
//!   files hold `<text>` elements in the viewer's `sans-serif` font at the same size.
//!
//! NOTE: `plotters`' own `ab_glyph` text drawing drops each glyph's side bearing and rounds
//! baselines per glyph, which makes small text ragged ("T otal", raised full stops). Both
//! backends are therefore wrapped in `Typeset`, which measures text with the embedded font for
//! layout and, for PNGs, rasterises it with `ab_glyph` directly, placed as the SVG text is.

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

use typeset::Typeset;

/// Width of every figure, in pixels (the PNG size; the SVG uses the same user units).
pub const WIDTH: u32 = 900;
/// Height of every figure, in pixels.
pub const HEIGHT: u32 = 600;

/// DejaVu Sans: PNGs have no system fonts to fall back on.
static FONT_BYTES: &[u8] = include_bytes!("assets/DejaVuSans.ttf");
/// The family name every text style here uses (and the SVG files name).
const FONT: &str = "sans-serif";

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
/// DejaVu Sans x-height in ems, to centre text vertically as SVG viewers do (`0.5ex`).
const X_HEIGHT: f32 = 0.547;
/// Baseline below the anchor for top-anchored text, as plotters' SVG backend writes it.
const TOP_BASELINE: f32 = 0.76;

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
// Colours

/// Fixed colours of the four controllers (Okabe-Ito: blue, vermillion, bluish green, purple).
const FIXED_COLOURS: [(&str, RGBColor); 4] = [
    ("mf", RGBColor(0, 114, 178)),
    ("mb", RGBColor(213, 94, 0)),
    ("rnd", RGBColor(0, 158, 115)),
    ("ec", RGBColor(204, 121, 167)),
];

/// Colours for other labels, none close to the fixed ones.
const PALETTE: [RGBColor; 8] = [
    RGBColor(230, 159, 0),
    RGBColor(86, 180, 233),
    RGBColor(64, 64, 64),
    RGBColor(140, 86, 75),
    RGBColor(117, 112, 179),
    RGBColor(128, 128, 0),
    RGBColor(165, 0, 38),
    RGBColor(0, 128, 128),
];

/// The controller (`mf`, `mb`, `rnd`, `ec`) a label's first word names, with its colour.
fn controller(label: &str) -> Option<(&'static str, RGBColor)> {
    let lower = label.trim().to_lowercase();
    let first = lower.split(|c: char| !c.is_alphanumeric()).next()?;
    FIXED_COLOURS
        .iter()
        .copied()
        .find(|(name, _)| *name == first)
}

/// The `k`-th variant of a controller's colour: itself, then alternately darker and lighter.
fn shade(colour: RGBColor, k: usize) -> RGBColor {
    let RGBColor(r, g, b) = colour;
    let step = k.div_ceil(2) as f64;
    let towards = |c: u8, target: f64, amount: f64| {
        (f64::from(c) + (target - f64::from(c)) * amount).round() as u8
    };
    if k == 0 {
        colour
    } else if k % 2 == 1 {
        let amount = (0.4 * step).min(0.8);
        RGBColor(
            towards(r, 0.0, amount),
            towards(g, 0.0, amount),
            towards(b, 0.0, amount),
        )
    } else {
        let amount = (0.45 * step).min(0.8);
        RGBColor(
            towards(r, 255.0, amount),
            towards(g, 255.0, amount),
            towards(b, 255.0, amount),
        )
    }
}

/// FNV-1a: a hash that, unlike `DefaultHasher`, is fixed across Rust versions.
fn fnv1a(text: &str) -> u64 {
    text.bytes().fold(0xcbf2_9ce4_8422_2325, |hash, byte| {
        (hash ^ u64::from(byte)).wrapping_mul(0x0100_0000_01b3)
    })
}

/// One colour per label; equal labels share a colour.
///
/// A label naming a controller gets that controller's colour; when several distinct labels of
/// one figure name the same controller (`"EC"`, `"EC, takeover"`), the bare name keeps the
/// colour and the others get darker and lighter shades in order of appearance. Other labels
/// take a palette colour picked by a hash of the label, probing past colours already taken in
/// the figure.
fn label_colours<S: AsRef<str>>(labels: &[S]) -> Vec<RGBColor> {
    let mut distinct: Vec<&str> = Vec::new();
    for label in labels {
        if !distinct.contains(&label.as_ref()) {
            distinct.push(label.as_ref());
        }
    }
    let mut taken: Vec<(&str, RGBColor)> = Vec::new();
    for (name, base) in FIXED_COLOURS {
        let mut family: Vec<&str> = distinct
            .iter()
            .copied()
            .filter(|l| controller(l).is_some_and(|(n, _)| n == name))
            .collect();
        // The bare controller name first (a stable sort keeps the others in order).
        family.sort_by_key(|l| !l.trim().eq_ignore_ascii_case(name));
        for (k, label) in family.into_iter().enumerate() {
            taken.push((label, shade(base, k)));
        }
    }
    for label in distinct {
        if taken.iter().any(|(l, _)| *l == label) {
            continue;
        }
        // The palette is tiny, so the remainder fits any integer type.
        let start = (fnv1a(label) % PALETTE.len() as u64) as usize;
        let colour = (0..PALETTE.len())
            .map(|k| PALETTE[(start + k) % PALETTE.len()])
            .find(|c| taken.iter().all(|(_, t)| t != c))
            .unwrap_or(PALETTE[start]);
        taken.push((label, colour));
    }
    labels
        .iter()
        .map(|label| {
            taken
                .iter()
                .find(|(l, _)| *l == label.as_ref())
                .map_or(PALETTE[0], |&(_, c)| c)
        })
        .collect()
}

// ---------------------------------------------------------------------------------------------
// Axes

/// A linear or logarithmic axis over `lo..hi` (`lo > 0` when logarithmic), with its own tick
/// choice and number format.
#[derive(Debug, Clone, Copy)]
struct Axis {
    lo: f64,
    hi: f64,
    log: bool,
}

impl Axis {
    /// An axis covering `min..=max` with a small margin on both sides (none below a bar
    /// chart's zero: `pad_low = false`).
    fn covering(min: f64, max: f64, log: bool, pad_low: bool) -> Self {
        if log {
            let (min, max) = if max > min {
                (min, max)
            } else {
                (min / 2.0, max * 2.0)
            };
            let factor = (max / min).powf(0.05);
            let lo = if pad_low { min / factor } else { min };
            Self {
                lo,
                hi: max * factor,
                log,
            }
        } else {
            let (min, max) = if max > min {
                (min, max)
            } else {
                let half = if min == 0.0 { 1.0 } else { min.abs() * 0.1 };
                (min - half, max + half)
            };
            let pad = (max - min) * 0.05;
            let lo = if pad_low { min - pad } else { min };
            Self {
                lo,
                hi: max + pad,
                log,
            }
        }
    }

    /// Position of `v` along the axis, 0 at `lo` and 1 at `hi`; non-positive values on a log
    /// axis go to `lo`.
    fn fraction(&self, v: f64) -> f64 {
        if self.log {
            (v.max(self.lo).ln() - self.lo.ln()) / (self.hi.ln() - self.lo.ln())
        } else {
            (v - self.lo) / (self.hi - self.lo)
        }
    }

    /// Whether tick labels are written in scientific notation: for large magnitudes, and for
    /// small ones (or log axes reaching them), so that one axis never mixes styles.
    fn scientific(&self) -> bool {
        let largest = self.lo.abs().max(self.hi.abs());
        !(1e-3..1e5).contains(&largest) || (self.log && self.lo < 1e-3)
    }

    /// The label of tick value `v`.
    fn format_tick(&self, v: f64) -> String {
        if self.scientific() && v != 0.0 {
            format_scientific(v)
        } else {
            format_number(v)
        }
    }

    /// At most `max` tick values inside the axis.
    fn ticks(&self, max: usize) -> Vec<f64> {
        if self.log {
            log_ticks(self.lo, self.hi, max)
        } else {
            linear_ticks(self.lo, self.hi, max)
        }
    }
}

impl Ranged for Axis {
    type FormatOption = NoDefaultFormatting;
    type ValueType = f64;

    fn map(&self, value: &f64, limit: (i32, i32)) -> i32 {
        let f = self.fraction(*value);
        let pixel = f64::from(limit.0) + f * f64::from(limit.1 - limit.0);
        // NOTE: clamped so a stray value can never overflow the backend's i32 coordinates.
        pixel.round().clamp(-1.0e6, 1.0e6) as i32
    }

    fn key_points<Hint: KeyPointHint>(&self, hint: Hint) -> Vec<f64> {
        // Only the labelled (bold) grid lines are drawn; the light ones would clutter.
        if hint.weight().allow_light_points() {
            return Vec::new();
        }
        self.ticks(hint.max_num_points())
    }

    fn range(&self) -> Range<f64> {
        self.lo..self.hi
    }
}

impl ValueFormatter<f64> for Axis {
    fn format(value: &f64) -> String {
        format_number(*value)
    }

    fn format_ext(&self, value: &f64) -> String {
        self.format_tick(*value)
    }
}

/// Round numbers between `lo` and `hi`, at most `max` (and at most 8) of them.
fn linear_ticks(lo: f64, hi: f64, max: usize) -> Vec<f64> {
    if max == 0 || !lo.is_finite() || !hi.is_finite() || hi <= lo {
        return Vec::new();
    }
    let want = max.clamp(2, 8);
    let raw = (hi - lo) / (want - 1) as f64;
    let magnitude = 10f64.powf(raw.log10().floor());
    let step = [1.0, 2.0, 2.5, 5.0, 10.0]
        .iter()
        .map(|m| m * magnitude)
        .find(|&s| s >= raw * (1.0 - 1e-9))
        .unwrap_or(10.0 * magnitude);
    let first = (lo / step - 1e-9).ceil();
    let mut ticks = Vec::new();
    for k in 0..=want {
        let t = (first + k as f64) * step;
        if t > hi + step * 1e-9 {
            break;
        }
        // Turn -0.0 into 0.0 so it prints as "0".
        ticks.push(if t == 0.0 { 0.0 } else { t });
    }
    ticks.truncate(max);
    ticks
}

/// Powers of ten (with 2 and 5 multiples on short ranges, every n-th decade on long ones)
/// between `lo > 0` and `hi`, at most `max` of them; round linear values inside one decade.
fn log_ticks(lo: f64, hi: f64, max: usize) -> Vec<f64> {
    if max == 0 || !hi.is_finite() || lo <= 0.0 || hi <= lo {
        return Vec::new();
    }
    let first = lo.log10().floor() as i32;
    let last = hi.log10().ceil() as i32;
    let within = |t: f64| t >= lo * (1.0 - 1e-9) && t <= hi * (1.0 + 1e-9);
    let collect = |mantissas: &[f64], every: i32| -> Vec<f64> {
        (first..=last)
            .filter(|e| e.rem_euclid(every) == 0)
            .flat_map(|e| mantissas.iter().map(move |m| m * 10f64.powi(e)))
            .filter(|&t| within(t))
            .collect()
    };
    let dense = collect(&[1.0, 2.0, 5.0], 1);
    if dense.len() >= 3 && dense.len() <= max {
        return dense;
    }
    for every in 1..=(last - first).max(1) {
        let decades = collect(&[1.0], every);
        if decades.len() <= max && decades.len() >= 2 {
            return decades;
        }
    }
    if dense.len() >= 2 && dense.len() <= max {
        return dense;
    }
    linear_ticks(lo, hi, max)
}

/// Shortest plain (or, for very large and very small magnitudes, scientific) text that reads
/// back as `v` to nine significant digits.
fn format_number(v: f64) -> String {
    if v == 0.0 {
        return "0".to_string();
    }
    if !v.is_finite() {
        return format!("{v}");
    }
    let tolerance = v.abs() * 1e-9;
    let reads_back = |s: &str| s.parse::<f64>().is_ok_and(|p| (p - v).abs() <= tolerance);
    if (1e-3..1e5).contains(&v.abs()) {
        (0..=6)
            .map(|d| format!("{v:.d$}"))
            .find(|s| reads_back(s))
            .unwrap_or_else(|| format!("{v:.4}"))
    } else {
        format_scientific(v)
    }
}

/// Shortest scientific text (`2.5e-5`) that reads back as `v` to nine significant digits.
fn format_scientific(v: f64) -> String {
    let tolerance = v.abs() * 1e-9;
    (0..=6)
        .map(|d| format!("{v:.d$e}"))
        .find(|s| s.parse::<f64>().is_ok_and(|p| (p - v).abs() <= tolerance))
        .unwrap_or_else(|| format!("{v:.3e}"))
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

// ---------------------------------------------------------------------------------------------
// Writing

/// A validated chart that can draw itself on any `plotters` backend.
trait Figure {
    fn draw<DB: DrawingBackend>(
        &self,
        root: &DrawingArea<DB, Shift>,
    ) -> Result<(), DrawingAreaErrorKind<DB::ErrorType>>;
}

/// The embedded font, parsed once per process. It is also registered with `plotters` under
/// `sans-serif`, so any text that bypasses `Typeset` still renders.
fn font() -> Result<&'static FontRef<'static>, PlotError> {
    static FONT_REF: OnceLock<Result<FontRef<'static>, String>> = OnceLock::new();
    FONT_REF
        .get_or_init(|| {
            let invalid = |_| "the embedded file is not a valid TrueType font".to_string();
            register_font(FONT, FontStyle::Normal, FONT_BYTES).map_err(invalid)?;
            FontRef::try_from_slice(FONT_BYTES).map_err(|e| e.to_string())
        })
        .as_ref()
        .map_err(|message| PlotError::Font(message.clone()))
}

/// `base` with `suffix` appended (not `with_extension`, which would eat a `.5` in `kappa_0.5`).
fn with_suffix(base: &Path, suffix: &str) -> PathBuf {
    let mut name = base.as_os_str().to_owned();
    name.push(suffix);
    PathBuf::from(name)
}

fn io_error(path: &Path) -> impl FnOnce(io::Error) -> PlotError + '_ {
    move |source| PlotError::Io {
        path: path.to_path_buf(),
        source,
    }
}

/// Draws `figure` into `<base>.svg` and `<base>.png`, each through a temporary file.
fn write_figure<F: Figure>(figure: &F, base: &Path) -> Result<Vec<PathBuf>, PlotError> {
    let font = font()?;
    if let Some(parent) = base.parent().filter(|p| !p.as_os_str().is_empty()) {
        fs::create_dir_all(parent).map_err(io_error(parent))?;
    }
    let svg = with_suffix(base, ".svg");
    let png = with_suffix(base, ".png");
    write_svg(figure, font, &svg, &with_suffix(base, ".tmp.svg"))?;
    write_png(figure, font, &png, &with_suffix(base, ".tmp.png"))?;
    Ok(vec![svg, png])
}

fn write_svg<F: Figure>(
    figure: &F,
    font: &'static FontRef<'static>,
    target: &Path,
    tmp: &Path,
) -> Result<(), PlotError> {
    let mut text = String::new();
    {
        let root = Typeset {
            inner: SVGBackend::with_string(&mut text, (WIDTH, HEIGHT)),
            font,
            raster: false,
        }
        .into_drawing_area();
        figure
            .draw(&root)
            .and_then(|()| root.present())
            .map_err(|e| PlotError::Draw {
                path: target.to_path_buf(),
                message: e.to_string(),
            })?;
    }
    let written = File::create(tmp)
        .and_then(|mut file| {
            file.write_all(text.as_bytes())?;
            file.sync_all()
        })
        .and_then(|()| fs::rename(tmp, target));
    written.map_err(|source| {
        // Best effort: the error that matters is the one reported.
        let _ = fs::remove_file(tmp);
        PlotError::Io {
            path: target.to_path_buf(),
            source,
        }
    })
}

fn write_png<F: Figure>(
    figure: &F,
    font: &'static FontRef<'static>,
    target: &Path,
    tmp: &Path,
) -> Result<(), PlotError> {
    let drawn = {
        let root = Typeset {
            inner: BitMapBackend::new(tmp, (WIDTH, HEIGHT)),
            font,
            raster: true,
        }
        .into_drawing_area();
        figure
            .draw(&root)
            .and_then(|()| root.present())
            .map_err(|e| e.to_string())
        // NOTE: on error the backend still saves what it has when dropped here; the partial
        // temporary file is removed below and never renamed.
    };
    if let Err(message) = drawn {
        let _ = fs::remove_file(tmp);
        return Err(PlotError::Draw {
            path: target.to_path_buf(),
            message,
        });
    }
    let written = File::open(tmp)
        .and_then(|file| file.sync_all())
        .and_then(|()| fs::rename(tmp, target));
    written.map_err(|source| {
        let _ = fs::remove_file(tmp);
        PlotError::Io {
            path: target.to_path_buf(),
            source,
        }
    })
}

mod typeset {
    //! The text-measuring, text-drawing backend wrapper (its own module because `plotters`'
    //! `Color` and `plotters_backend`'s `BackendStyle` both name a `stroke_width` method).

    use ab_glyph::{Font, FontRef, PxScale, ScaleFont, point};
    use plotters::prelude::DrawingBackend;
    use plotters::style::text_anchor::{HPos, VPos};
    use plotters_backend::{
        BackendColor, BackendCoord, BackendStyle, BackendTextStyle, DrawingErrorKind,
    };

    use super::{TOP_BASELINE, X_HEIGHT};

    /// A drawing backend that measures text with the embedded font and, if `raster`, draws text
    /// itself; everything else goes to `inner` unchanged (so SVG keeps its native shapes and text).
    pub(super) struct Typeset<B> {
        pub(super) inner: B,
        pub(super) font: &'static FontRef<'static>,
        pub(super) raster: bool,
    }

    /// Glyphs of one line of text laid out from the origin along the baseline, and its width.
    pub(super) fn layout_glyphs(
        font: &FontRef<'static>,
        text: &str,
        size: f64,
    ) -> (Vec<ab_glyph::Glyph>, f32) {
        let em_px = (size / 1.24) as f32;
        // ab_glyph scales by the font's height (ascent - descent), not by its em.
        let units_per_em = font.units_per_em().unwrap_or(2048.0);
        let scale = PxScale::from(em_px * font.height_unscaled() / units_per_em);
        let scaled = font.as_scaled(scale);
        let mut glyphs = Vec::with_capacity(text.len());
        let mut caret = 0.0;
        let mut previous = None;
        for c in text.chars() {
            let id = scaled.glyph_id(c);
            if let Some(previous) = previous {
                caret += scaled.kern(previous, id);
            }
            glyphs.push(id.with_scale_and_position(scale, point(caret, 0.0)));
            caret += scaled.h_advance(id);
            previous = Some(id);
        }
        (glyphs, caret)
    }

    impl<B: DrawingBackend> DrawingBackend for Typeset<B> {
        type ErrorType = B::ErrorType;

        fn get_size(&self) -> (u32, u32) {
            self.inner.get_size()
        }

        fn ensure_prepared(&mut self) -> Result<(), DrawingErrorKind<B::ErrorType>> {
            self.inner.ensure_prepared()
        }

        fn present(&mut self) -> Result<(), DrawingErrorKind<B::ErrorType>> {
            self.inner.present()
        }

        fn draw_pixel(
            &mut self,
            point: BackendCoord,
            color: BackendColor,
        ) -> Result<(), DrawingErrorKind<B::ErrorType>> {
            self.inner.draw_pixel(point, color)
        }

        fn draw_line<S: BackendStyle>(
            &mut self,
            from: BackendCoord,
            to: BackendCoord,
            style: &S,
        ) -> Result<(), DrawingErrorKind<B::ErrorType>> {
            self.inner.draw_line(from, to, style)
        }

        fn draw_rect<S: BackendStyle>(
            &mut self,
            upper_left: BackendCoord,
            bottom_right: BackendCoord,
            style: &S,
            fill: bool,
        ) -> Result<(), DrawingErrorKind<B::ErrorType>> {
            self.inner.draw_rect(upper_left, bottom_right, style, fill)
        }

        fn draw_path<S: BackendStyle, I: IntoIterator<Item = BackendCoord>>(
            &mut self,
            path: I,
            style: &S,
        ) -> Result<(), DrawingErrorKind<B::ErrorType>> {
            self.inner.draw_path(path, style)
        }

        fn draw_circle<S: BackendStyle>(
            &mut self,
            center: BackendCoord,
            radius: u32,
            style: &S,
            fill: bool,
        ) -> Result<(), DrawingErrorKind<B::ErrorType>> {
            self.inner.draw_circle(center, radius, style, fill)
        }

        fn fill_polygon<S: BackendStyle, I: IntoIterator<Item = BackendCoord>>(
            &mut self,
            vert: I,
            style: &S,
        ) -> Result<(), DrawingErrorKind<B::ErrorType>> {
            self.inner.fill_polygon(vert, style)
        }

        fn blit_bitmap(
            &mut self,
            pos: BackendCoord,
            size: (u32, u32),
            src: &[u8],
        ) -> Result<(), DrawingErrorKind<B::ErrorType>> {
            self.inner.blit_bitmap(pos, size, src)
        }

        fn estimate_text_size<S: BackendTextStyle>(
            &self,
            text: &str,
            style: &S,
        ) -> Result<(u32, u32), DrawingErrorKind<B::ErrorType>> {
            let (_, width) = layout_glyphs(self.font, text, style.size());
            let em_px = style.size() / 1.24;
            let height = f64::from(self.font.height_unscaled())
                / f64::from(self.font.units_per_em().unwrap_or(2048.0))
                * em_px;
            Ok((width.ceil() as u32, height.ceil() as u32))
        }

        fn draw_text<S: BackendTextStyle>(
            &mut self,
            text: &str,
            style: &S,
            pos: BackendCoord,
        ) -> Result<(), DrawingErrorKind<B::ErrorType>> {
            let colour = style.color();
            if !self.raster {
                return self.inner.draw_text(text, style, pos);
            }
            if colour.alpha == 0.0 {
                return Ok(());
            }
            let (glyphs, width) = layout_glyphs(self.font, text, style.size());
            let em_px = (style.size() / 1.24) as f32;
            // Anchor as plotters' SVG backend does (text-anchor and dy), so both files agree.
            let dx = match style.anchor().h_pos {
                HPos::Left => 0.0,
                HPos::Center => -width / 2.0,
                HPos::Right => -width,
            };
            let baseline = match style.anchor().v_pos {
                VPos::Top => TOP_BASELINE * em_px,
                VPos::Center => 0.5 * X_HEIGHT * em_px,
                VPos::Bottom => -0.5 * X_HEIGHT * em_px,
            };
            let transform = style.transform();
            let (w, h) = self.inner.get_size();
            let mut pixels: Vec<(BackendCoord, f32)> = Vec::new();
            for mut glyph in glyphs {
                glyph.position.x += dx;
                glyph.position.y += baseline;
                if let Some(outlined) = self.font.outline_glyph(glyph) {
                    let bounds = outlined.px_bounds();
                    outlined.draw(|x, y, coverage| {
                        if coverage > 0.0 {
                            let tx = bounds.min.x as i32 + x as i32;
                            let ty = bounds.min.y as i32 + y as i32;
                            pixels.push((transform.transform(tx, ty), coverage));
                        }
                    });
                }
            }
            for ((x, y), coverage) in pixels {
                let (x, y) = (pos.0 + x, pos.1 + y);
                if x >= 0 && y >= 0 && (x as u32) < w && (y as u32) < h {
                    let color = BackendColor {
                        alpha: colour.alpha * f64::from(coverage.min(1.0)),
                        rgb: colour.rgb,
                    };
                    self.inner.draw_pixel((x, y), color)?;
                }
            }
            Ok(())
        }
    }
}

// ---------------------------------------------------------------------------------------------
// Shared drawing helpers

fn text_style(size: f64) -> TextStyle<'static> {
    TextStyle::from((FONT, size).into_font()).color(&BLACK)
}

type DrawResult<DB> = Result<(), DrawingAreaErrorKind<<DB as DrawingBackend>::ErrorType>>;

/// Pixel width of `text`.
fn text_width<DB: DrawingBackend>(
    area: &DrawingArea<DB, Shift>,
    text: &str,
    style: &TextStyle,
) -> Result<u32, DrawingAreaErrorKind<DB::ErrorType>> {
    Ok(area.estimate_text_size(text, style)?.0)
}

/// `text`, shortened with an ellipsis until it is at most `max_width` pixels wide.
fn fit_text<DB: DrawingBackend>(
    area: &DrawingArea<DB, Shift>,
    text: &str,
    style: &TextStyle,
    max_width: u32,
) -> Result<String, DrawingAreaErrorKind<DB::ErrorType>> {
    if text_width(area, text, style)? <= max_width {
        return Ok(text.to_string());
    }
    let mut chars: Vec<char> = text.chars().collect();
    while !chars.is_empty() {
        chars.pop();
        let candidate: String = chars.iter().collect::<String>() + "…";
        if text_width(area, &candidate, style)? <= max_width {
            return Ok(candidate);
        }
    }
    Ok(String::new())
}

/// The area under the title (the whole figure if the title is empty), on a white background.
fn titled_area<DB: DrawingBackend>(
    root: &DrawingArea<DB, Shift>,
    title: &str,
) -> Result<DrawingArea<DB, Shift>, DrawingAreaErrorKind<DB::ErrorType>> {
    root.fill(&WHITE)?;
    let root = root.margin(12, 4, 4, 4);
    if title.trim().is_empty() {
        return Ok(root);
    }
    let style = text_style(TITLE_SIZE);
    let (width, _) = root.dim_in_pixel();
    let title = fit_text(&root, title, &style, width.saturating_sub(20))?;
    root.titled(&title, style)
}

/// Width the y label area needs for these ticks, their labels and the rotated axis text.
fn y_label_area_width<DB: DrawingBackend>(
    area: &DrawingArea<DB, Shift>,
    axis: &Axis,
    ticks: usize,
) -> Result<u32, DrawingAreaErrorKind<DB::ErrorType>> {
    let style = text_style(TICK_SIZE);
    let mut widest = 0;
    for tick in axis.ticks(ticks) {
        widest = widest.max(text_width(area, &axis.format_tick(tick), &style)?);
    }
    Ok(widest + 16 + DESC_SIZE as u32 + 12)
}

/// How many x ticks fit side by side in `plot_width` pixels without labels touching.
fn x_tick_count<DB: DrawingBackend>(
    area: &DrawingArea<DB, Shift>,
    axis: &Axis,
    plot_width: u32,
) -> Result<usize, DrawingAreaErrorKind<DB::ErrorType>> {
    let style = text_style(TICK_SIZE);
    for count in (2..=10).rev() {
        let ticks = axis.ticks(count);
        let mut widest = 0;
        for tick in &ticks {
            widest = widest.max(text_width(area, &axis.format_tick(*tick), &style)?);
        }
        if (widest + 24) as usize * ticks.len() <= plot_width as usize {
            return Ok(count);
        }
    }
    Ok(2)
}

/// How a legend entry's swatch looks.
#[derive(Clone, Copy)]
enum Swatch {
    /// A line, over a translucent band if `band`.
    Line { colour: RGBColor, band: bool },
    /// A filled square.
    Block(RGBColor),
    /// A small dot.
    Dot(RGBColor),
    /// A line through a large dot.
    LineDot(RGBColor),
    /// The knee marker.
    Ring,
}

const LEGEND_SWATCH: i32 = 28;
const LEGEND_ROW: i32 = 26;

/// Height of one line of legend text, in pixels.
const LEGEND_LINE: i32 = 19;

/// Width of a legend panel for these labels: the widest label, at most 30% of the figure
/// (longer labels are wrapped).
fn legend_width<DB: DrawingBackend>(
    area: &DrawingArea<DB, Shift>,
    labels: &[&str],
) -> Result<u32, DrawingAreaErrorKind<DB::ErrorType>> {
    let style = text_style(LEGEND_SIZE);
    let mut widest = 0;
    for label in labels {
        widest = widest.max(text_width(area, label, &style)?);
    }
    Ok((widest + LEGEND_SWATCH as u32 + 30).min(WIDTH * 3 / 10))
}

/// `text` broken at spaces into lines at most `max_width` pixels wide; at most `max_lines`
/// lines, the last shortened with an ellipsis if it is still too long.
fn wrap_text<DB: DrawingBackend>(
    area: &DrawingArea<DB, Shift>,
    text: &str,
    style: &TextStyle,
    max_width: u32,
    max_lines: usize,
) -> Result<Vec<String>, DrawingAreaErrorKind<DB::ErrorType>> {
    let mut lines: Vec<String> = Vec::new();
    let mut current = String::new();
    for word in text.split_whitespace() {
        let candidate = if current.is_empty() {
            word.to_string()
        } else {
            format!("{current} {word}")
        };
        if current.is_empty() || text_width(area, &candidate, style)? <= max_width {
            current = candidate;
        } else {
            lines.push(std::mem::replace(&mut current, word.to_string()));
        }
    }
    if !current.is_empty() || lines.is_empty() {
        lines.push(current);
    }
    if lines.len() > max_lines.max(1) {
        let rest = lines.split_off(max_lines.max(1) - 1).join(" ");
        lines.push(rest);
    }
    lines
        .iter()
        .map(|line| fit_text(area, line, style, max_width))
        .collect()
}

/// Draws a legend panel: a swatch and a (wrapped) label per entry, from `top` down.
fn draw_legend<DB: DrawingBackend>(
    area: &DrawingArea<DB, Shift>,
    entries: &[(String, Swatch)],
    top: i32,
) -> DrawResult<DB> {
    let style = text_style(LEGEND_SIZE).pos(Pos::new(HPos::Left, VPos::Center));
    let (width, _) = area.dim_in_pixel();
    let text_room = width.saturating_sub(LEGEND_SWATCH as u32 + 22);
    let mut y = top;
    for (label, swatch) in entries {
        let (x0, x1) = (6, 6 + LEGEND_SWATCH);
        let mid = (x0 + x1) / 2;
        match *swatch {
            Swatch::Line { colour, band } => {
                if band {
                    area.draw(&Rectangle::new(
                        [(x0, y - 7), (x1, y + 7)],
                        colour.mix(0.2).filled(),
                    ))?;
                }
                area.draw(&PathElement::new(
                    vec![(x0, y), (x1, y)],
                    colour.stroke_width(3),
                ))?;
            }
            Swatch::Block(colour) => {
                let corners = [(x0 + 4, y - 8), (x1 - 4, y + 8)];
                area.draw(&Rectangle::new(corners, colour.filled()))?;
                area.draw(&Rectangle::new(corners, AXIS.stroke_width(1)))?;
            }
            Swatch::Dot(colour) => {
                area.draw(&Circle::new((mid, y), 4, colour.filled()))?;
            }
            Swatch::LineDot(colour) => {
                area.draw(&PathElement::new(
                    vec![(x0, y), (x1, y)],
                    colour.stroke_width(2),
                ))?;
                area.draw(&Circle::new((mid, y), 5, colour.filled()))?;
            }
            Swatch::Ring => {
                area.draw(&Circle::new((mid, y), 9, BLACK.stroke_width(2)))?;
            }
        }
        let lines = wrap_text(area, label, &style, text_room, 3)?;
        let count = lines.len() as i32;
        for (k, line) in lines.into_iter().enumerate() {
            let line_y = y + k as i32 * LEGEND_LINE;
            area.draw(&Text::new(line, (x1 + 10, line_y), style.clone()))?;
        }
        y += LEGEND_ROW.max(count * LEGEND_LINE + 9);
    }
    Ok(())
}

/// Plot area and legend area side by side (the legend on the right).
fn split_for_legend<DB: DrawingBackend>(
    area: &DrawingArea<DB, Shift>,
    legend_width: u32,
) -> (DrawingArea<DB, Shift>, DrawingArea<DB, Shift>) {
    let (width, _) = area.dim_in_pixel();
    area.split_horizontally(width.saturating_sub(legend_width))
}

/// Configures and draws the mesh (grid, ticks, tick labels, axis texts).
fn draw_mesh<DB: DrawingBackend>(
    chart: &mut ChartContext<'_, DB, Cartesian2d<Axis, Axis>>,
    x_ticks: usize,
    y_ticks: usize,
    x_label: &str,
    y_label: &str,
) -> DrawResult<DB> {
    let mut mesh = chart.configure_mesh();
    mesh.x_labels(x_ticks)
        .y_labels(y_ticks)
        .label_style(text_style(TICK_SIZE))
        .axis_desc_style(text_style(DESC_SIZE))
        .bold_line_style(GRID.stroke_width(1))
        .axis_style(AXIS.stroke_width(1));
    if x_ticks == 0 {
        mesh.disable_x_mesh();
    }
    if !x_label.trim().is_empty() {
        mesh.x_desc(x_label);
    }
    if !y_label.trim().is_empty() {
        mesh.y_desc(y_label);
    }
    mesh.draw()
}

// ---------------------------------------------------------------------------------------------
// Line chart

struct LineSeries {
    label: String,
    colour: RGBColor,
    points: Vec<(f64, f64)>,
    /// `(x, y - band, y + band)` per point, if the series has a band.
    band: Option<Vec<(f64, f64, f64)>>,
}

struct LineFigure<'a> {
    chart: &'a LineChart,
    series: Vec<LineSeries>,
    x: Axis,
    y: Axis,
}

/// Series with at most this many points get a marker on each point.
const MARKER_LIMIT: usize = 25;

impl<'a> LineFigure<'a> {
    fn new(chart: &'a LineChart, figure: &str) -> Result<Self, PlotError> {
        if chart.series.is_empty() {
            return Err(empty(figure, "series list"));
        }
        for s in &chart.series {
            let name = |part: &str| format!("series '{}' {part}", s.label);
            if s.x.is_empty() {
                return Err(empty(figure, &format!("series '{}'", s.label)));
            }
            check_len(figure, &name("y"), s.x.len(), s.y.len())?;
            check_values(figure, &name("x"), &s.x, false)?;
            check_values(figure, &name("y"), &s.y, false)?;
            if let Some(band) = &s.band {
                check_len(figure, &name("band"), s.x.len(), band.len())?;
                check_values(figure, &name("band"), band, true)?;
            }
        }
        let labels: Vec<&str> = chart.series.iter().map(|s| s.label.as_str()).collect();
        let colours = label_colours(&labels);
        let series: Vec<LineSeries> = chart
            .series
            .iter()
            .zip(colours)
            .map(|(s, colour)| {
                let keep: Vec<usize> = (0..s.x.len())
                    .filter(|&i| drawable(s.x[i], s.y[i], chart.log_x, chart.log_y))
                    .collect();
                LineSeries {
                    label: s.label.clone(),
                    colour,
                    points: keep.iter().map(|&i| (s.x[i], s.y[i])).collect(),
                    band: s.band.as_ref().map(|b| {
                        keep.iter()
                            .map(|&i| (s.x[i], s.y[i] - b[i], s.y[i] + b[i]))
                            .collect()
                    }),
                }
            })
            .collect();
        if series.iter().all(|s| s.points.is_empty()) {
            let xs: Vec<f64> = chart.series.iter().flat_map(|s| s.x.clone()).collect();
            return Err(no_positive(figure, &xs, chart.log_x));
        }
        let (x_min, x_max) = extent(series.iter().flat_map(|s| s.points.iter().map(|p| p.0)));
        let ys = series.iter().flat_map(|s| {
            let band = s.band.iter().flatten().flat_map(|&(_, lo, hi)| [lo, hi]);
            s.points.iter().map(|p| p.1).chain(band)
        });
        let (y_min, y_max) = extent(ys.filter(|&y| !chart.log_y || y > 0.0));
        Ok(Self {
            chart,
            series,
            x: Axis::covering(x_min, x_max, chart.log_x, true),
            y: Axis::covering(y_min, y_max, chart.log_y, true),
        })
    }
}

impl Figure for LineFigure<'_> {
    fn draw<DB: DrawingBackend>(&self, root: &DrawingArea<DB, Shift>) -> DrawResult<DB> {
        let area = titled_area(root, &self.chart.title)?;
        let labels: Vec<&str> = self.series.iter().map(|s| s.label.as_str()).collect();
        let legend_w = legend_width(&area, &labels)?;
        let (plot_area, legend_area) = split_for_legend(&area, legend_w);
        let y_ticks = 8;
        let y_area = y_label_area_width(&plot_area, &self.y, y_ticks)?;
        let plot_width = plot_area.dim_in_pixel().0.saturating_sub(y_area + 30);
        let x_ticks = x_tick_count(&plot_area, &self.x, plot_width)?;
        let mut chart = ChartBuilder::on(&plot_area)
            .margin(14)
            .x_label_area_size(64)
            .y_label_area_size(y_area)
            .build_cartesian_2d(self.x, self.y)?;
        draw_mesh(
            &mut chart,
            x_ticks,
            y_ticks,
            &self.chart.x_label,
            &self.chart.y_label,
        )?;
        for s in &self.series {
            if let Some(band) = &s.band {
                if band.len() >= 2 {
                    let outline: Vec<(f64, f64)> = band
                        .iter()
                        .map(|&(x, _, hi)| (x, hi))
                        .chain(band.iter().rev().map(|&(x, lo, _)| (x, lo)))
                        .collect();
                    chart.draw_series(std::iter::once(Polygon::new(
                        outline,
                        s.colour.mix(0.18).filled(),
                    )))?;
                } else if let Some(&(x, lo, hi)) = band.first() {
                    chart.draw_series(std::iter::once(PathElement::new(
                        vec![(x, lo), (x, hi)],
                        s.colour.mix(0.5).stroke_width(6),
                    )))?;
                }
            }
        }
        for s in &self.series {
            chart.draw_series(std::iter::once(PathElement::new(
                s.points.clone(),
                s.colour.stroke_width(2),
            )))?;
            if s.points.len() <= MARKER_LIMIT {
                chart.draw_series(
                    s.points
                        .iter()
                        .map(|&p| Circle::new(p, 4, s.colour.filled())),
                )?;
            }
        }
        let entries: Vec<(String, Swatch)> = self
            .series
            .iter()
            .map(|s| {
                let swatch = Swatch::Line {
                    colour: s.colour,
                    band: s.band.is_some(),
                };
                (s.label.clone(), swatch)
            })
            .collect();
        draw_legend(&legend_area, &entries, 30)
    }
}

// ---------------------------------------------------------------------------------------------
// Bar chart

/// Gap between groups, in bar widths.
const GROUP_GAP: f64 = 0.8;
/// Width of a drawn bar, in bar slots.
const BAR_WIDTH: f64 = 0.76;

struct BarFigure<'a> {
    chart: &'a BarChart,
    /// Centre of each bar (indexed like `chart.bars`) on the x axis.
    centres: Vec<f64>,
    colours: Vec<RGBColor>,
    /// Group names with the x span of their bars.
    groups: Vec<(String, f64, f64)>,
    /// `(i, j, text, height)` of each bracket.
    brackets: Vec<(usize, usize, String, f64)>,
    x: Axis,
    y: Axis,
}

impl<'a> BarFigure<'a> {
    fn new(chart: &'a BarChart, figure: &str) -> Result<Self, PlotError> {
        if chart.bars.is_empty() {
            return Err(empty(figure, "bar list"));
        }
        let values: Vec<f64> = chart.bars.iter().map(|b| b.value).collect();
        check_values(figure, "bar value", &values, false)?;
        let errors: Vec<f64> = chart.bars.iter().map(|b| b.error.unwrap_or(0.0)).collect();
        check_values(figure, "bar error", &errors, true)?;
        for (k, (i, j, _)) in chart.annotations.iter().enumerate() {
            let what = format!("annotation {k}");
            check_index(figure, &what, *i, chart.bars.len())?;
            check_index(figure, &what, *j, chart.bars.len())?;
        }

        let mut group_names: Vec<&str> = Vec::new();
        for bar in &chart.bars {
            if !group_names.contains(&bar.group.as_str()) {
                group_names.push(&bar.group);
            }
        }
        let mut centres = vec![0.0; chart.bars.len()];
        let mut groups = Vec::new();
        let mut cursor = 0.3;
        for name in group_names {
            let start = cursor;
            for (i, bar) in chart.bars.iter().enumerate() {
                if bar.group == name {
                    centres[i] = cursor + 0.5;
                    cursor += 1.0;
                }
            }
            groups.push((name.to_string(), start, cursor));
            cursor += GROUP_GAP;
        }
        let x = Axis {
            lo: 0.0,
            hi: cursor - GROUP_GAP + 0.3,
            log: false,
        };

        let tops: Vec<f64> = chart
            .bars
            .iter()
            .map(|b| (b.value + b.error.unwrap_or(0.0)).max(b.value).max(0.0))
            .collect();
        let bottoms = chart
            .bars
            .iter()
            .map(|b| (b.value - b.error.unwrap_or(0.0)).min(0.0));
        let (lowest, _) = extent(bottoms);
        let (_, highest) = extent(tops.iter().copied());
        let span = if highest > lowest {
            highest - lowest
        } else {
            1.0
        };
        // Brackets: narrow ones first, each above the bars it spans and above any bracket
        // already placed that it overlaps.
        let mut order: Vec<usize> = (0..chart.annotations.len()).collect();
        let width_of = |k: usize| {
            let (i, j, _) = &chart.annotations[k];
            (centres[*i] - centres[*j]).abs()
        };
        order.sort_by(|&a, &b| width_of(a).total_cmp(&width_of(b)));
        let mut brackets: Vec<(usize, usize, String, f64)> = Vec::new();
        for k in order {
            let (i, j, text) = &chart.annotations[k];
            let (left, right) = if centres[*i] <= centres[*j] {
                (centres[*i], centres[*j])
            } else {
                (centres[*j], centres[*i])
            };
            let inside = |c: f64| c >= left - 1e-9 && c <= right + 1e-9;
            let mut height = centres
                .iter()
                .zip(&tops)
                .filter(|(c, _)| inside(**c))
                .map(|(_, t)| *t)
                .fold(0.0, f64::max)
                + 0.04 * span;
            for (bi, bj, _, bh) in &brackets {
                let (bl, br) = (
                    centres[*bi].min(centres[*bj]),
                    centres[*bi].max(centres[*bj]),
                );
                if bl <= right + 0.5 && br >= left - 0.5 {
                    height = height.max(bh + 0.09 * span);
                }
            }
            brackets.push((*i, *j, text.clone(), height));
        }
        let bracket_top = brackets
            .iter()
            .map(|b| b.3 + 0.08 * span)
            .fold(highest, f64::max);
        let y = Axis::covering(lowest, bracket_top.max(highest), false, lowest < 0.0);
        let y = Axis {
            lo: if lowest < 0.0 { y.lo } else { 0.0 },
            ..y
        };
        let labels: Vec<&str> = chart.bars.iter().map(|b| b.label.as_str()).collect();
        Ok(Self {
            chart,
            centres,
            colours: label_colours(&labels),
            groups,
            brackets,
            x,
            y,
        })
    }
}

impl Figure for BarFigure<'_> {
    fn draw<DB: DrawingBackend>(&self, root: &DrawingArea<DB, Shift>) -> DrawResult<DB> {
        let area = titled_area(root, &self.chart.title)?;
        let y_ticks = 8;
        let y_area = y_label_area_width(&area, &self.y, y_ticks)?;
        let margin = 14;
        // Do the bar labels fit under their bars? If not, a legend names the colours.
        let label_style = text_style(TICK_SIZE);
        let plot_width = area.dim_in_pixel().0.saturating_sub(y_area + 2 * margin);
        let slot = f64::from(plot_width) / (self.x.hi - self.x.lo);
        let mut widest = 0;
        for bar in &self.chart.bars {
            widest = widest.max(text_width(&area, &bar.label, &label_style)?);
        }
        let labels_fit = f64::from(widest + 6) <= slot;
        let mut unique: Vec<(String, RGBColor)> = Vec::new();
        for (bar, colour) in self.chart.bars.iter().zip(&self.colours) {
            if !unique.iter().any(|(l, _)| *l == bar.label) {
                unique.push((bar.label.clone(), *colour));
            }
        }
        let (plot_area, legend_area) = if labels_fit {
            (area.clone(), None)
        } else {
            let names: Vec<&str> = unique.iter().map(|(l, _)| l.as_str()).collect();
            let (p, l) = split_for_legend(&area, legend_width(&area, &names)?);
            (p, Some(l))
        };
        let show_groups = self.groups.len() > 1 || !self.groups[0].0.trim().is_empty();
        let rows = u32::from(labels_fit) + u32::from(show_groups);
        let mut chart = ChartBuilder::on(&plot_area)
            .margin(margin)
            .x_label_area_size(10 + 28 * rows.max(1))
            .y_label_area_size(y_area)
            .build_cartesian_2d(self.x, self.y)?;
        draw_mesh(&mut chart, 0, y_ticks, "", &self.chart.y_label)?;
        if self.y.lo < 0.0 {
            chart.draw_series(std::iter::once(PathElement::new(
                vec![(self.x.lo, 0.0), (self.x.hi, 0.0)],
                AXIS.stroke_width(1),
            )))?;
        }
        let half = BAR_WIDTH / 2.0;
        for ((bar, &c), colour) in self.chart.bars.iter().zip(&self.centres).zip(&self.colours) {
            let corners = [(c - half, 0.0), (c + half, bar.value)];
            chart.draw_series([
                Rectangle::new(corners, colour.filled()),
                Rectangle::new(corners, AXIS.stroke_width(1)),
            ])?;
            if let Some(e) = bar.error.filter(|&e| e > 0.0) {
                let (lo, hi) = (bar.value - e, bar.value + e);
                let cap = 0.12;
                chart.draw_series([
                    PathElement::new(vec![(c, lo), (c, hi)], BLACK.stroke_width(2)),
                    PathElement::new(vec![(c - cap, lo), (c + cap, lo)], BLACK.stroke_width(2)),
                    PathElement::new(vec![(c - cap, hi), (c + cap, hi)], BLACK.stroke_width(2)),
                ])?;
            }
        }
        let note_style = text_style(NOTE_SIZE).pos(Pos::new(HPos::Center, VPos::Bottom));
        for (i, j, text, height) in &self.brackets {
            let (a, b) = (self.centres[*i], self.centres[*j]);
            if i != j {
                let drop = 0.025 * (self.y.hi - self.y.lo);
                chart.draw_series(std::iter::once(PathElement::new(
                    vec![
                        (a, height - drop),
                        (a, *height),
                        (b, *height),
                        (b, height - drop),
                    ],
                    BLACK.stroke_width(1),
                )))?;
            }
            let (px, py) = chart.backend_coord(&((a + b) / 2.0, *height));
            root.draw(&Text::new(text.clone(), (px, py - 3), note_style.clone()))?;
        }
        // Labels under the plot: bar labels (if they fit), then group names.
        let below = chart.backend_coord(&(self.x.lo, self.y.lo)).1 + 8;
        let top_style = label_style.pos(Pos::new(HPos::Center, VPos::Top));
        let mut row_y = below;
        if labels_fit {
            for (bar, &c) in self.chart.bars.iter().zip(&self.centres) {
                let (px, _) = chart.backend_coord(&(c, 0.0));
                root.draw(&Text::new(
                    bar.label.clone(),
                    (px, row_y),
                    top_style.clone(),
                ))?;
            }
            row_y += 28;
        }
        if show_groups {
            // The largest size at which every group name fits its group (and half of each gap).
            let spans: Vec<(i32, i32)> = self
                .groups
                .iter()
                .map(|(_, start, end)| {
                    let left = chart.backend_coord(&(*start, 0.0)).0;
                    let right = chart.backend_coord(&(*end, 0.0)).0;
                    (left, right)
                })
                .collect();
            let gap = chart.backend_coord(&(GROUP_GAP, 0.0)).0 - chart.backend_coord(&(0.0, 0.0)).0;
            let room = |(left, right): (i32, i32)| (right - left + gap - 4).max(0) as u32;
            let mut size = DESC_SIZE;
            for candidate in [DESC_SIZE, TICK_SIZE, em(13.0)] {
                size = candidate;
                let style = text_style(candidate);
                let mut fits = true;
                for ((name, _, _), span) in self.groups.iter().zip(&spans) {
                    fits &= text_width(root, name, &style)? <= room(*span);
                }
                if fits {
                    break;
                }
            }
            let group_style = text_style(size).pos(Pos::new(HPos::Center, VPos::Top));
            for ((name, _, _), &(left, right)) in self.groups.iter().zip(&spans) {
                let name = fit_text(root, name, &group_style, room((left, right)))?;
                root.draw(&Text::new(
                    name,
                    ((left + right) / 2, row_y),
                    group_style.clone(),
                ))?;
            }
        }
        if let Some(legend_area) = legend_area {
            let entries: Vec<(String, Swatch)> = unique
                .into_iter()
                .map(|(label, colour)| (label, Swatch::Block(colour)))
                .collect();
            draw_legend(&legend_area, &entries, 30)?;
        }
        Ok(())
    }
}

// ---------------------------------------------------------------------------------------------
// Scatter chart

const POINT_COLOUR: RGBColor = RGBColor(150, 150, 150);
const FRONT_COLOUR: RGBColor = RGBColor(178, 34, 34);

struct ScatterFigure<'a> {
    chart: &'a ScatterChart,
    /// Drawable points (positive on log axes) by index into `chart.points`.
    shown: Vec<bool>,
    /// Front indices, drawable only, in order of x.
    front: Vec<usize>,
    x: Axis,
    y: Axis,
}

impl<'a> ScatterFigure<'a> {
    fn new(chart: &'a ScatterChart, figure: &str) -> Result<Self, PlotError> {
        let n = chart.points.len();
        if n == 0 {
            return Err(empty(figure, "point list"));
        }
        let xs: Vec<f64> = chart.points.iter().map(|p| p.0).collect();
        let ys: Vec<f64> = chart.points.iter().map(|p| p.1).collect();
        check_values(figure, "point x", &xs, false)?;
        check_values(figure, "point y", &ys, false)?;
        for &i in &chart.highlighted {
            check_index(figure, "highlighted", i, n)?;
        }
        if let Some(i) = chart.marked {
            check_index(figure, "marked", i, n)?;
        }
        if !chart.point_labels.is_empty() {
            check_len(figure, "point_labels", n, chart.point_labels.len())?;
        }
        let shown: Vec<bool> = chart
            .points
            .iter()
            .map(|&(x, y)| drawable(x, y, chart.log_x, chart.log_y))
            .collect();
        if !shown.contains(&true) {
            return Err(no_positive(figure, &xs, chart.log_x));
        }
        let mut front: Vec<usize> = chart
            .highlighted
            .iter()
            .copied()
            .filter(|&i| shown[i])
            .collect();
        front.sort_by(|&a, &b| {
            let (pa, pb) = (chart.points[a], chart.points[b]);
            pa.0.total_cmp(&pb.0).then(pa.1.total_cmp(&pb.1))
        });
        front.dedup();
        let visible = || {
            chart
                .points
                .iter()
                .zip(&shown)
                .filter(|(_, s)| **s)
                .map(|(p, _)| *p)
        };
        let (x_min, x_max) = extent(visible().map(|p| p.0));
        let (y_min, y_max) = extent(visible().map(|p| p.1));
        Ok(Self {
            chart,
            shown,
            front,
            x: Axis::covering(x_min, x_max, chart.log_x, true),
            y: Axis::covering(y_min, y_max, chart.log_y, true),
        })
    }

    fn label(&self, i: usize) -> Option<&str> {
        self.chart
            .point_labels
            .get(i)
            .map(String::as_str)
            .filter(|l| !l.trim().is_empty())
    }
}

/// Pixel rectangle `(x0, y0, x1, y1)`.
type Bounds = (i32, i32, i32, i32);

fn overlaps(a: Bounds, b: Bounds) -> bool {
    a.0 < b.2 && b.0 < a.2 && a.1 < b.3 && b.1 < a.3
}

impl Figure for ScatterFigure<'_> {
    fn draw<DB: DrawingBackend>(&self, root: &DrawingArea<DB, Shift>) -> DrawResult<DB> {
        let area = titled_area(root, &self.chart.title)?;
        let mut entries = vec![("all points".to_string(), Swatch::Dot(POINT_COLOUR))];
        if !self.front.is_empty() {
            entries.push(("Pareto front".to_string(), Swatch::LineDot(FRONT_COLOUR)));
        }
        let knee = self.chart.marked.filter(|&i| self.shown[i]);
        if knee.is_some() {
            entries.push(("knee".to_string(), Swatch::Ring));
        }
        let names: Vec<&str> = entries.iter().map(|(l, _)| l.as_str()).collect();
        let (plot_area, legend_area) = split_for_legend(&area, legend_width(&area, &names)?);
        let y_ticks = 8;
        let y_area = y_label_area_width(&plot_area, &self.y, y_ticks)?;
        let plot_width = plot_area.dim_in_pixel().0.saturating_sub(y_area + 30);
        let x_ticks = x_tick_count(&plot_area, &self.x, plot_width)?;
        let mut chart = ChartBuilder::on(&plot_area)
            .margin(14)
            .x_label_area_size(64)
            .y_label_area_size(y_area)
            .build_cartesian_2d(self.x, self.y)?;
        draw_mesh(
            &mut chart,
            x_ticks,
            y_ticks,
            &self.chart.x_label,
            &self.chart.y_label,
        )?;
        let points = &self.chart.points;
        chart.draw_series(
            points
                .iter()
                .zip(&self.shown)
                .filter(|(_, s)| **s)
                .map(|(&p, _)| Circle::new(p, 3, POINT_COLOUR.mix(0.8).filled())),
        )?;
        if !self.front.is_empty() {
            let line: Vec<(f64, f64)> = self.front.iter().map(|&i| points[i]).collect();
            chart.draw_series(std::iter::once(PathElement::new(
                line.clone(),
                FRONT_COLOUR.stroke_width(2),
            )))?;
            chart.draw_series(
                line.iter()
                    .map(|&p| Circle::new(p, 5, FRONT_COLOUR.filled())),
            )?;
        }
        if let Some(i) = knee {
            chart.draw_series(std::iter::once(Circle::new(
                points[i],
                10,
                BLACK.stroke_width(2),
            )))?;
        }

        // Labels: the knee's first, then the front's, each at the spot around its point that
        // stays in the plot, overlaps no earlier label and covers the fewest markers and line.
        let (x0, y1) = chart.backend_coord(&(self.x.lo, self.y.lo));
        let (x1, y0) = chart.backend_coord(&(self.x.hi, self.y.hi));
        let plot_bounds = (x0, y0, x1, y1);
        let mut obstacles: Vec<Bounds> = Vec::new();
        for (p, _) in points.iter().zip(&self.shown).filter(|(_, s)| **s) {
            let (px, py) = chart.backend_coord(p);
            obstacles.push((px - 4, py - 4, px + 4, py + 4));
        }
        let front_pixels: Vec<(i32, i32)> = self
            .front
            .iter()
            .map(|&i| chart.backend_coord(&points[i]))
            .collect();
        for pair in front_pixels.windows(2) {
            let ((ax, ay), (bx, by)) = (pair[0], pair[1]);
            let steps = ((bx - ax).abs().max((by - ay).abs()) / 4).max(1);
            for k in 0..=steps {
                let x = ax + (bx - ax) * k / steps;
                let y = ay + (by - ay) * k / steps;
                obstacles.push((x - 1, y - 1, x + 1, y + 1));
            }
        }
        for &(px, py) in &front_pixels {
            obstacles.push((px - 6, py - 6, px + 6, py + 6));
        }
        let mut wanted: Vec<(usize, String, f64)> = Vec::new();
        if let Some(i) = knee {
            let text = match self.label(i) {
                Some(l) => format!("knee ({l})"),
                None => "knee".to_string(),
            };
            wanted.push((i, text, LEGEND_SIZE));
        }
        for &i in &self.front {
            if Some(i) != knee
                && let Some(l) = self.label(i)
            {
                wanted.push((i, l.to_string(), POINT_LABEL_SIZE));
            }
        }
        let (fig_w, fig_h) = root.dim_in_pixel();
        let figure_bounds = (0, 0, fig_w as i32, fig_h as i32);
        let mut placed: Vec<Bounds> = Vec::new();
        for (i, text, size) in wanted {
            let style = text_style(size);
            let (w, h) = root.estimate_text_size(&text, &style)?;
            let (w, h) = (w as i32, h as i32);
            let (px, py) = chart.backend_coord(&points[i]);
            let gap = if Some(i) == knee { 13 } else { 7 };
            let spots = [
                (px + gap, py - gap - h),
                (px - gap - w, py - gap - h),
                (px + gap, py + gap),
                (px - gap - w, py + gap),
                (px - w / 2, py - gap - h),
                (px - w / 2, py + gap),
                (px + gap + 2, py - h / 2),
                (px - gap - 2 - w, py - h / 2),
            ]
            .map(|(x, y)| (x, y, x + w, y + h));
            let own = (px - 1, py - 1, px + 1, py + 1);
            let free = |b: &Bounds, within: Bounds| {
                b.0 >= within.0
                    && b.2 <= within.2
                    && b.1 >= within.1
                    && b.3 <= within.3
                    && placed.iter().all(|p| !overlaps(*b, *p))
            };
            let cost = |b: &Bounds| {
                obstacles
                    .iter()
                    .filter(|o| !overlaps(**o, own) && overlaps(*b, **o))
                    .count()
            };
            let best = |within: Bounds| {
                spots
                    .iter()
                    .filter(|b| free(b, within))
                    .min_by_key(|b| cost(b))
                    .copied()
            };
            // The knee is always labelled, if need be outside the plot.
            let spot = match best(plot_bounds) {
                Some(b) => Some(b),
                None if Some(i) == knee => best(figure_bounds).or(Some(spots[0])),
                None => None,
            };
            if let Some(b) = spot {
                placed.push(b);
                root.draw(&Text::new(text, (b.0, b.1), style))?;
            }
        }
        draw_legend(&legend_area, &entries, 30)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A fresh, empty folder under the system temp dir, unique to this process and test.
    fn temp_dir(test: &str) -> PathBuf {
        let dir = std::env::temp_dir().join(format!("mbmf-plot-{}-{test}", std::process::id()));
        let _ = fs::remove_dir_all(&dir);
        fs::create_dir_all(&dir).unwrap();
        dir
    }

    fn assert_figure_files(paths: &[PathBuf], texts: &[&str]) {
        assert_eq!(paths.len(), 2);
        let svg = fs::read_to_string(&paths[0]).unwrap();
        assert!(paths[0].extension().is_some_and(|e| e == "svg"));
        assert!(
            svg.starts_with("<svg"),
            "not an SVG: {}",
            &svg[..40.min(svg.len())]
        );
        for text in texts {
            assert!(svg.contains(text), "SVG lacks '{text}'");
        }
        let png = fs::read(&paths[1]).unwrap();
        assert!(png.len() > 1000, "PNG has only {} bytes", png.len());
        assert_eq!(&png[..8], b"\x89PNG\r\n\x1a\n");
        let dir = paths[0].parent().unwrap();
        for entry in fs::read_dir(dir).unwrap() {
            let name = entry.unwrap().file_name();
            assert!(
                !name.to_string_lossy().contains(".tmp."),
                "temporary file {name:?} left behind"
            );
        }
    }

    fn series(label: &str, x: Vec<f64>, y: Vec<f64>) -> Series {
        Series {
            label: label.to_string(),
            x,
            y,
            band: None,
        }
    }

    fn reward_chart() -> LineChart {
        let x: Vec<f64> = (0..=100).map(|i| f64::from(i) * 100.0).collect();
        let make = |label: &str, rate: f64| {
            let y: Vec<f64> = x
                .iter()
                .map(|t| rate * t * (1.0 - (-t / 3000.0).exp()))
                .collect();
            let band = y.iter().map(|v| 0.05 * v + 1.0).collect();
            Series {
                band: Some(band),
                ..series(label, x.clone(), y)
            }
        };
        LineChart {
            title: "Cumulative reward, task 1".to_string(),
            x_label: "step".to_string(),
            y_label: "cumulative reward".to_string(),
            series: vec![make("MF", 0.05), make("MB", 0.03), make("EC", 0.045)],
            log_x: false,
            log_y: false,
        }
    }

    fn bars() -> BarChart {
        let bar = |label: &str, group: &str, value: f64| Bar {
            label: label.to_string(),
            value,
            error: Some(value * 0.1),
            group: group.to_string(),
        };
        BarChart {
            title: "Total reward by interaction".to_string(),
            y_label: "total reward".to_string(),
            bars: vec![
                bar("MF", "none", 300.0),
                bar("MB", "none", 250.0),
                bar("MF", "takeover", 420.0),
                bar("MB", "takeover", 330.0),
            ],
            annotations: vec![(0, 1, "***".to_string()), (1, 3, "n.s.".to_string())],
        }
    }

    fn front() -> ScatterChart {
        let points: Vec<(f64, f64)> = (0..20)
            .map(|i| {
                let c = f64::from(i);
                (
                    1000.0 + c * 500.0,
                    200.0 + 30.0 * c.sqrt() - (c % 3.0) * 20.0,
                )
            })
            .collect();
        ScatterChart {
            title: "Reward against cost".to_string(),
            x_label: "total cost".to_string(),
            y_label: "total reward".to_string(),
            point_labels: (0..20).map(|i| format!("κ={i}")).collect(),
            points,
            highlighted: vec![0, 3, 6, 9, 12, 15, 18],
            marked: Some(9),
            log_x: false,
            log_y: false,
        }
    }

    #[test]
    fn a_line_chart_writes_an_svg_and_a_png_with_its_title_and_labels() {
        let dir = temp_dir("line");
        let paths = line_chart(&reward_chart(), &dir.join("reward")).unwrap();
        assert_eq!(paths, vec![dir.join("reward.svg"), dir.join("reward.png")]);
        assert_figure_files(
            &paths,
            &["Cumulative reward, task 1", "MF", "MB", "EC", "step"],
        );
        fs::remove_dir_all(dir).unwrap();
    }

    #[test]
    fn a_bar_chart_writes_both_files_with_labels_groups_and_marks() {
        let dir = temp_dir("bar");
        let paths = bar_chart(&bars(), &dir.join("bars")).unwrap();
        assert_figure_files(
            &paths,
            &[
                "Total reward by interaction",
                "MF",
                "MB",
                "takeover",
                "***",
                "n.s.",
            ],
        );
        fs::remove_dir_all(dir).unwrap();
    }

    #[test]
    fn a_scatter_chart_writes_both_files_with_front_and_knee_labels() {
        let dir = temp_dir("scatter");
        let paths = scatter_chart(&front(), &dir.join("pareto")).unwrap();
        assert_figure_files(
            &paths,
            &["Reward against cost", "Pareto front", "knee (κ=9)"],
        );
        fs::remove_dir_all(dir).unwrap();
    }

    #[test]
    fn a_dotted_file_name_keeps_its_dots_and_missing_folders_are_created() {
        let dir = temp_dir("dotted");
        let base = dir.join("sub").join("kappa_0.5");
        let paths = line_chart(&reward_chart(), &base).unwrap();
        assert_eq!(paths[0], dir.join("sub").join("kappa_0.5.svg"));
        assert!(paths[1].exists());
        fs::remove_dir_all(dir).unwrap();
    }

    #[test]
    fn a_single_point_is_drawn_in_every_chart_kind() {
        let dir = temp_dir("single");
        let line = LineChart {
            series: vec![Series {
                band: Some(vec![0.5]),
                ..series("rnd", vec![3.0], vec![7.0])
            }],
            ..reward_chart()
        };
        assert_figure_files(&line_chart(&line, &dir.join("line")).unwrap(), &["rnd"]);
        let bar = BarChart {
            bars: vec![Bar {
                label: "EC".to_string(),
                value: 0.0,
                error: None,
                group: String::new(),
            }],
            annotations: vec![(0, 0, "*".to_string())],
            ..bars()
        };
        assert_figure_files(&bar_chart(&bar, &dir.join("bar")).unwrap(), &["EC"]);
        let scatter = ScatterChart {
            points: vec![(1.0, 1.0)],
            highlighted: vec![0],
            marked: Some(0),
            point_labels: vec![],
            ..front()
        };
        assert_figure_files(
            &scatter_chart(&scatter, &dir.join("scatter")).unwrap(),
            &["knee"],
        );
        fs::remove_dir_all(dir).unwrap();
    }

    #[test]
    fn log_axes_leave_out_non_positive_values() {
        let dir = temp_dir("log");
        let chart = LineChart {
            series: vec![series(
                "MB",
                vec![0.0, 1.0, 10.0, 100.0],
                vec![-1.0, 5.0, 50.0, 5e6],
            )],
            log_x: true,
            log_y: true,
            ..reward_chart()
        };
        assert_figure_files(&line_chart(&chart, &dir.join("log")).unwrap(), &["MB"]);
        fs::remove_dir_all(dir).unwrap();
    }

    #[test]
    fn a_log_axis_without_positive_values_is_an_error() {
        let dir = temp_dir("log-error");
        let chart = LineChart {
            series: vec![series("MB", vec![1.0, 2.0], vec![0.0, -3.0])],
            log_y: true,
            ..reward_chart()
        };
        let err = line_chart(&chart, &dir.join("x")).unwrap_err();
        assert!(
            matches!(err, PlotError::NoPositiveValues { axis: "y", .. }),
            "{err}"
        );
        let scatter = ScatterChart {
            points: vec![(-1.0, 1.0)],
            highlighted: vec![],
            marked: None,
            point_labels: vec![],
            log_x: true,
            ..front()
        };
        let err = scatter_chart(&scatter, &dir.join("y")).unwrap_err();
        assert!(
            matches!(err, PlotError::NoPositiveValues { axis: "x", .. }),
            "{err}"
        );
        assert_eq!(
            fs::read_dir(&dir).unwrap().count(),
            0,
            "no file for a failed figure"
        );
        fs::remove_dir_all(dir).unwrap();
    }

    #[test]
    fn empty_inputs_are_errors() {
        let dir = temp_dir("empty");
        let no_series = LineChart {
            series: vec![],
            ..reward_chart()
        };
        let err = line_chart(&no_series, &dir.join("a")).unwrap_err();
        assert!(matches!(err, PlotError::Empty { .. }), "{err}");
        let empty_series = LineChart {
            series: vec![series("MF", vec![], vec![])],
            ..reward_chart()
        };
        let err = line_chart(&empty_series, &dir.join("b")).unwrap_err();
        assert!(err.to_string().contains("series 'MF'"), "{err}");
        let no_bars = BarChart {
            bars: vec![],
            ..bars()
        };
        assert!(matches!(
            bar_chart(&no_bars, &dir.join("c")),
            Err(PlotError::Empty { .. })
        ));
        let no_points = ScatterChart {
            points: vec![],
            ..front()
        };
        assert!(matches!(
            scatter_chart(&no_points, &dir.join("d")),
            Err(PlotError::Empty { .. })
        ));
        fs::remove_dir_all(dir).unwrap();
    }

    #[test]
    fn nan_and_infinite_values_are_errors_naming_the_value() {
        let dir = temp_dir("nan");
        let chart = LineChart {
            series: vec![series("EC", vec![1.0, 2.0], vec![1.0, f64::NAN])],
            ..reward_chart()
        };
        let err = line_chart(&chart, &dir.join("a")).unwrap_err();
        assert!(
            matches!(&err, PlotError::InvalidValue { index: 1, what, .. } if what == "series 'EC' y"),
            "{err}"
        );
        let mut bar = bars();
        bar.bars[2].error = Some(f64::INFINITY);
        let err = bar_chart(&bar, &dir.join("b")).unwrap_err();
        assert!(
            matches!(err, PlotError::InvalidValue { index: 2, .. }),
            "{err}"
        );
        let mut scatter = front();
        scatter.points[4].0 = f64::NAN;
        let err = scatter_chart(&scatter, &dir.join("c")).unwrap_err();
        assert!(
            matches!(err, PlotError::InvalidValue { index: 4, .. }),
            "{err}"
        );
        fs::remove_dir_all(dir).unwrap();
    }

    #[test]
    fn mismatched_lengths_bad_indices_and_negative_bands_are_errors() {
        let dir = temp_dir("shape");
        let chart = LineChart {
            series: vec![series("MF", vec![1.0, 2.0], vec![1.0])],
            ..reward_chart()
        };
        let err = line_chart(&chart, &dir.join("a")).unwrap_err();
        assert!(matches!(
            err,
            PlotError::LengthMismatch {
                expected: 2,
                found: 1,
                ..
            }
        ));
        let chart = LineChart {
            series: vec![Series {
                band: Some(vec![1.0, -1.0]),
                ..series("MF", vec![1.0, 2.0], vec![1.0, 2.0])
            }],
            ..reward_chart()
        };
        let err = line_chart(&chart, &dir.join("b")).unwrap_err();
        assert!(err.to_string().contains(">= 0"), "{err}");
        let mut bar = bars();
        bar.annotations.push((0, 9, "*".to_string()));
        let err = bar_chart(&bar, &dir.join("c")).unwrap_err();
        assert!(matches!(
            err,
            PlotError::IndexOutOfRange {
                index: 9,
                len: 4,
                ..
            }
        ));
        let scatter = ScatterChart {
            point_labels: vec!["a".to_string()],
            ..front()
        };
        let err = scatter_chart(&scatter, &dir.join("d")).unwrap_err();
        assert!(matches!(err, PlotError::LengthMismatch { .. }), "{err}");
        let scatter = ScatterChart {
            marked: Some(20),
            ..front()
        };
        let err = scatter_chart(&scatter, &dir.join("e")).unwrap_err();
        assert!(matches!(err, PlotError::IndexOutOfRange { .. }), "{err}");
        fs::remove_dir_all(dir).unwrap();
    }

    #[test]
    fn controllers_keep_their_colour_whatever_the_other_series() {
        let a = label_colours(&["MF", "MB", "other"]);
        let b = label_colours(&["mb takeover", "mf", "RND", "ec"]);
        assert_eq!(a[0], b[1]);
        assert_eq!(a[1], b[0]);
        assert_eq!(label_colours(&["x", "y"])[0], label_colours(&["z", "x"])[1]);
        let many: Vec<String> = (0..8).map(|i| format!("label {i}")).collect();
        let colours = label_colours(&many);
        for (i, c) in colours.iter().enumerate() {
            assert!(!colours[..i].contains(c), "colour repeated within a figure");
        }
    }

    #[test]
    fn labels_naming_one_controller_get_distinct_shades_with_the_bare_name_first() {
        let colours = label_colours(&["EC, takeover", "EC", "ec congratulation", "EC"]);
        let ec = FIXED_COLOURS[3].1;
        assert_eq!(colours[1], ec);
        assert_eq!(colours[3], ec);
        assert_ne!(colours[0], ec);
        assert_ne!(colours[2], ec);
        assert_ne!(colours[0], colours[2]);
    }

    #[test]
    fn extreme_values_draw_without_panicking() {
        let dir = temp_dir("extreme");
        let chart = LineChart {
            series: vec![series("MF", vec![-1e300, 1e300], vec![1e-300, 1e300])],
            log_y: true,
            ..reward_chart()
        };
        assert!(line_chart(&chart, &dir.join("huge")).is_ok());
        assert!(log_ticks(1e-300, f64::INFINITY, 8).is_empty());
        assert!(linear_ticks(f64::NEG_INFINITY, 1.0, 8).is_empty());
        fs::remove_dir_all(dir).unwrap();
    }

    #[test]
    fn text_is_measured_with_the_embedded_font() {
        let font = font().unwrap();
        let (_, narrow) = typeset::layout_glyphs(font, "iii", em(16.0));
        let (_, wide) = typeset::layout_glyphs(font, "WWW", em(16.0));
        assert!(wide > 2.0 * narrow, "WWW {wide} px, iii {narrow} px");
        // DejaVu Sans "M" advances 0.863 em.
        let (_, m) = typeset::layout_glyphs(font, "M", em(100.0));
        assert!((m - 86.3).abs() < 0.5, "M is {m} px wide at 100 px per em");
    }

    #[test]
    fn tick_values_are_round_and_print_short() {
        assert_eq!(
            linear_ticks(0.0, 10.0, 6),
            vec![0.0, 2.0, 4.0, 6.0, 8.0, 10.0]
        );
        assert_eq!(log_ticks(1.0, 1000.0, 8), vec![1.0, 10.0, 100.0, 1000.0]);
        assert_eq!(log_ticks(1.0, 10.0, 8), vec![1.0, 2.0, 5.0, 10.0]);
        assert!(log_ticks(1e-3, 1e9, 7).len() <= 7);
        assert_eq!(format_number(0.1 + 0.2), "0.3");
        assert_eq!(format_number(2500.0), "2500");
        assert_eq!(format_number(1e8), "1e8");
        assert_eq!(format_number(-0.0), "0");
        assert_eq!(format_number(2.5e-5), "2.5e-5");
        let costs = Axis {
            lo: 1.0,
            hi: 1e8,
            log: true,
        };
        assert_eq!(costs.format_tick(100.0), "1e2", "one axis, one notation");
    }
}
