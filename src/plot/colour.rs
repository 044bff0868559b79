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
