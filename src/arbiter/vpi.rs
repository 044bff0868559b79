//! `vpi` (SPEC 12.4, Keramati, Dezfouli & Piray 2011): a Kalman MF, and per action MB's value
//! when the value of perfect information about the action exceeds the cost of the time to get
//! it (`vpi_tau` times the average reward).

use std::f64::consts::PI;
use std::sync::LazyLock;

use super::{Arbiter, Choice, Draw, Inputs, Model, Own, Transition};
use crate::analysis::stats::{normal_cdf, normal_sf};
use crate::expert::mf;
use crate::params::Params;

/// The run's average reward, its one scalar.
const RBAR: usize = 0;

/// Value of information, per action.
pub struct Vpi;

/// The standard normal density.
fn normal_pdf(z: f64) -> f64 {
    (-0.5 * z * z).exp() / (2.0 * PI).sqrt()
}

/// VPI of every action (SPEC 12.4) from the MF means `q` and variances `var` of one state,
/// written into `out`: the reference [`plan`] is checked against (a decision needs only the
/// comparisons). a1 is the best mean, a2 the second (ties by the lower action index). At
/// sigma = 0 a VPI is its limit, 0 (a certain value brings no information). With a single
/// action there is no alternative to learn about: 0.
#[cfg(test)]
pub fn vpi(q: &[f64], var: &[f64], out: &mut [f64]) {
    let n = q.len();
    if n < 2 {
        out.fill(0.0);
        return;
    }
    let mut a1 = 0;
    for a in 1..n {
        if q[a] > q[a1] {
            a1 = a;
        }
    }
    let mut a2 = usize::from(a1 == 0);
    for a in 0..n {
        if a != a1 && q[a] > q[a2] {
            a2 = a;
        }
    }
    for a in 0..n {
        let sigma = var[a].sqrt();
        out[a] = if sigma == 0.0 {
            0.0
        } else if a == a1 {
            let d = q[a2] - q[a1];
            d * normal_cdf(d / sigma) + sigma * normal_pdf(d / sigma)
        } else {
            let z = (q[a1] - q[a]) / sigma;
            (q[a] - q[a1]) * (1.0 - normal_cdf(z)) + sigma * normal_pdf(z)
        };
    }
}

/// Whether each action's VPI (as `vpi` computes it, bit for bit) reaches `threshold`: 1.0 or
/// 0.0 in `flags`; returns how many do. A decision needs only these comparisons: most are
/// settled from a table of bounds ([`settled_by_table`]), and the rest compute a VPI no further
/// than their comparison needs ([`reaches`]).
pub fn plan(q: &[f64], var: &[f64], threshold: f64, flags: &mut [f64]) -> usize {
    let n = q.len();
    if n < 2 {
        let by_mb = 0.0 >= threshold;
        flags.fill(if by_mb { 1.0 } else { 0.0 });
        return if by_mb { n } else { 0 };
    }
    // a1 and a2 in one pass, as [`vpi`]'s two find them: a new best hands its place to the old
    // one, the first of its equals; ties keep the lower index.
    let (mut a1, mut a2) = if q[1] > q[0] { (1, 0) } else { (0, 1) };
    for a in 2..n {
        if q[a] > q[a1] {
            a2 = a1;
            a1 = a;
        } else if q[a] > q[a2] {
            a2 = a;
        }
    }
    // A threshold far from 0 and infinity lets the loss table settle most comparisons.
    let table = TABLE_RANGE.contains(&threshold).then(|| &*LOSS_BOUNDS);
    let mut planned = 0;
    for a in 0..n {
        // Both formulas are `linear * c + tail`, linear = -|z| sigma the distance to the other
        // best mean: the best's to the second, another's to the best.
        let linear = if a == a1 { q[a2] - q[a1] } else { q[a] - q[a1] };
        let by_mb = match table.and_then(|t| settled_by_table(t, linear, var[a], threshold)) {
            Some(answer) => answer,
            None => reaches(linear, var[a], a == a1, threshold),
        };
        flags[a] = if by_mb { 1.0 } else { 0.0 };
        planned += usize::from(by_mb);
    }
    planned
}

/// Both VPI formulas are sigma g(x), x = |z|, with g(x) = phi(x) - x (1 - Phi(x)) the standard
/// normal loss function; so for a threshold T > 0 the comparison VPI >= T is V G(p) >= T^2, V the
/// variance, p = x^2 = linear^2 / V, G(p) = g(sqrt p)^2 decreasing. [`LOSS_BOUNDS`] bounds G on
/// buckets of p cut by its float bits (eighths of an octave: `OCTAVE_BITS` bits of the
/// mantissa), so that a division for p, then a multiplication and a comparison against each
/// bound, settle all but a few comparisons in a thousand (on tidy1) without a square root, an
/// `exp` or an `erfc`; the rest go to [`reaches`].
const OCTAVE_BITS: u32 = 3;

/// The buckets' octaves of p: from 2^-30 (below, G is within 1e-4 of G(0), one bucket) to 2^8
/// (x = 16, where G is about 1e-117; above, one bucket whose upper bound alone is used).
const FIRST_OCTAVE: i64 = -30;
const OCTAVES: usize = 38;

/// The buckets: one below the first octave, eight per octave, one from the last octave up.
const BUCKETS: usize = (OCTAVES << OCTAVE_BITS) + 2;

/// Relative margin of the table's bounds: far above the computed VPI's own (see
/// [`BOUND_MARGIN`], [`LINEAR_MARGIN`]), the squares' and products' roundings, and the error of
/// G computed at the buckets' edges (about 1e-13 relative at x = 16).
const TABLE_MARGIN: f64 = 1e-7;

/// Thresholds and variances for which the table's products neither underflow nor overflow.
const TABLE_RANGE: std::ops::RangeInclusive<f64> = 1e-100..=1e100;

/// The bucket of p >= 0 (or +inf): the bits of a non-negative float, read as an integer, grow
/// with it, so their top bits name its octave and the eighth of the octave.
#[inline(always)]
fn bucket(p: f64) -> usize {
    let first = (1023 + FIRST_OCTAVE) << OCTAVE_BITS;
    let j = (p.to_bits() >> (52 - OCTAVE_BITS)) as i64 - first + 1;
    j.clamp(0, BUCKETS as i64 - 1) as usize
}

/// The lower edge of bucket `b` (1 to `BUCKETS - 1`): exact in floating point.
fn bucket_start(b: usize) -> f64 {
    let j = (b - 1) as i64;
    let (octave, eighth) = (j >> OCTAVE_BITS, j & ((1 << OCTAVE_BITS) - 1));
    let unit = (2.0f64).powi((FIRST_OCTAVE + octave) as i32);
    unit * (1.0 + eighth as f64 / (1 << OCTAVE_BITS) as f64)
}

/// G(p) = g(sqrt p)^2, g the standard normal loss function (with the survival function, which
/// keeps its digits in the far tail where 1 - Phi would not).
fn loss_squared(p: f64) -> f64 {
    let x = p.sqrt();
    let g = normal_pdf(x) - x * normal_sf(x);
    g * g
}

/// Per bucket of p: (below, above), below <= G(p) (1 - margins) and above >= G(p) (1 +
/// margins) for every p of the bucket. The last bucket's `below` is 0: it settles no VPI as
/// reaching the threshold.
static LOSS_BOUNDS: LazyLock<[(f64, f64); BUCKETS]> = LazyLock::new(|| {
    let mut bounds = [(0.0, 0.0); BUCKETS];
    for (b, bound) in bounds.iter_mut().enumerate() {
        let start = if b == 0 { 0.0 } else { bucket_start(b) };
        let end = (b + 1 < BUCKETS).then(|| bucket_start(b + 1));
        let below = end.map_or(0.0, |e| loss_squared(e) * (1.0 - TABLE_MARGIN));
        *bound = (below, loss_squared(start) * (1.0 + TABLE_MARGIN));
    }
    bounds
});

/// Whether the VPI of an action at distance `linear` with variance `var` reaches `threshold`
/// (in [`TABLE_RANGE`]), if the loss table settles it: VPI is sigma g(x) up to
/// [`BOUND_MARGIN`] relative and `LINEAR_MARGIN |linear|` absolute, so it reaches T when V G >=
/// (T + slack)^2 and falls short when V G < (T - slack)^2, G bounded by the bucket of p.
#[inline(always)]
fn settled_by_table(
    bounds: &[(f64, f64); BUCKETS],
    linear: f64,
    var: f64,
    threshold: f64,
) -> Option<bool> {
    if !TABLE_RANGE.contains(&var) {
        return None;
    }
    let slack = LINEAR_MARGIN * linear.abs();
    let (below, above) = bounds[bucket(linear * linear / var)];
    let (high, low) = (threshold + slack, threshold - slack);
    if var * below >= high * high {
        Some(true)
    } else if low > 0.0 && var * above < low * low {
        Some(false)
    } else {
        None
    }
}

/// Relative margin of the bounds in [`reaches`] on the VPI computed in floating point: far above
/// the rounding of its few operations and the normal CDF's error (about 1e-13 relative).
const BOUND_MARGIN: f64 = 1e-9;

/// Margin on the absolute error of `1 - Phi(z)` (two roundings near 1), times the linear term.
const LINEAR_MARGIN: f64 = 1e-14;

/// Lower and upper bounds on 1 - x R(x), the VPI over its tail sigma phi(z) at x = |z|, with R
/// the Mills ratio (1 - Phi) / phi: R lies between 2 / (x + sqrt(x^2 + 4)) (Birnbaum 1942) and
/// 2 / (x + sqrt(x^2 + 8/pi)) (Sampford 1953), which give 8/pi / (t + x)^2 with t = sqrt(x^2 +
/// 8/pi), and 4 / (s + x)^2 with s = sqrt(x^2 + 4); 4 / (s + x)^2 <= 1 / (1 + x^2). Each as
/// (numerator, denominator), so that a comparison needs no division.
#[inline(always)]
fn vpi_over_tail(x: f64) -> ((f64, f64), (f64, f64)) {
    let eight_over_pi = 8.0 / PI;
    let t = (x * x + eight_over_pi).sqrt() + x;
    let s = (x * x + 4.0).sqrt() + x;
    ((eight_over_pi, t * t), (4.0, s * s))
}

/// 1/6, for the cubic term of the density's upper bound (a product is quicker than a quotient;
/// its rounding is far inside [`BOUND_MARGIN`]).
const SIXTH: f64 = 1.0 / 6.0;

/// Whether the VPI of one action of variance `var`, `linear * c + sigma phi(z)` with z = linear
/// / sigma for the best action (`best`, c = Phi(z)) and -linear / sigma for another (c = 1 -
/// Phi(z)), as `vpi` computes it, bit for bit, reaches `threshold`, computing as little of it
/// as the comparison needs.
///
/// Both formulas are a non-positive term plus the tail sigma phi(z), equal to the tail times 1 -
/// |z| R(|z|), bounded by [`vpi_over_tail`]; and phi(z) = phi(0) e^-y, y = z^2 / 2, lies between
/// phi(0) (1 - y/8)^8 (for y <= 8) and phi(0) / (1 + y + y^2/2 + y^3/6). Where these bounds
/// settle the comparison with a margin far above the rounding of the computed value, neither the
/// density's `exp` nor the normal CDF (an erfc, most of the rule's cost) is evaluated; elsewhere
/// the VPI is computed as `vpi` does. (The computed VPI never exceeds the computed tail, its
/// linear term being non-positive, so a VPI that reaches the threshold passes the tail's test.)
///
/// The commonest answer, a VPI far below the threshold, is found first from z^2 = linear^2 /
/// var, which needs neither the square root nor z: the bound's few roundings, and those of z^2
/// against (linear / sigma)^2, stay far inside its margin. (Where linear^2 underflows, z^2 = 0
/// gives the tail's own bound sigma phi(0), which the computed VPI never exceeds either.)
#[inline(always)]
fn reaches(linear: f64, var: f64, best: bool, threshold: f64) -> bool {
    let pdf_at_0 = normal_pdf(0.0);
    let sigma = var.sqrt();
    if sigma == 0.0 {
        // A certain value: the VPI is its limit, 0.
        return 0.0 >= threshold;
    }
    if sigma * pdf_at_0 < threshold {
        return false;
    }
    let slack = LINEAR_MARGIN * linear.abs();
    // Each test below is `bound (+ or -) margins` against `threshold`, multiplied out by the
    // bound's positive denominator.
    let m = BOUND_MARGIN;
    {
        let x2 = linear * linear / var;
        let y = 0.5 * x2;
        // Above: sigma phi(0) / (1 + y + y^2/2 + y^3/6) times 1 / (1 + x^2).
        let (over, inv) = (1.0 + y * (1.0 + y * (0.5 + y * SIXTH)), 1.0 + x2);
        if sigma * pdf_at_0 * (1.0 + m * inv) < (threshold - slack) * (over * inv) {
            return false;
        }
    }
    let z = if best {
        linear / sigma
    } else {
        -linear / sigma
    };
    // The lower bounds assume linear = -|z| sigma up to rounding: not so where z underflowed.
    let bounded = if z == 0.0 {
        linear == 0.0
    } else {
        z.abs() >= f64::MIN_POSITIVE
    };
    if bounded {
        let x = z.abs();
        let y = 0.5 * x * x;
        if y <= 8.0 {
            // Below: sigma phi(0) (1 - y/8)^8 times the lower bound of the VPI over its tail.
            let r = 1.0 - y / 8.0;
            let r2 = r * r;
            let density_below = sigma * pdf_at_0 * (r2 * r2) * (r2 * r2);
            let ((num, den), _) = vpi_over_tail(x);
            if density_below >= f64::MIN_POSITIVE
                && density_below * (num - m * den) >= (threshold + slack) * den
            {
                return true;
            }
        }
    }
    let tail = sigma * normal_pdf(z);
    if tail < threshold {
        return false;
    }
    if bounded && tail >= f64::MIN_POSITIVE {
        let ((lo_num, lo_den), (up_num, up_den)) = vpi_over_tail(z.abs());
        if tail * (up_num + m * up_den) < (threshold - slack) * up_den {
            return false;
        }
        if tail * (lo_num - m * lo_den) >= (threshold + slack) * lo_den {
            return true;
        }
    }
    if best {
        linear * normal_cdf(z) + tail >= threshold
    } else {
        linear * (1.0 - normal_cdf(z)) + tail >= threshold
    }
}

/// One Kalman update of a mean `q` and variance `v` towards the target `y` (SPEC 12.4):
/// V grows by `kalman_eta`, then K = V / (V + noise), Q += K (y - Q), V = (1 - K) V.
pub fn kalman(params: &Params, q: &mut f64, v: &mut f64, y: f64) {
    let grown = *v * (1.0 + params.kalman_eta);
    let k = grown / (grown + params.kalman_noise);
    *q += k * (y - *q);
    *v = (1.0 - k) * grown;
}

/// The state's block of the run's pair tables: its variances, then its MB flags, one per
/// action (a state's rows side by side, so a rule that knows only the action count finds them).
#[inline(always)]
fn block(n_actions: usize, state: usize) -> std::ops::Range<usize> {
    2 * state * n_actions..2 * (state + 1) * n_actions
}

impl Arbiter for Vpi {
    /// MB infers only when an action takes its value, the first decision in a state included.
    const FIRST_DECISION_BOTH: bool = false;
    const OBSERVES: bool = true;
    const DRAW: Draw = Draw::PerAction;
    const LEARNS_MF: bool = true;
    const PARAMS: &'static [&'static str] = &[
        "kalman_v0",
        "kalman_eta",
        "kalman_noise",
        "rbar_rate",
        "vpi_tau",
    ];

    fn run_scalars(_params: &Params) -> usize {
        1
    }

    fn pair_tables(_params: &Params) -> usize {
        2
    }

    /// Every variance starts at `kalman_v0`. (The flags share the fill: each decision writes
    /// its state's before reading them.)
    fn start(params: &Params, own: &mut Own<'_>) {
        own.pairs.fill(params.kalman_v0);
    }

    #[inline(always)]
    fn choose(inputs: &mut Inputs<'_>) -> Choice {
        let n = inputs.n_actions;
        let threshold = inputs.params.vpi_tau * inputs.own.run[RBAR];
        let (var, flags) = inputs.own.pairs[block(n, inputs.state)].split_at_mut(n);
        let planned = plan(&inputs.q_mf[inputs.row.clone()], var, threshold, flags);
        Choice {
            use_mb: planned > 0,
            p_mb: planned as f64 / n as f64,
            chosen_entropy: f64::NAN,
        }
    }

    #[inline(always)]
    fn action_values(own: &Own<'_>, state: usize, q_mf: &[f64], q_mb: &[f64], out: &mut [f64]) {
        let n = q_mf.len();
        let flags = &own.pairs[block(n, state)][n..];
        for a in 0..n {
            out[a] = if flags[a] != 0.0 { q_mb[a] } else { q_mf[a] };
        }
    }

    #[inline(always)]
    fn observe(
        params: &Params,
        own: &mut Own<'_>,
        t: &Transition,
        _q_mf: &[f64],
        _model: &Model<'_>,
    ) {
        let rate = params.rbar_rate;
        own.run[RBAR] = (1.0 - rate) * own.run[RBAR] + rate * t.r;
    }

    #[inline(always)]
    fn learn_mf(params: &Params, own: &mut Own<'_>, t: &Transition, q_mf: &mut [f64]) {
        let n = t.n_actions;
        let y = t.r + params.gamma_mf * mf::future(q_mf, n, t.next, t.terminal);
        let v = &mut own.pairs[block(n, t.s).start + t.a];
        kalman(params, &mut q_mf[t.s * n + t.a], v, y);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Expected values from python: Phi(z) = 0.5 * math.erfc(-z / sqrt(2)), phi(z) =
    /// exp(-z^2 / 2) / sqrt(2 pi), and SPEC 12.4's two formulas.
    fn check(q: &[f64], var: &[f64], expected: &[f64]) {
        let mut out = vec![f64::NAN; q.len()];
        vpi(q, var, &mut out);
        for (a, (&got, &want)) in out.iter().zip(expected).enumerate() {
            assert!(
                (got - want).abs() <= 1e-14 + 1e-12 * want.abs(),
                "VPI({a}) of {q:?}, {var:?}: {got} vs {want}"
            );
        }
    }

    #[test]
    fn vpi_matches_the_normal_cdf_and_density() {
        // a1 = 0, a2 = 1. VPI(a1) = -0.5 Phi(-0.5) + phi(-0.5); VPI(1) = -0.5 (1 - Phi(1)) + 0.5
        // phi(1); VPI(2) = -1 (1 - Phi(5)) + 0.2 phi(5).
        check(
            &[1.0, 0.5, 0.0],
            &[1.0, 0.25, 0.04],
            &[
                0.197_796_557_401_306_08,
                0.041_657_735_293_843_146,
                1.069_233_102_332_441_2e-8,
            ],
        );
    }

    #[test]
    fn vpi_of_ties_and_zero_variance() {
        // Tied best: a1 = 0 (lower index), a2 = 1: VPI = sigma phi(0) = sigma / sqrt(2 pi).
        // Action 2 has variance 0: its limit, 0.
        check(
            &[0.3, 0.3, 0.1],
            &[0.01, 1.0, 0.0],
            &[0.039_894_228_040_143_274, 0.398_942_280_401_432_7, 0.0],
        );
        // Certain values: no information to gain anywhere; a single action neither.
        check(&[0.2, 0.0], &[0.0, 0.0], &[0.0, 0.0]);
        check(&[0.2], &[1.0], &[0.0]);
    }

    /// Uniforms in [0, 1) from a xorshift generator seeded with `state`: inputs that are the same
    /// at every run of the tests.
    fn uniforms(mut state: u64) -> impl FnMut() -> f64 {
        move || {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            (state >> 11) as f64 / (1u64 << 53) as f64
        }
    }

    #[test]
    fn the_plan_flags_exactly_the_actions_whose_vpi_reaches_the_threshold() {
        // Inputs around every branch: certain values, small and large variances, ties, VPIs
        // just below and above the threshold, negative and NaN thresholds.
        let mut next = uniforms(0x2545_f491_4f6c_dd1d);
        for case in 0..50_000 {
            let n = 1 + case % 7;
            // Some rows' differences are so small that their squares underflow.
            let scale = if case % 11 == 0 { 1e-155 } else { 1.0 };
            let q: Vec<f64> = (0..n)
                .map(|_| ((next() * 4.0).round() / 4.0 - 0.5) * scale)
                .collect();
            let var: Vec<f64> = (0..n)
                .map(|_| match (next() * 5.0) as u32 {
                    0 => 0.0,
                    1 => next() * 1e-4,
                    // Small variances, far tails: z of tens and hundreds.
                    2 => next() * 1e-2 * 10f64.powi(-((next() * 8.0) as i32)),
                    _ => next(),
                })
                .collect();
            let mut values = vec![0.0; n];
            vpi(&q, &var, &mut values);
            let thresholds = [
                0.0,
                -0.1,
                f64::NAN,
                next() * 0.2,
                values[case % n],
                values[case % n] + f64::EPSILON,
                // Just either side of a VPI, where the bounds must leave it to the exact value.
                values[case % n] * (1.0 - 1e-12),
                values[case % n] * (1.0 + 1e-12),
                values[(case + 1) % n] * (1.0 + 1e-6),
            ];
            for threshold in thresholds {
                let mut flags = vec![f64::NAN; n];
                let planned = plan(&q, &var, threshold, &mut flags);
                let expected: Vec<f64> = values
                    .iter()
                    .map(|&v| if v >= threshold { 1.0 } else { 0.0 })
                    .collect();
                assert_eq!(flags, expected, "{q:?} {var:?} at {threshold}");
                assert_eq!(planned, expected.iter().filter(|&&f| f == 1.0).count());
            }
        }
    }

    #[test]
    fn the_buckets_cut_p_at_eighths_of_octaves() {
        assert_eq!(bucket(0.0), 0);
        assert_eq!(bucket(2f64.powi(-31)), 0);
        assert_eq!(bucket(2f64.powi(-30)), 1);
        assert_eq!(bucket_start(1), 2f64.powi(-30));
        // 1.0 = 2^0: octave 30 from the first, its first eighth; 1.125 starts the next eighth.
        assert_eq!(bucket(1.0), 1 + 30 * 8);
        assert_eq!(bucket(1.124_999), 1 + 30 * 8);
        assert_eq!(bucket(1.125), 2 + 30 * 8);
        assert_eq!(bucket_start(2 + 30 * 8), 1.125);
        assert_eq!(bucket(255.9), BUCKETS - 2);
        assert_eq!(bucket(256.0), BUCKETS - 1);
        assert_eq!(bucket(f64::INFINITY), BUCKETS - 1);
        assert_eq!(bucket(f64::NAN), BUCKETS - 1);
        // Every edge starts its own bucket, and the value just below it is in the one before.
        for b in 1..BUCKETS {
            let start = bucket_start(b);
            assert_eq!(bucket(start), b, "{start}");
            assert_eq!(bucket(start.next_down()), b - 1, "{start}");
        }
    }

    #[test]
    fn the_loss_bounds_hold_g_squared_across_each_bucket() {
        // G at each bucket's edges and inside (g from the survival function, which keeps its
        // digits in the far tail): the table's bounds hold it, with room for the margins.
        let bounds = &*LOSS_BOUNDS;
        for (b, &(below, above)) in bounds.iter().enumerate() {
            let start = if b == 0 { 0.0 } else { bucket_start(b) };
            let end = if b + 1 < BUCKETS {
                bucket_start(b + 1)
            } else {
                1e4
            };
            for i in 0..=16 {
                let p = if i == 16 {
                    end.next_down()
                } else {
                    start + (end - start) * f64::from(i) / 16.0
                };
                let x = p.sqrt();
                let g = normal_pdf(x) - x * normal_sf(x);
                assert!(below <= g * g * (1.0 - 5e-8), "bucket {b} at p = {p}");
                assert!(above >= g * g * (1.0 + 5e-8), "bucket {b} at p = {p}");
            }
        }
        assert_eq!(
            bounds[BUCKETS - 1].0,
            0.0,
            "the last bucket settles no VPI as reaching"
        );
        // At x = 2 (G falls as p^-5.4 there) an eighth of an octave of p spans a factor of 1.9.
        let (below, above) = bounds[bucket(4.0)];
        assert!((1.8..2.0).contains(&(above / below)), "{below} {above}");
    }

    #[test]
    fn the_plan_leaves_to_the_exact_vpi_whatever_the_table_cannot_settle() {
        // Thresholds at relative distances from the computed VPI that the table must leave
        // (1e-9 and closer) or may settle (1e-3 and farther), for x from 0 to 20 and
        // variances across and outside the table's range.
        let mut next = uniforms(0x9e37_79b9_7f4a_7c15);
        for case in 0..20_000 {
            let var = 10f64.powf(next() * 240.0 - 120.0);
            let x = next() * 20.0;
            let sigma = var.sqrt();
            let q = [x * sigma, 0.0, -x * sigma * next()];
            let v = [var, var, var * next()];
            let mut values = [0.0; 3];
            vpi(&q, &v, &mut values);
            let a = case % 3;
            for rel in [0.0, 1e-12, -1e-12, 1e-9, -1e-9, 1e-3, -1e-3, 0.5, -0.5] {
                let threshold = values[a] * (1.0 + rel);
                let mut flags = [f64::NAN; 3];
                plan(&q, &v, threshold, &mut flags);
                let expected: Vec<f64> = values
                    .iter()
                    .map(|&value| if value >= threshold { 1.0 } else { 0.0 })
                    .collect();
                assert_eq!(flags.to_vec(), expected, "{q:?} {v:?} at {threshold}");
            }
        }
    }

    #[test]
    fn kalman_update_by_hand() {
        // V = 1 * (1 + 1e-4) = 1.0001; K = 1.0001 / 1.0501 = 0.952385...; Q = 0 + K (1 - 0);
        // V = (1 - K) 1.0001 = 0.05 * 1.0001 / 1.0501.
        let params = Params::default();
        let (mut q, mut v) = (0.0, 1.0);
        kalman(&params, &mut q, &mut v, 1.0);
        assert!((q - 1.0001 / 1.0501).abs() < 1e-15, "{q}");
        assert!((v - 0.05 * 1.0001 / 1.0501).abs() < 1e-15, "{v}");
        // The gain shrinks as the variance does: a second identical target moves Q less.
        let before = q;
        kalman(&params, &mut q, &mut v, 2.0);
        let k2 = (0.05 * 1.0001 / 1.0501 * 1.0001) / (0.05 * 1.0001 / 1.0501 * 1.0001 + 0.05);
        assert!((q - (before + k2 * (2.0 - before))).abs() < 1e-15);
        assert!(k2 < 0.5);
    }
}
