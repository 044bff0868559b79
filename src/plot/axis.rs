//! Linear and logarithmic axes: ranges, tick choice and number format.

use super::*;

/// A linear or logarithmic axis over `lo..hi` (`lo > 0` when logarithmic), with its own tick
/// choice and number format.
#[derive(Debug, Clone, Copy)]
pub(super) struct Axis {
    pub(super) lo: f64,
    pub(super) hi: f64,
    pub(super) log: bool,
}

impl Axis {
    /// An axis covering `min..=max` with a small margin on both sides (none below a bar
    /// chart's zero: `pad_low = false`).
    pub(super) fn covering(min: f64, max: f64, log: bool, pad_low: bool) -> Self {
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
    pub(super) fn fraction(&self, v: f64) -> f64 {
        if self.log {
            (v.max(self.lo).ln() - self.lo.ln()) / (self.hi.ln() - self.lo.ln())
        } else {
            (v - self.lo) / (self.hi - self.lo)
        }
    }

    /// Whether tick labels are written in scientific notation: for large magnitudes, and for
    /// small ones (or log axes reaching them), so that one axis never mixes styles.
    pub(super) fn scientific(&self) -> bool {
        let largest = self.lo.abs().max(self.hi.abs());
        !(1e-3..1e5).contains(&largest) || (self.log && self.lo < 1e-3)
    }

    /// The label of tick value `v`.
    pub(super) fn format_tick(&self, v: f64) -> String {
        if self.scientific() && v != 0.0 {
            format_scientific(v)
        } else {
            format_number(v)
        }
    }

    /// At most `max` tick values inside the axis.
    pub(super) fn ticks(&self, max: usize) -> Vec<f64> {
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
pub(super) fn linear_ticks(lo: f64, hi: f64, max: usize) -> Vec<f64> {
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
pub(super) fn log_ticks(lo: f64, hi: f64, max: usize) -> Vec<f64> {
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
pub(super) fn format_number(v: f64) -> String {
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
pub(super) fn format_scientific(v: f64) -> String {
    let tolerance = v.abs() * 1e-9;
    (0..=6)
        .map(|d| format!("{v:.d$e}"))
        .find(|s| s.parse::<f64>().is_ok_and(|p| (p - v).abs() <= tolerance))
        .unwrap_or_else(|| format!("{v:.3e}"))
}
