//! Colours that follow a series label, so one controller looks the same in every figure.

use super::*;

/// Fixed colours of the four controllers (Okabe-Ito: blue, vermillion, bluish green, purple).
pub(super) const FIXED_COLOURS: [(&str, RGBColor); 4] = [
    ("mf", RGBColor(0, 114, 178)),
    ("mb", RGBColor(213, 94, 0)),
    ("rnd", RGBColor(0, 158, 115)),
    ("ec", RGBColor(204, 121, 167)),
];

/// Colours for other labels, none close to the fixed ones.
pub(super) const PALETTE: [RGBColor; 8] = [
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
pub(super) fn controller(label: &str) -> Option<(&'static str, RGBColor)> {
    let lower = label.trim().to_lowercase();
    let first = lower.split(|c: char| !c.is_alphanumeric()).next()?;
    FIXED_COLOURS
        .iter()
        .copied()
        .find(|(name, _)| *name == first)
}

/// The `k`-th variant of a controller's colour: itself, then alternately darker and lighter.
pub(super) fn shade(colour: RGBColor, k: usize) -> RGBColor {
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
pub(super) fn fnv1a(text: &str) -> u64 {
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
pub(super) fn label_colours<S: AsRef<str>>(labels: &[S]) -> Vec<RGBColor> {
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

/// Viridis (van der Walt and Smith, matplotlib's default map) at eleven evenly spaced stops:
/// perceptually uniform, readable in grey and by colour-blind readers, so equal steps of a
/// swept number look like equal steps of colour.
pub(super) const VIRIDIS: [RGBColor; 11] = [
    RGBColor(68, 1, 84),
    RGBColor(72, 36, 117),
    RGBColor(65, 68, 135),
    RGBColor(53, 95, 141),
    RGBColor(42, 120, 142),
    RGBColor(33, 145, 140),
    RGBColor(34, 168, 132),
    RGBColor(68, 191, 112),
    RGBColor(122, 209, 81),
    RGBColor(189, 223, 38),
    RGBColor(253, 231, 37),
];

/// Viridis at `t` in [0, 1] (clamped; NaN gives the low end), linear between the stops.
pub(super) fn viridis(t: f64) -> RGBColor {
    let t = if t.is_nan() { 0.0 } else { t.clamp(0.0, 1.0) };
    let last = VIRIDIS.len() - 1;
    let position = t * last as f64;
    let k = (position.floor() as usize).min(last - 1);
    let f = position - k as f64;
    let (RGBColor(r0, g0, b0), RGBColor(r1, g1, b1)) = (VIRIDIS[k], VIRIDIS[k + 1]);
    let mix = |a: u8, b: u8| (f64::from(a) + (f64::from(b) - f64::from(a)) * f).round() as u8;
    RGBColor(mix(r0, r1), mix(g0, g1), mix(b0, b1))
}

/// Where viridis stops for data: its last tenth, a pale yellow, is hard to see on white.
pub(super) const SCALE_TOP: f64 = 0.9;

/// A numeric value's place on a colour scale over `lo..=hi`: viridis from its dark end (`lo`)
/// to [`SCALE_TOP`] (`hi`); a scale of one value takes the middle colour.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(super) struct ValueScale {
    pub(super) lo: f64,
    pub(super) hi: f64,
}

impl ValueScale {
    /// The scale spanning the finite `values` (`None` when there is none).
    pub(super) fn spanning(values: &[f64]) -> Option<ValueScale> {
        let finite = values.iter().copied().filter(|v| v.is_finite());
        let (lo, hi) = extent(finite);
        (lo <= hi).then_some(ValueScale { lo, hi })
    }

    /// Position of `v` on the viridis map, in [0, SCALE_TOP].
    pub(super) fn position(&self, v: f64) -> f64 {
        if self.hi > self.lo {
            ((v - self.lo) / (self.hi - self.lo)).clamp(0.0, 1.0) * SCALE_TOP
        } else {
            SCALE_TOP / 2.0
        }
    }

    /// The colour of `v`.
    pub(super) fn colour(&self, v: f64) -> RGBColor {
        viridis(self.position(v))
    }
}
