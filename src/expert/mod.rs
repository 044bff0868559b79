//! The two experts (SPEC 3) and the policy arithmetic they share: softmax, entropy and the
//! exponential moving averages. Every function works on one run's slices, so the batch engine can
//! call it on rows of its `[run, state, action]` arrays without copying.

pub mod mb;
pub mod mf;

/// Softmax of `q[a] + bonus * g[a]` with temperature `tau`, written into `out` (Eqs. 3 and 8).
///
/// The maximum is subtracted first so no `exp` overflows, whatever the values and `tau`.
#[inline]
pub fn softmax_biased(q: &[f64], g: &[u8], bonus: f64, tau: f64, out: &mut [f64]) {
    softmax_graded(q, g, bonus, tau, out, f64::from);
}

/// G(s, a) of a real person's punishment: -1 when read signed by [`softmax_graded_by`] (the simulated
/// humans' G is 0 or 1, kept unsigned because the unsigned conversion is the cheaper one in the
/// hot loop).
pub const PUNISHED: u8 = (-1i8).cast_unsigned();

/// [`softmax_biased`], with G read as signed (+1, 0, or -1 stored as [`PUNISHED`]) when
/// `signed`: a person both congratulates and punishes, with one weight.
#[inline]
pub fn softmax_graded_by(signed: bool, q: &[f64], g: &[u8], bonus: f64, tau: f64, out: &mut [f64]) {
    if signed {
        softmax_graded(q, g, bonus, tau, out, |g| f64::from(g.cast_signed()));
    } else {
        softmax_biased(q, g, bonus, tau, out);
    }
}

/// The softmax of Eqs. 3 and 8 with G(s, a) read by `grade`.
#[inline(always)]
fn softmax_graded(
    q: &[f64],
    g: &[u8],
    bonus: f64,
    tau: f64,
    out: &mut [f64],
    grade: impl Fn(u8) -> f64,
) {
    debug_assert!(q.len() == g.len() && q.len() == out.len());
    // Equal lengths up front, so the loops below carry no bounds checks and the element-wise
    // ones vectorise.
    let n = out.len();
    let (q, g) = (&q[..n], &g[..n]);
    let mut max = f64::NEG_INFINITY;
    for i in 0..n {
        let biased = q[i] + bonus * grade(g[i]);
        out[i] = biased;
        max = max.max(biased);
    }
    // NOTE: SPEC 3.3's literal arithmetic, exp((v - max) / tau) / sum (the sum in action order),
    // so that independent implementations agree to the last bit.
    for o in out.iter_mut() {
        *o = (*o - max) / tau;
    }
    // Rows often repeat values (untried actions, no-op actions that converge alike): an argument
    // equal to one of the last two exponentiated, or 0 (the maximum's: exp(0) = 1 exactly, IEEE
    // 754, C Annex F), reuses its value.
    let mut cache = Recent::pinned(0.0, 1.0);
    let mut sum = 0.0;
    for o in out.iter_mut() {
        let e = cache.get_or(*o, f64::exp);
        *o = e;
        sum += e;
    }
    for o in out.iter_mut() {
        *o /= sum;
    }
}

/// Maximum of a Q row, folded in action order; NaN entries are skipped and an empty or all-NaN
/// row gives -inf, so the result is never NaN. Both experts' future terms use it, and a maximum
/// kept between steps is bit for bit the one computed afresh.
#[inline(always)]
pub fn max_of(row: &[f64]) -> f64 {
    row.iter().copied().fold(f64::NEG_INFINITY, f64::max)
}

/// Base-2 entropy of a distribution, with 0 log 0 = 0 (SPEC 3.3, Eq. 5).
#[inline]
pub fn entropy_bits(p: &[f64]) -> f64 {
    let mut h = 0.0;
    // Equal probabilities give equal terms: a probability equal to one of the last two whose
    // term was computed reuses it. (Only positive ones are asked, so the pinned 0 never is.)
    let mut cache = Recent::pinned(0.0, 0.0);
    for &x in p {
        if x > 0.0 {
            h -= cache.get_or(x, |x| x * x.log2());
        }
    }
    h.max(0.0)
}

/// Entropy divided by log2(|A|), clamped to [0, 1] against rounding (SPEC 3.3).
#[inline]
pub fn normalised_entropy(p: &[f64]) -> f64 {
    normalise_bits(entropy_bits(p), p.len())
}

/// An entropy of `bits` over `n` actions divided by log2(n), clamped to [0, 1]; 0 when n < 2.
/// `normalised_entropy(p) == normalise_bits(entropy_bits(p), p.len())`, bit for bit.
#[inline]
pub fn normalise_bits(bits: f64, n: usize) -> f64 {
    if n < 2 {
        return 0.0;
    }
    (bits / log2_count(n)).clamp(0.0, 1.0)
}

/// `(n as f64).log2()`, from a table for small n (the same values: the table is built with it).
#[inline]
fn log2_count(n: usize) -> f64 {
    const TABLE_LEN: usize = 64;
    static TABLE: std::sync::OnceLock<[f64; TABLE_LEN]> = std::sync::OnceLock::new();
    if n < TABLE_LEN {
        TABLE.get_or_init(|| std::array::from_fn(|i| (i as f64).log2()))[n]
    } else {
        (n as f64).log2()
    }
}

/// Results of a pure function for the last two distinct arguments (compared bit for bit), and
/// for one pinned argument given with its result, so a row with repeated values costs about one
/// call per distinct value, with identical results. Fixed slots rather than a searched table:
/// rows are short and their repeats mostly neighbours or one shared value. The three compares
/// settle on one branch (hit or miss) and the hit's value is selected without branching: rows
/// mix repeats and fresh values unpredictably, and each branch there is a likely mispredict.
struct Recent {
    /// The pinned argument's key, then the last two computed (most recent first); empty slots
    /// hold the pinned key.
    keys: [u64; 3],
    values: [f64; 3],
}

impl Recent {
    /// No argument computed yet; `f(x) = fx` known.
    #[inline(always)]
    fn pinned(x: f64, fx: f64) -> Recent {
        let key = x.to_bits();
        Recent {
            keys: [key; 3],
            values: [fx; 3],
        }
    }

    /// `f(x)`, from memory when `x` is the pinned argument or one of the last two computed.
    #[inline(always)]
    fn get_or(&mut self, x: f64, f: impl Fn(f64) -> f64) -> f64 {
        let key = x.to_bits();
        let hits = [
            key == self.keys[0],
            key == self.keys[1],
            key == self.keys[2],
        ];
        if hits[0] | hits[1] | hits[2] {
            let recent = if hits[1] {
                self.values[1]
            } else {
                self.values[2]
            };
            return if hits[1] | hits[2] {
                recent
            } else {
                self.values[0]
            };
        }
        let value = f(x);
        self.keys[2] = self.keys[1];
        self.values[2] = self.values[1];
        self.keys[1] = key;
        self.values[1] = value;
        value
    }
}

/// One step of an exponential moving average: `(1 - alpha) * old + alpha * new`.
#[inline(always)]
pub fn ema(old: f64, new: f64, alpha: f64) -> f64 {
    (1.0 - alpha) * old + alpha * new
}

/// Folds a distribution into its moving average, element by element; whether any element
/// changed (bit for bit), so that what was computed from the average can be kept when none did.
#[inline]
pub fn ema_into(avg: &mut [f64], new: &[f64], alpha: f64) -> bool {
    let mut changed = false;
    for (a, &n) in avg.iter_mut().zip(new) {
        let folded = ema(*a, n, alpha);
        changed |= folded.to_bits() != a.to_bits();
        *a = folded;
    }
    changed
}

/// Index drawn from distribution `p` with a uniform `u` in [0, 1). Rounding can leave the
/// cumulative sum just under 1: then the last index with a positive probability is returned.
#[inline]
pub fn draw(p: &[f64], u: f64) -> usize {
    let mut cum = 0.0;
    let mut last_positive = 0;
    for (i, &x) in p.iter().enumerate() {
        if x > 0.0 {
            cum += x;
            last_positive = i;
            if u < cum {
                return i;
            }
        }
    }
    last_positive
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn softmax_with_bonus_matches_hand_computation() {
        // q = (0, 0.1), bonus zeta = 0.1 on action 0, tau = 0.1: both biased values are 0.1.
        let mut out = [0.0; 2];
        softmax_biased(&[0.0, 0.1], &[1, 0], 0.1, 0.1, &mut out);
        assert!((out[0] - 0.5).abs() < 1e-12 && (out[1] - 0.5).abs() < 1e-12);
        // Without the bonus: p1 = e^1 / (1 + e^1).
        softmax_biased(&[0.0, 0.1], &[0, 0], 0.1, 0.1, &mut out);
        let e = 1f64.exp();
        assert!((out[1] - e / (1.0 + e)).abs() < 1e-12);
    }

    #[test]
    fn a_persons_punishment_is_read_as_minus_one_only_when_signed() {
        // q = (0.1, 0), a punishment on action 0 with weight 0.1, tau 0.1: both biased values
        // are 0, so p = (0.5, 0.5).
        let mut out = [0.0; 2];
        softmax_graded_by(true, &[0.1, 0.0], &[PUNISHED, 0], 0.1, 0.1, &mut out);
        assert!((out[0] - 0.5).abs() < 1e-12 && (out[1] - 0.5).abs() < 1e-12);
        // Unsigned, the same byte is 255: action 0 takes all the mass.
        softmax_graded_by(false, &[0.1, 0.0], &[PUNISHED, 0], 0.1, 0.1, &mut out);
        assert!(out[0] > 1.0 - 1e-12);
        // A congratulation reads +1 either way.
        let mut signed = [0.0; 2];
        softmax_graded_by(true, &[0.0, 0.1], &[1, 0], 0.1, 0.1, &mut signed);
        softmax_graded_by(false, &[0.0, 0.1], &[1, 0], 0.1, 0.1, &mut out);
        assert_eq!(signed, out);
    }

    #[test]
    fn softmax_survives_huge_values_and_tiny_tau() {
        let mut out = [0.0; 3];
        softmax_biased(&[1e300, -1e300, 5.0], &[0, 0, 0], 0.0, 1e-6, &mut out);
        assert_eq!(out, [1.0, 0.0, 0.0]);
        let sum: f64 = out.iter().sum();
        assert!((sum - 1.0).abs() < 1e-12);
    }

    #[test]
    fn entropy_of_uniform_seven_is_log2_7_and_normalises_to_one() {
        let p = [1.0 / 7.0; 7];
        assert!((entropy_bits(&p) - 7f64.log2()).abs() < 1e-12);
        assert!((normalised_entropy(&p) - 1.0).abs() < 1e-12);
        assert_eq!(normalised_entropy(&[1.0, 0.0, 0.0]), 0.0);
        // H(0.5, 0.25, 0.25) = 1.5 bits.
        assert!((entropy_bits(&[0.5, 0.25, 0.25]) - 1.5).abs() < 1e-12);
    }

    #[test]
    fn recent_results_are_the_functions_and_spare_repeated_calls() {
        use std::cell::Cell;
        let calls = Cell::new(0);
        let f = |x: f64| {
            calls.set(calls.get() + 1);
            x.exp()
        };
        let mut cache = Recent::pinned(0.0, 1.0);
        // 0 is pinned; 2 and 3 are the last two when asked again; 1 has been pushed out by then.
        let args = [0.0, 1.0, 2.0, 1.0, 3.0, 2.0, 0.0, 3.0, 1.0, 0.0, -0.0];
        let computed = [0, 1, 2, 2, 3, 3, 3, 3, 4, 4, 5];
        for (&x, &count) in args.iter().zip(&computed) {
            assert_eq!(cache.get_or(x, f).to_bits(), x.exp().to_bits(), "f({x})");
            assert_eq!(calls.get(), count, "calls after f({x})");
        }
    }

    #[test]
    fn softmax_and_entropy_of_rows_with_repeats_are_the_plain_formulas_bit_for_bit() {
        let q = [0.3, 0.1, 0.3, 0.1, 0.2, 0.1, -0.4];
        let mut out = [0.0; 7];
        softmax_biased(&q, &[0; 7], 0.0, 0.07, &mut out);
        let max = 0.3;
        let e: Vec<f64> = q.iter().map(|&v| ((v - max) / 0.07).exp()).collect();
        let sum = e.iter().fold(0.0, |s, &x| s + x);
        for (got, want) in out.iter().zip(&e) {
            assert_eq!(got.to_bits(), (want / sum).to_bits());
        }
        let plain = out.iter().fold(0.0, |h: f64, &x| h - x * x.log2()).max(0.0);
        assert_eq!(entropy_bits(&out).to_bits(), plain.to_bits());
    }

    #[test]
    fn moving_average_weights_the_new_value_by_alpha() {
        assert!((ema(1.0, 0.0, 0.6) - 0.4).abs() < 1e-15);
        let mut avg = [0.5, 0.5];
        assert!(ema_into(&mut avg, &[1.0, 0.0], 0.6));
        assert!((avg[0] - 0.8).abs() < 1e-15 && (avg[1] - 0.2).abs() < 1e-15);
        // A distribution folded into itself stays what it is, and says so.
        let mut same = [0.25, 0.75];
        assert!(!ema_into(&mut same, &[0.25, 0.75], 0.6));
    }

    #[test]
    fn draw_follows_the_cumulative_distribution() {
        let p = [0.2, 0.0, 0.8];
        assert_eq!(draw(&p, 0.0), 0);
        assert_eq!(draw(&p, 0.19), 0);
        assert_eq!(draw(&p, 0.2), 2);
        assert_eq!(draw(&p, 0.999_999), 2);
        assert_eq!(draw(&[0.5, 0.5 - 1e-16, 0.0], 0.999_999_999_999_999_9), 1);
    }
}
