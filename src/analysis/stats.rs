//! Statistics for comparing conditions: mean, standard deviation, standard error and Student-t
//! confidence intervals; the Wilcoxon–Mann–Whitney test (exact and normal approximation, as
//! `scipy.stats.mannwhitneyu`); Holm's correction; and the special functions behind them
//! (`erfc`, the normal and Student-t distributions).
//!
//! Pure functions on slices. Descriptive statistics return NaN when they are undefined (too few
//! values), as numpy does, so that a missing cell stays visibly missing in a table; the test
//! returns a typed error for inputs it cannot test.
//!
//! NOTE: only `ln Γ` comes from `statrs`. Its `erfc` (so its normal distribution) is off by up
//! to 1e-10 relative in 0.18 and 0.19.1 (interval constants truncated to ten digits, fixed
//! upstream in statrs-dev/statrs#412, not yet released), and its Student-t loses 1e-6 in the
//! quantile and 8e-11 in the tail at 1e5 degrees of freedom; the scipy values below hold
//! these to 1e-13, 1e-10 and 1e-11.

use std::f64::consts::{FRAC_1_SQRT_2, FRAC_2_SQRT_PI, PI};
use std::fmt;

// ---------------------------------------------------------------------------------------------
// Descriptive statistics
// ---------------------------------------------------------------------------------------------

/// Arithmetic mean; NaN for an empty slice.
pub fn mean(xs: &[f64]) -> f64 {
    if xs.is_empty() {
        return f64::NAN;
    }
    xs.iter().sum::<f64>() / xs.len() as f64
}

/// Sample standard deviation (denominator `n - 1`); NaN for fewer than two values.
pub fn sd(xs: &[f64]) -> f64 {
    if xs.len() < 2 {
        return f64::NAN;
    }
    // Two passes: summing squared deviations from the mean avoids the cancellation of the
    // sum-of-squares formula when the mean is large compared with the spread.
    let m = mean(xs);
    let ss: f64 = xs.iter().map(|x| (x - m) * (x - m)).sum();
    (ss / (xs.len() - 1) as f64).sqrt()
}

/// Standard error of the mean, `sd / sqrt(n)`; NaN for fewer than two values.
pub fn sem(xs: &[f64]) -> f64 {
    sd(xs) / (xs.len() as f64).sqrt()
}

/// Half-width of the two-sided confidence interval for the mean at `level` (e.g. 0.95):
/// `t_{(1+level)/2, n-1} * sem`. NaN for fewer than two values or a level outside (0, 1).
pub fn ci_half_width(xs: &[f64], level: f64) -> f64 {
    if xs.len() < 2 || !(level > 0.0 && level < 1.0) {
        return f64::NAN;
    }
    student_t_quantile(0.5 + level / 2.0, (xs.len() - 1) as f64) * sem(xs)
}

/// Half-width of the two-sided 95% confidence interval for the mean, `t_{0.975, n-1} * sem`
/// (Student's t, so small samples get wider intervals). NaN for fewer than two values.
pub fn ci95_half_width(xs: &[f64]) -> f64 {
    ci_half_width(xs, 0.95)
}

// ---------------------------------------------------------------------------------------------
// Special functions and distributions
// ---------------------------------------------------------------------------------------------

/// Below this argument `erfc` uses the power series of `erf`; from it on, a continued fraction.
/// At 2, `erfc(2) ≈ 4.7e-3`, so `1 - erf` loses under three digits; the fraction converges in
/// about a hundred terms there and faster beyond.
const ERFC_SERIES_BELOW: f64 = 2.0;

/// Beyond this argument `erfc` underflows to zero in `f64`.
const ERFC_ZERO_FROM: f64 = 27.3;

/// Complementary error function, `erfc(x) = 1 - erf(x)`, with relative error around 1e-14 in
/// the upper tail (where p-values live): a positive-term power series for `|x| < 2` and a
/// continued fraction (modified Lentz) beyond, so tiny tail values keep their digits.
pub fn erfc(x: f64) -> f64 {
    if x.is_nan() {
        return f64::NAN;
    }
    if x < 0.0 {
        return 2.0 - erfc(-x);
    }
    if x < ERFC_SERIES_BELOW {
        1.0 - erf_series(x)
    } else if x < ERFC_ZERO_FROM {
        erfc_continued_fraction(x)
    } else {
        0.0
    }
}

/// `erf(x)` for `0 <= x < 2` from `erf(x) = 2/sqrt(pi) exp(-x^2) sum_k 2^k x^(2k+1) / (2k+1)!!`,
/// whose terms are all positive (no cancellation).
fn erf_series(x: f64) -> f64 {
    let x2 = x * x;
    let mut term = x;
    let mut sum = x;
    for k in 1..200 {
        term *= 2.0 * x2 / (2 * k + 1) as f64;
        sum += term;
        if term <= sum * f64::EPSILON {
            break;
        }
    }
    FRAC_2_SQRT_PI * (-x2).exp() * sum
}

/// `erfc(x)` for `x >= 2` from `exp(-x^2)/sqrt(pi) / (x + (1/2)/(x + 1/(x + (3/2)/(x + ...))))`.
fn erfc_continued_fraction(x: f64) -> f64 {
    const TINY: f64 = 1e-300;
    let mut f = x;
    let mut c = f;
    let mut d = 0.0;
    for k in 1..1000 {
        let a = k as f64 / 2.0;
        d = x + a * d;
        if d.abs() < TINY {
            d = TINY;
        }
        c = x + a / c;
        if c.abs() < TINY {
            c = TINY;
        }
        d = 1.0 / d;
        let delta = c * d;
        f *= delta;
        if (delta - 1.0).abs() <= f64::EPSILON {
            break;
        }
    }
    (-x * x).exp() / (PI.sqrt() * f)
}

/// Standard normal cumulative distribution function, `P(Z <= z)`.
pub fn normal_cdf(z: f64) -> f64 {
    0.5 * erfc(-z * FRAC_1_SQRT_2)
}

/// Standard normal survival function, `P(Z > z)`, accurate for large `z` (no `1 - cdf`).
pub fn normal_sf(z: f64) -> f64 {
    0.5 * erfc(z * FRAC_1_SQRT_2)
}

/// Natural log of the gamma function for `x > 0` (statrs' Lanczos approximation, about 2e-14
/// relative). NaN for `x <= 0`.
fn ln_gamma(x: f64) -> f64 {
    if x.is_nan() || x <= 0.0 {
        return f64::NAN;
    }
    statrs::function::gamma::ln_gamma(x)
}

/// `ln B(a, b) = ln Γ(a) + ln Γ(b) - ln Γ(a + b)` for `a, b > 0`. When the larger argument is
/// big, `ln Γ(big) - ln Γ(big + small)` is taken from Stirling's series in a form without the
/// cancellation of two huge logs (which would cost ~1e-10 at 1e5 degrees of freedom).
fn ln_beta(a: f64, b: f64) -> f64 {
    let (small, big) = if a < b { (a, b) } else { (b, a) };
    if big < STIRLING_FROM {
        return ln_gamma(a) + ln_gamma(b) - ln_gamma(a + b);
    }
    // ln Γ(x) = (x - 1/2) ln x - x + ln(2π)/2 + corr(x), so
    // ln Γ(big) - ln Γ(big + small)
    //   = -(big - 1/2) ln(1 + small/big) - small ln(big + small) + small + corr(big) - corr(big + small).
    let sum = big + small;
    let diff =
        -(big - 0.5) * (small / big).ln_1p() - small * sum.ln() + small + stirling_correction(big)
            - stirling_correction(sum);
    let ln_gamma_small = if small < STIRLING_FROM {
        ln_gamma(small)
    } else {
        (small - 0.5) * small.ln() - small + 0.5 * (2.0 * PI).ln() + stirling_correction(small)
    };
    ln_gamma_small + diff
}

/// Arguments from which `stirling_correction` is accurate to about 1e-17.
const STIRLING_FROM: f64 = 10.0;

/// `ln Γ(x) - ((x - 1/2) ln x - x + ln(2π)/2)` for `x >= 10`, from the first eight terms of
/// Stirling's series `sum_k B_2k / (2k (2k - 1) x^(2k-1))`.
fn stirling_correction(x: f64) -> f64 {
    const C: [f64; 8] = [
        1.0 / 12.0,
        -1.0 / 360.0,
        1.0 / 1260.0,
        -1.0 / 1680.0,
        1.0 / 1188.0,
        -691.0 / 360_360.0,
        1.0 / 156.0,
        -3617.0 / 122_400.0,
    ];
    let inv2 = 1.0 / (x * x);
    let poly = C.iter().rev().fold(0.0, |acc, c| acc * inv2 + c);
    poly / x
}

/// Regularized incomplete beta `I_x(a, b)`, given `x` and `y = 1 - x` separately so that a
/// caller who knows `1 - x` accurately does not lose it to rounding.
fn reg_inc_beta(a: f64, b: f64, x: f64, y: f64) -> f64 {
    if x <= 0.0 {
        return 0.0;
    }
    if y <= 0.0 {
        return 1.0;
    }
    let ln_front = a * x.ln() + b * y.ln() - ln_beta(a, b);
    // The continued fraction converges fast for x < (a + 1) / (a + b + 2); otherwise use the
    // symmetry I_x(a, b) = 1 - I_{1-x}(b, a).
    if x < (a + 1.0) / (a + b + 2.0) {
        ln_front.exp() * beta_continued_fraction(a, b, x) / a
    } else {
        1.0 - ln_front.exp() * beta_continued_fraction(b, a, y) / b
    }
}

/// Continued fraction of the incomplete beta function (modified Lentz, as in Numerical Recipes
/// `betacf`).
fn beta_continued_fraction(a: f64, b: f64, x: f64) -> f64 {
    const TINY: f64 = 1e-300;
    let guard = |v: f64| if v.abs() < TINY { TINY } else { v };
    let (qab, qap, qam) = (a + b, a + 1.0, a - 1.0);
    let mut c = 1.0;
    let mut d = 1.0 / guard(1.0 - qab * x / qap);
    let mut h = d;
    for m in 1..10_000 {
        let m = m as f64;
        let m2 = 2.0 * m;
        let aa = m * (b - m) * x / ((qam + m2) * (a + m2));
        d = 1.0 / guard(1.0 + aa * d);
        c = guard(1.0 + aa / c);
        h *= d * c;
        let aa = -(a + m) * (qab + m) * x / ((a + m2) * (qap + m2));
        d = 1.0 / guard(1.0 + aa * d);
        c = guard(1.0 + aa / c);
        let delta = d * c;
        h *= delta;
        if (delta - 1.0).abs() <= 2.0 * f64::EPSILON {
            break;
        }
    }
    h
}

/// Survival function of Student's t with `df` degrees of freedom, `P(T > t)`. NaN unless
/// `df > 0`.
pub fn student_t_sf(t: f64, df: f64) -> f64 {
    if t.is_nan() || df.is_nan() || df <= 0.0 {
        return f64::NAN;
    }
    if t.is_infinite() {
        return if t > 0.0 { 0.0 } else { 1.0 };
    }
    // P(|T| > |t|) = I_{df/(df+t^2)}(df/2, 1/2); 1 - x is passed as t^2/(df+t^2) directly.
    let t2 = t * t;
    let two_tail = reg_inc_beta(df / 2.0, 0.5, df / (df + t2), t2 / (df + t2));
    if t > 0.0 {
        two_tail / 2.0
    } else {
        1.0 - two_tail / 2.0
    }
}

/// Quantile of Student's t with `df > 0` degrees of freedom: the `t` with `P(T <= t) = p`,
/// found by bisection on the tail probability to about 1e-14 relative. NaN unless
/// `0 < p < 1` and `df > 0`.
pub fn student_t_quantile(p: f64, df: f64) -> f64 {
    if !(p > 0.0 && p < 1.0) || df.is_nan() || df <= 0.0 {
        return f64::NAN;
    }
    if p == 0.5 {
        return 0.0;
    }
    // Solve in the upper tail, where the target tail mass q is small and exact.
    let (q, sign) = if p > 0.5 { (1.0 - p, 1.0) } else { (p, -1.0) };
    let mut lo = 0.0;
    let mut hi = 1.0;
    while student_t_sf(hi, df) > q {
        lo = hi;
        hi *= 2.0;
        if hi > 1e300 {
            return sign * f64::INFINITY;
        }
    }
    for _ in 0..200 {
        let mid = 0.5 * (lo + hi);
        if student_t_sf(mid, df) > q {
            lo = mid;
        } else {
            hi = mid;
        }
        if hi - lo <= 4.0 * f64::EPSILON * hi {
            break;
        }
    }
    sign * 0.5 * (lo + hi)
}

// ---------------------------------------------------------------------------------------------
// Wilcoxon–Mann–Whitney
// ---------------------------------------------------------------------------------------------

/// Alternative hypothesis of a two-sample test of `x` against `y`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Alternative {
    /// The distributions differ (either direction).
    TwoSided,
    /// `x` tends to be larger than `y`.
    Greater,
    /// `x` tends to be smaller than `y`.
    Less,
}

/// How a Mann–Whitney p-value was (or is to be) computed.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Method {
    /// The exact null distribution of U (no ties allowed).
    Exact,
    /// Normal approximation with tie correction and continuity correction.
    NormalApprox,
}

impl Method {
    /// The method's name in `mbmf stats`'s table, `--json` and the Python tables.
    pub fn name(self) -> &'static str {
        match self {
            Method::Exact => "exact",
            Method::NormalApprox => "normal",
        }
    }

    /// The method `mann_whitney` chooses, which is `scipy.stats.mannwhitneyu`'s `'auto'` rule
    /// (scipy 1.17): exact when there are no ties (in the pooled sample) and at least one sample
    /// has at most 8 values; the normal approximation otherwise.
    pub fn auto(n: usize, m: usize, has_ties: bool) -> Method {
        if !has_ties && n.min(m) <= EXACT_MAX_SMALLER_SIZE {
            Method::Exact
        } else {
            Method::NormalApprox
        }
    }
}

/// Largest size of the smaller sample for which `Method::auto` chooses the exact test.
pub const EXACT_MAX_SMALLER_SIZE: usize = 8;

/// Largest size of the smaller sample for which `Method::Exact` can be forced: up to here the
/// exact p-values are within ~1e-14 (relative) of exact integer arithmetic; beyond, rounding
/// error in the recurrence grows quickly (1e-11 at 300, 1e-7 at 500).
pub const EXACT_MAX_SMALLER_SIZE_FORCED: usize = 200;

/// Result of a Wilcoxon–Mann–Whitney test of `x` against `y`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MannWhitney {
    /// U statistic of `x`: the number of pairs with `x_i > y_j`, ties counting one half
    /// (`U_y = n * m - U_x`), as scipy reports it.
    pub u: f64,
    /// p-value for the requested alternative, in [0, 1]; two-sided is twice the one-sided tail,
    /// capped at 1.
    pub p_value: f64,
    /// How the p-value was computed.
    pub method: Method,
    /// Rank-biserial correlation `2 U_x / (n m) - 1`, equal to Cliff's delta
    /// `P(X > Y) - P(X < Y)`: +1 when every `x` exceeds every `y`, -1 in the opposite case.
    pub effect_size: f64,
}

/// Which sample of a two-sample test.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Sample {
    /// The first sample.
    X,
    /// The second sample.
    Y,
}

impl fmt::Display for Sample {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            Sample::X => "x",
            Sample::Y => "y",
        })
    }
}

/// Inputs the Mann–Whitney test cannot handle.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum MannWhitneyError {
    /// A sample has no values.
    Empty(Sample),
    /// A sample contains NaN at the given index.
    NotANumber(Sample, usize),
    /// `Method::Exact` was requested but the pooled data has ties.
    ExactWithTies,
    /// `Method::Exact` was requested but the smaller sample (of the given size) has more than
    /// [`EXACT_MAX_SMALLER_SIZE_FORCED`] values.
    ExactTooLarge(usize),
}

impl fmt::Display for MannWhitneyError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            MannWhitneyError::Empty(s) => write!(
                f,
                "Mann-Whitney test: sample {s} is empty; each sample needs at least one value"
            ),
            MannWhitneyError::NotANumber(s, i) => write!(
                f,
                "Mann-Whitney test: sample {s} has NaN at index {i}; drop or impute it first"
            ),
            MannWhitneyError::ExactWithTies => write!(
                f,
                "Mann-Whitney test: the exact method needs data without ties; \
                 use the normal approximation (or the automatic choice)"
            ),
            MannWhitneyError::ExactTooLarge(size) => write!(
                f,
                "Mann-Whitney test: the exact method is limited to a smaller sample of at most \
                 {EXACT_MAX_SMALLER_SIZE_FORCED} values (here {size}); use the normal \
                 approximation, which is accurate at these sizes"
            ),
        }
    }
}

impl std::error::Error for MannWhitneyError {}

/// Wilcoxon–Mann–Whitney rank-sum test of `x` against `y`, with the method chosen by
/// [`Method::auto`] (scipy's `'auto'`): exact when there are no ties and the smaller sample has
/// at most 8 values, normal approximation (tie- and continuity-corrected) otherwise.
/// Same statistic and p-value as `scipy.stats.mannwhitneyu(x, y, alternative=...)`.
///
/// When every value is identical the p-value is 1 (no evidence either way) and the effect size
/// 0. Errors on an empty sample or a NaN.
pub fn mann_whitney(
    x: &[f64],
    y: &[f64],
    alternative: Alternative,
) -> Result<MannWhitney, MannWhitneyError> {
    mann_whitney_inner(x, y, alternative, None)
}

/// As [`mann_whitney`] but with the method forced. `Method::Exact` costs
/// O(min(n, m) · n · m) time and O(n · m) memory; it fails with
/// [`MannWhitneyError::ExactWithTies`] on tied data (scipy would silently ignore the ties) and
/// with [`MannWhitneyError::ExactTooLarge`] when the smaller sample has more than
/// [`EXACT_MAX_SMALLER_SIZE_FORCED`] values.
pub fn mann_whitney_with_method(
    x: &[f64],
    y: &[f64],
    alternative: Alternative,
    method: Method,
) -> Result<MannWhitney, MannWhitneyError> {
    mann_whitney_inner(x, y, alternative, Some(method))
}

fn mann_whitney_inner(
    x: &[f64],
    y: &[f64],
    alternative: Alternative,
    method: Option<Method>,
) -> Result<MannWhitney, MannWhitneyError> {
    for (sample, values) in [(Sample::X, x), (Sample::Y, y)] {
        if values.is_empty() {
            return Err(MannWhitneyError::Empty(sample));
        }
        if let Some(i) = values.iter().position(|v| v.is_nan()) {
            return Err(MannWhitneyError::NotANumber(sample, i));
        }
    }
    let (n, m) = (x.len(), y.len());
    let ranked = pooled_ranks(x, y);
    let has_ties = ranked.tie_term > 0.0;
    let method = method.unwrap_or_else(|| Method::auto(n, m, has_ties));
    if method == Method::Exact && has_ties {
        return Err(MannWhitneyError::ExactWithTies);
    }
    if method == Method::Exact && n.min(m) > EXACT_MAX_SMALLER_SIZE_FORCED {
        return Err(MannWhitneyError::ExactTooLarge(n.min(m)));
    }

    let (nf, mf) = (n as f64, m as f64);
    let nm = nf * mf;
    let u_x = ranked.rank_sum_x - nf * (nf + 1.0) / 2.0;
    let u_y = nm - u_x;
    // Like scipy, every alternative is an upper-tail probability P(U >= u) of some U, doubled
    // for the two-sided test.
    let (u_tail, factor) = match alternative {
        Alternative::Greater => (u_x, 1.0),
        Alternative::Less => (u_y, 1.0),
        Alternative::TwoSided => (u_x.max(u_y), 2.0),
    };
    let one_tail = match method {
        Method::Exact => exact_upper_tail(n, m, u_tail.round() as usize),
        Method::NormalApprox => normal_upper_tail(nf, mf, u_tail, ranked.tie_term),
    };
    Ok(MannWhitney {
        u: u_x,
        p_value: (factor * one_tail).clamp(0.0, 1.0),
        method,
        effect_size: 2.0 * u_x / nm - 1.0,
    })
}

/// Ranks of the pooled sample, summarised.
struct PooledRanks {
    /// Sum of the (mid-)ranks of `x`'s values, ranks starting at 1.
    rank_sum_x: f64,
    /// `sum (t^3 - t)` over groups of `t` tied values; 0 when there are no ties.
    tie_term: f64,
}

/// Mid-ranks of `x` followed by `y` (no NaN).
fn pooled_ranks(x: &[f64], y: &[f64]) -> PooledRanks {
    let mut pooled: Vec<(f64, bool)> = x
        .iter()
        .map(|&v| (v, true))
        .chain(y.iter().map(|&v| (v, false)))
        .collect();
    pooled.sort_by(|a, b| a.0.total_cmp(&b.0));
    let mut rank_sum_x = 0.0;
    let mut tie_term = 0.0;
    let mut start = 0;
    while start < pooled.len() {
        // `==` rather than `total_cmp` so that -0.0 and 0.0 tie (they are adjacent once sorted).
        let end = start
            + pooled[start..]
                .iter()
                .take_while(|p| p.0 == pooled[start].0)
                .count();
        let t = (end - start) as f64;
        // Positions start..end hold ranks start+1..=end; their mean is the mid-rank.
        let mid_rank = (start + 1 + end) as f64 / 2.0;
        let in_x = pooled[start..end].iter().filter(|p| p.1).count();
        rank_sum_x += mid_rank * in_x as f64;
        tie_term += t * t * t - t;
        start = end;
    }
    PooledRanks {
        rank_sum_x,
        tie_term,
    }
}

/// Normal approximation to `P(U >= u)`, with continuity correction (subtract 1/2) and the tie
/// correction of the variance, exactly as scipy computes it.
fn normal_upper_tail(n: f64, m: f64, u: f64, tie_term: f64) -> f64 {
    let total = n + m;
    let var = n * m / 12.0 * ((total + 1.0) - tie_term / (total * (total - 1.0)));
    if var <= 0.0 {
        // Every value is identical: U sits at its mean and there is no evidence either way.
        return 1.0;
    }
    let z = (u - n * m / 2.0 - 0.5) / var.sqrt();
    normal_sf(z)
}

/// Exact `P(U >= u)` under the null hypothesis for samples of sizes `n` and `m` without ties.
fn exact_upper_tail(n: usize, m: usize, u: usize) -> f64 {
    // U is symmetric about nm/2: P(U >= u) = P(U <= nm - u). Sum whichever tail is the small
    // one so that small p-values are sums of small terms, not differences of large ones.
    let complement = n * m - u.min(n * m);
    if u < complement {
        if u == 0 {
            return 1.0;
        }
        1.0 - exact_u_pmf(n, m, u - 1).iter().sum::<f64>()
    } else {
        exact_u_pmf(n, m, complement).iter().sum()
    }
}

/// `P(U = k)` for `k = 0..=max_u` under the null hypothesis, sizes `n`, `m`, no ties.
///
/// The counts of U are the coefficients of the Gaussian binomial `[n+m choose n]_q`, built up as
/// `[l+i choose i]_q = [l+i-1 choose i-1]_q (1 - q^(l+i)) / (1 - q^i)` for `i = 1..=min(n, m)`
/// (`l = max(n, m)`), truncated at `q^max_u` and at the degree `l i` (Harding's algorithm). The
/// coefficients are kept as probabilities (divided by `C(l+i, i)` at each step) so nothing
/// overflows.
///
/// NOTE: the recurrence subtracts, and its rounding error grows quickly with the number of
/// steps `min(n, m)`: against exact integer arithmetic the worst relative error of the CDF is
/// ~1e-15 up to 150, 1.4e-14 at 200, 1e-13 at 250, 1e-11 at 300 and 1e-7 at 500 (n = m);
/// with 8 steps it is ~1e-13 even for `m` = 20,000. Hence `EXACT_MAX_SMALLER_SIZE_FORCED`.
fn exact_u_pmf(n: usize, m: usize, max_u: usize) -> Vec<f64> {
    let (small, large) = (n.min(m), n.max(m));
    let mut p = vec![0.0; max_u + 1];
    p[0] = 1.0;
    for i in 1..=small {
        // Coefficients above the degree are exactly zero; leaving them untouched (still 0)
        // keeps rounding noise out of them.
        let top = max_u.min(large * i);
        // Multiply by (1 - q^k): descending, so p[u - k] is still the old coefficient.
        let k = large + i;
        for u in (k..=top).rev() {
            p[u] -= p[u - k];
        }
        // Divide by (1 - q^i), i.e. multiply by 1 + q^i + q^2i + ...: ascending.
        for u in i..=top {
            p[u] += p[u - i];
        }
        let scale = i as f64 / (large + i) as f64;
        for v in &mut p[..=top] {
            *v *= scale;
        }
    }
    p
}

// ---------------------------------------------------------------------------------------------
// Multiple comparisons
// ---------------------------------------------------------------------------------------------

/// Conventional significance marks: `***` for p < 0.001, `**` < 0.01, `*` < 0.05, else empty.
pub fn significance_stars(p: f64) -> &'static str {
    if p < 0.001 {
        "***"
    } else if p < 0.01 {
        "**"
    } else if p < 0.05 {
        "*"
    } else {
        ""
    }
}

/// Holm–Bonferroni adjusted p-values, in the input order: with the `k` p-values sorted
/// ascending, the `i`-th (from 0) becomes `max_{j <= i} min(1, (k - j) p_(j))`, so the adjusted
/// values are monotone in the raw ones and capped at 1. Rejecting where the adjusted value is
/// below `alpha` controls the family-wise error rate at `alpha`.
///
/// A NaN p-value stays NaN and still counts in the family size `k` (as R's `p.adjust` does by
/// default), which is conservative for the others.
pub fn holm(p_values: &[f64]) -> Vec<f64> {
    let k = p_values.len();
    let mut order: Vec<usize> = (0..k).filter(|&i| !p_values[i].is_nan()).collect();
    order.sort_by(|&a, &b| p_values[a].total_cmp(&p_values[b]));
    let mut adjusted = vec![f64::NAN; k];
    let mut running_max: f64 = 0.0;
    for (rank, &i) in order.iter().enumerate() {
        let candidate = ((k - rank) as f64 * p_values[i]).min(1.0);
        running_max = running_max.max(candidate);
        adjusted[i] = running_max;
    }
    adjusted
}

#[cfg(test)]
mod tests {
    use super::*;

    fn assert_rel(actual: f64, expected: f64, rel: f64, what: &str) {
        let err = if expected == 0.0 {
            actual.abs()
        } else {
            ((actual - expected) / expected).abs()
        };
        assert!(
            err <= rel,
            "{what}: got {actual:e}, expected {expected:e} (relative error {err:e} > {rel:e})"
        );
    }

    #[test]
    fn descriptive_statistics_match_hand_computed_values() {
        let xs = [2.0, 4.0, 4.0, 4.0, 5.0, 5.0, 7.0, 9.0];
        assert_eq!(mean(&xs), 5.0);
        // Sum of squared deviations is 32, so the sample variance is 32/7.
        assert_rel(sd(&xs), (32.0f64 / 7.0).sqrt(), 1e-15, "sd");
        assert_rel(sem(&xs), (32.0f64 / 7.0).sqrt() / 8f64.sqrt(), 1e-15, "sem");
    }

    #[test]
    fn descriptive_statistics_are_nan_when_undefined() {
        assert!(mean(&[]).is_nan());
        assert!(sd(&[1.0]).is_nan());
        assert!(sem(&[1.0]).is_nan());
        assert!(ci95_half_width(&[1.0]).is_nan());
        assert!(ci_half_width(&[1.0, 2.0], 1.0).is_nan());
    }

    #[test]
    fn ci95_half_width_uses_the_student_t_quantile_with_n_minus_1_df() {
        let xs = [1.0, 2.0, 3.0, 4.0, 5.0];
        // sd = sqrt(2.5), sem = sqrt(0.5), t_{0.975,4} = 2.7764451051977934 (scipy).
        assert_rel(
            ci95_half_width(&xs),
            2.776_445_105_197_793_4 * 0.5f64.sqrt(),
            1e-12,
            "ci95",
        );
    }

    #[test]
    fn student_t_quantiles_match_tables_to_four_decimals() {
        for (df, t) in [(1.0, 12.7062), (4.0, 2.7764), (49.0, 2.0096)] {
            let got = student_t_quantile(0.975, df);
            assert!((got - t).abs() < 5e-5, "t_0.975,{df} = {got}, table {t}");
        }
    }

    #[test]
    fn special_functions_match_scipy() {
        // Reference values: see the note above `MW_SCIPY` at the end of this module.
        for &(x, expected) in ERFC_SCIPY {
            assert_rel(erfc(x), expected, 1e-13, &format!("erfc({x})"));
        }
        for &(z, expected) in NORM_SF_SCIPY {
            assert_rel(normal_sf(z), expected, 1e-13, &format!("normal_sf({z})"));
            assert_rel(
                normal_cdf(-z),
                expected,
                1e-13,
                &format!("normal_cdf({})", -z),
            );
        }
        for &(p, df, expected) in T_PPF_SCIPY {
            assert_rel(
                student_t_quantile(p, df),
                expected,
                1e-10,
                &format!("t.ppf({p}, {df})"),
            );
        }
        for &(t, df, expected) in T_SF_SCIPY {
            assert_rel(
                student_t_sf(t, df),
                expected,
                1e-11,
                &format!("t.sf({t}, {df})"),
            );
        }
        for &(a, b, expected) in BETALN_MPMATH {
            assert_rel(ln_beta(a, b), expected, 1e-13, &format!("betaln({a}, {b})"));
        }
        for &(x, expected) in LGAMMA_PYTHON {
            assert_rel(ln_gamma(x), expected, 1e-13, &format!("lgamma({x})"));
        }
    }

    #[test]
    fn erfc_handles_infinities_and_nan() {
        assert_eq!(erfc(f64::INFINITY), 0.0);
        assert_eq!(erfc(f64::NEG_INFINITY), 2.0);
        assert!(erfc(f64::NAN).is_nan());
        assert_eq!(normal_sf(f64::INFINITY), 0.0);
        assert_eq!(normal_cdf(f64::INFINITY), 1.0);
    }

    #[test]
    fn student_t_quantile_rejects_probabilities_outside_zero_one() {
        assert!(student_t_quantile(0.0, 3.0).is_nan());
        assert!(student_t_quantile(1.0, 3.0).is_nan());
        assert!(student_t_quantile(0.5, 0.0).is_nan());
        assert_eq!(student_t_quantile(0.5, 3.0), 0.0);
        assert_rel(
            student_t_quantile(0.025, 4.0),
            -student_t_quantile(0.975, 4.0),
            1e-14,
            "symmetry",
        );
    }

    /// Deterministic sample shared with the scipy script below: a 64-bit LCG, top 31 bits, either
    /// as a fraction in [0, 1) (continuous, practically tie-free) or modulo `levels` (ties).
    fn lcg_sample(seed: u64, n: usize, levels: u64, shift: f64) -> Vec<f64> {
        let mut s = seed;
        (0..n)
            .map(|_| {
                s = s
                    .wrapping_mul(6_364_136_223_846_793_005)
                    .wrapping_add(1_442_695_040_888_963_407);
                let r = s >> 33;
                let v = if levels == 0 {
                    r as f64 / 2_147_483_648.0
                } else {
                    (r % levels) as f64
                };
                v + shift
            })
            .collect()
    }

    /// One scipy reference case: data recipe, then per alternative (two-sided, greater, less)
    /// the p-values of `method='auto'`, `'asymptotic'` and `'exact'` (NaN: not computed, the
    /// data has ties).
    struct MwCase {
        seed_x: u64,
        n: usize,
        seed_y: u64,
        m: usize,
        levels: u64,
        shift_x: f64,
        u: f64,
        auto_is_exact: bool,
        p: [[f64; 3]; 3],
    }

    /// Relative tolerance against scipy. Both implementations agree to ~1e-13 on these cases
    /// (exact and normal alike), so this is tight enough to catch any change of formula.
    const MW_TOL: f64 = 1e-12;

    #[test]
    fn mann_whitney_matches_scipy_for_every_method_and_alternative() {
        let alternatives = [
            Alternative::TwoSided,
            Alternative::Greater,
            Alternative::Less,
        ];
        for (ci, case) in MW_SCIPY.iter().enumerate() {
            let x = lcg_sample(case.seed_x, case.n, case.levels, case.shift_x);
            let y = lcg_sample(case.seed_y, case.m, case.levels, 0.0);
            for (ai, &alt) in alternatives.iter().enumerate() {
                let what = format!("case {ci} (n={}, m={}) {alt:?}", case.n, case.m);
                let [p_auto, p_normal, p_exact] = case.p[ai];

                let auto = mann_whitney(&x, &y, alt).unwrap();
                assert_eq!(auto.u, case.u, "{what}: U");
                let expected_method = if case.auto_is_exact {
                    Method::Exact
                } else {
                    Method::NormalApprox
                };
                assert_eq!(auto.method, expected_method, "{what}: method");
                assert_rel(auto.p_value, p_auto, MW_TOL, &format!("{what} auto"));

                let normal = mann_whitney_with_method(&x, &y, alt, Method::NormalApprox).unwrap();
                assert_rel(normal.p_value, p_normal, MW_TOL, &format!("{what} normal"));

                let exact = mann_whitney_with_method(&x, &y, alt, Method::Exact);
                if p_exact.is_nan() {
                    assert_eq!(exact, Err(MannWhitneyError::ExactWithTies), "{what}");
                } else {
                    let exact = exact.unwrap();
                    assert_rel(exact.p_value, p_exact, MW_TOL, &format!("{what} exact"));
                }
            }
        }
    }

    #[test]
    fn exact_null_distribution_matches_brute_force_enumeration() {
        // Under H0 every choice of which n of the n+m ranks belong to x is equally likely.
        for (n, m) in [(1, 1), (1, 4), (2, 3), (3, 3), (4, 6), (5, 5), (3, 7)] {
            let total = n + m;
            let mut counts = vec![0u64; n * m + 1];
            for mask in 0u32..(1 << total) {
                if mask.count_ones() as usize != n {
                    continue;
                }
                // U_x = sum over x ranks (1-based) minus n(n+1)/2.
                let rank_sum: usize = (0..total)
                    .filter(|b| mask & (1 << b) != 0)
                    .map(|b| b + 1)
                    .sum();
                counts[rank_sum - n * (n + 1) / 2] += 1;
            }
            let all: u64 = counts.iter().sum();
            let pmf = exact_u_pmf(n, m, n * m);
            for (u, &c) in counts.iter().enumerate() {
                assert_rel(
                    pmf[u],
                    c as f64 / all as f64,
                    1e-13,
                    &format!("P(U={u}) for n={n}, m={m}"),
                );
            }
        }
    }

    #[test]
    fn forced_exact_p_values_match_exact_integer_arithmetic_at_the_size_limit() {
        // n = m = 200, U_x = 20396. Reference: two-sided p = 2 * sum_{u <= 19604} c(u) / C(400,
        // 200), with the counts c(u) from the same recurrence in Python integers (exact) and
        // the ratio taken as a `fractions.Fraction`: 0.7325651571437333.
        // (scipy 1.17.1 `method='exact'` gives 0.7325651571436114, 1.7e-13 away.)
        let x: Vec<f64> = (0..200).map(|i| i as f64 * 1.01 + 0.00123).collect();
        let y: Vec<f64> = (0..200).map(|i| i as f64 * 0.99).collect();
        let r = mann_whitney_with_method(&x, &y, Alternative::TwoSided, Method::Exact).unwrap();
        assert_eq!(r.u, 20396.0);
        assert_rel(r.p_value, 0.732_565_157_143_733_3, 1e-13, "p");
    }

    #[test]
    fn forced_exact_is_refused_beyond_the_size_limit() {
        let x: Vec<f64> = (0..201).map(|i| i as f64 + 0.5).collect();
        let y: Vec<f64> = (0..300).map(|i| i as f64).collect();
        let e = mann_whitney_with_method(&x, &y, Alternative::Less, Method::Exact).unwrap_err();
        assert_eq!(e, MannWhitneyError::ExactTooLarge(201));
        assert!(
            e.to_string().contains("at most 200 values (here 201)"),
            "{e}"
        );
        // The automatic choice is unaffected.
        assert!(mann_whitney(&x, &y, Alternative::Less).is_ok());
    }

    #[test]
    fn mann_whitney_u_and_effect_size_count_pairs_with_ties_as_halves() {
        let x = [1.0, 2.0, 3.0];
        let y = [2.0, 0.0];
        // Pairs x>y: (1>0), (2>0), (3>2), (3>0) = 4; ties: (2=2) = 1/2. U = 4.5 of 6.
        let r = mann_whitney(&x, &y, Alternative::TwoSided).unwrap();
        assert_eq!(r.u, 4.5);
        // Cliff's delta: (4 - 1) / 6 (one pair with x < y: 1 < 2).
        assert_rel(r.effect_size, 0.5, 1e-15, "effect size");
    }

    #[test]
    fn mann_whitney_reports_complete_separation_as_effect_size_one() {
        let r = mann_whitney(&[4.0, 5.0, 6.0], &[1.0, 2.0, 3.0], Alternative::Greater).unwrap();
        assert_eq!(r.u, 9.0);
        assert_eq!(r.effect_size, 1.0);
        assert_eq!(r.method, Method::Exact);
        // Only one of the C(6,3) = 20 rank assignments is this extreme.
        assert_rel(r.p_value, 0.05, 1e-14, "p");
    }

    #[test]
    fn mann_whitney_gives_p_one_when_all_values_are_identical() {
        let x = [3.0; 12];
        let y = [3.0; 10];
        for alt in [
            Alternative::TwoSided,
            Alternative::Greater,
            Alternative::Less,
        ] {
            let r = mann_whitney(&x, &y, alt).unwrap();
            assert_eq!(r.p_value, 1.0, "{alt:?}");
            assert_eq!(r.effect_size, 0.0);
            assert_eq!(r.method, Method::NormalApprox);
        }
        // A single value each, tied: still p = 1, no division by zero.
        let r = mann_whitney(&[1.0], &[1.0], Alternative::TwoSided).unwrap();
        assert_eq!(r.p_value, 1.0);
    }

    #[test]
    fn mann_whitney_treats_negative_and_positive_zero_as_tied() {
        let r = mann_whitney(&[-0.0, 1.0], &[0.0, 2.0], Alternative::TwoSided).unwrap();
        assert_eq!(r.u, 1.5);
        assert_eq!(r.method, Method::NormalApprox);
    }

    #[test]
    fn mann_whitney_rejects_empty_samples_and_nan_naming_the_sample() {
        let e = mann_whitney(&[], &[1.0], Alternative::TwoSided).unwrap_err();
        assert_eq!(e, MannWhitneyError::Empty(Sample::X));
        assert!(e.to_string().contains("sample x is empty"), "{e}");
        let e = mann_whitney(&[1.0], &[], Alternative::TwoSided).unwrap_err();
        assert_eq!(e, MannWhitneyError::Empty(Sample::Y));
        let e = mann_whitney(&[1.0], &[2.0, f64::NAN], Alternative::Less).unwrap_err();
        assert_eq!(e, MannWhitneyError::NotANumber(Sample::Y, 1));
        assert!(e.to_string().contains("index 1"), "{e}");
    }

    #[test]
    fn exact_p_values_stay_accurate_far_in_the_tail() {
        // x entirely above y with n = 8, m = 60: P = 1 / C(68, 8) for the one-sided test.
        let x: Vec<f64> = (0..8).map(|i| 100.0 + i as f64).collect();
        let y: Vec<f64> = (0..60).map(|i| i as f64).collect();
        let r = mann_whitney(&x, &y, Alternative::Greater).unwrap();
        assert_eq!(r.method, Method::Exact);
        let c_68_8 = 7_392_009_768.0_f64; // C(68, 8)
        assert_rel(r.p_value, 1.0 / c_68_8, 1e-12, "p");
        let r = mann_whitney(&x, &y, Alternative::Less).unwrap();
        assert_eq!(r.p_value, 1.0);
    }

    #[test]
    fn holm_matches_statsmodels_and_keeps_the_input_order() {
        // Reference values from statsmodels 0.15.0 (see the note above `MW_SCIPY`).
        for (p, expected) in HOLM_STATSMODELS {
            let got = holm(p);
            assert_eq!(got.len(), p.len());
            for (i, (&g, &e)) in got.iter().zip(expected.iter()).enumerate() {
                assert_rel(g, e, 1e-14, &format!("holm({p:?})[{i}]"));
            }
        }
    }

    #[test]
    fn holm_is_monotone_capped_at_one_and_handles_empty_and_nan() {
        assert!(holm(&[]).is_empty());
        let adj = holm(&[0.01, 0.04, 0.03, 0.5, 0.02]);
        // Sorted raw: 0.01*5, 0.02*4, 0.03*3, 0.04*2, 0.5*1 -> 0.05, 0.08, 0.09, 0.09 (max), 0.5.
        let expected = [0.05, 0.09, 0.09, 0.5, 0.08];
        for (a, e) in adj.iter().zip(expected) {
            assert_rel(*a, e, 1e-14, "holm");
        }
        let adj = holm(&[0.9, 0.8]);
        assert_eq!(adj, vec![1.0, 1.0]);
        // NaN stays NaN and counts in the family: 0.01 * 2.
        let adj = holm(&[f64::NAN, 0.01]);
        assert!(adj[0].is_nan());
        assert_rel(adj[1], 0.02, 1e-15, "holm with NaN");
    }

    // --- Reference values -------------------------------------------------------------------
    // Computed with Python 3.11.7, scipy 1.17.1, numpy 2.4.6, statsmodels 0.15.0, mpmath 1.4.1
    // and printed with repr(float(...)):
    // - MW_SCIPY: `scipy.stats.mannwhitneyu(x, y, alternative=alt, method=meth).pvalue` (default
    //   `use_continuity=True`) for alt in ('two-sided', 'greater', 'less') and meth in ('auto',
    //   'asymptotic', 'exact'), and `.statistic` as `u`; 'exact' skipped on tied data. The data
    //   is the same LCG as `lcg_sample` above, in Python:
    //     s = seed; for each value: s = (s * 6364136223846793005 + 1442695040888963407) % 2**64;
    //     r = s >> 33; v = r / 2**31 if levels == 0 else float(r % levels); append v + shift
    //   with x = lcg(seed_x, n, levels, shift_x), y = lcg(seed_y, m, levels, 0.0).
    // - ERFC_SCIPY: `scipy.special.erfc(x)`; NORM_SF_SCIPY: `scipy.stats.norm.sf(z)`;
    //   T_PPF_SCIPY: `scipy.stats.t.ppf(p, df)`; T_SF_SCIPY: `scipy.stats.t.sf(t, df)`;
    //   LGAMMA_PYTHON: `math.lgamma(x)`; BETALN_MPMATH: `mpmath.log(mpmath.beta(a, b))` at 40
    //   digits (`scipy.special.betaln(50000, 0.5)` is itself off by 7e-12 relative).
    // - HOLM_STATSMODELS: `statsmodels.stats.multitest.multipletests(p, method='holm')[1]`.
    const MW_SCIPY: &[MwCase] = &[
        MwCase {
            seed_x: 1,
            n: 3,
            seed_y: 2,
            m: 4,
            levels: 0,
            shift_x: 0.3,
            u: 9.0,
            auto_is_exact: true,
            p: [
                [0.4, 0.376759117811582, 0.4],
                [0.2, 0.188379558905791, 0.2],
                [0.8857142857142858, 0.8920375305299298, 0.8857142857142858],
            ],
        },
        MwCase {
            seed_x: 3,
            n: 5,
            seed_y: 4,
            m: 8,
            levels: 0,
            shift_x: 0.2,
            u: 26.0,
            auto_is_exact: true,
            p: [
                [0.43512043512043513, 0.4207518433669324, 0.43512043512043513],
                [0.21756021756021757, 0.2103759216834662, 0.21756021756021757],
                [0.8228438228438228, 0.8293253430226205, 0.8228438228438228],
            ],
        },
        MwCase {
            seed_x: 5,
            n: 8,
            seed_y: 6,
            m: 8,
            levels: 0,
            shift_x: 0.4,
            u: 47.0,
            auto_is_exact: true,
            p: [
                [
                    0.13038073038073036,
                    0.12780760094754465,
                    0.13038073038073036,
                ],
                [
                    0.06519036519036518,
                    0.06390380047377232,
                    0.06519036519036518,
                ],
                [0.9475524475524476, 0.948219064411733, 0.9475524475524476],
            ],
        },
        MwCase {
            seed_x: 7,
            n: 8,
            seed_y: 8,
            m: 60,
            levels: 0,
            shift_x: 0.5,
            u: 398.0,
            auto_is_exact: true,
            p: [
                [
                    0.001648262161766126,
                    0.0027179221654797464,
                    0.001648262161766126,
                ],
                [
                    0.000824131080883063,
                    0.0013589610827398732,
                    0.000824131080883063,
                ],
                [0.9992397809017614, 0.99872353383788, 0.9992397809017614],
            ],
        },
        MwCase {
            seed_x: 9,
            n: 9,
            seed_y: 10,
            m: 9,
            levels: 0,
            shift_x: 0.3,
            u: 63.0,
            auto_is_exact: false,
            p: [
                [
                    0.052058768750600205,
                    0.052058768750600205,
                    0.05030851501439737,
                ],
                [
                    0.026029384375300103,
                    0.026029384375300103,
                    0.025154257507198685,
                ],
                [0.9788699469580217, 0.9788699469580217, 0.9800082270670506],
            ],
        },
        MwCase {
            seed_x: 11,
            n: 20,
            seed_y: 12,
            m: 25,
            levels: 0,
            shift_x: 0.2,
            u: 301.0,
            auto_is_exact: false,
            p: [
                [0.24870468992498762, 0.24870468992498762, 0.2514651117144464],
                [0.12435234496249381, 0.12435234496249381, 0.1257325558572232],
                [0.8802710595695349, 0.8802710595695349, 0.8789432390152798],
            ],
        },
        MwCase {
            seed_x: 13,
            n: 50,
            seed_y: 14,
            m: 50,
            levels: 0,
            shift_x: 0.4,
            u: 2111.0,
            auto_is_exact: false,
            p: [
                [
                    2.990260550246842e-09,
                    2.990260550246842e-09,
                    2.9992895132279704e-10,
                ],
                [
                    1.495130275123421e-09,
                    1.495130275123421e-09,
                    1.4996447566139852e-10,
                ],
                [0.9999999985663964, 0.9999999985663964, 0.9999999998580577],
            ],
        },
        MwCase {
            seed_x: 15,
            n: 60,
            seed_y: 16,
            m: 55,
            levels: 10,
            shift_x: 1.0,
            u: 1717.0,
            auto_is_exact: false,
            p: [
                [0.7082543651125973, 0.7082543651125973, f64::NAN],
                [0.35412718255629866, 0.35412718255629866, f64::NAN],
                [0.6479636927184353, 0.6479636927184353, f64::NAN],
            ],
        },
        MwCase {
            seed_x: 17,
            n: 6,
            seed_y: 18,
            m: 7,
            levels: 4,
            shift_x: 0.0,
            u: 19.0,
            auto_is_exact: false,
            p: [
                [0.8242776333294188, 0.8242776333294188, f64::NAN],
                [0.6443376680713846, 0.6443376680713846, f64::NAN],
                [0.4121388166647094, 0.4121388166647094, f64::NAN],
            ],
        },
        MwCase {
            seed_x: 19,
            n: 3,
            seed_y: 20,
            m: 60,
            levels: 0,
            shift_x: -0.3,
            u: 41.0,
            auto_is_exact: true,
            p: [
                [
                    0.12303895646042658,
                    0.11750537210881205,
                    0.12303895646042658,
                ],
                [0.9425348140313767, 0.9449346136923213, 0.9425348140313767],
                [
                    0.06151947823021329,
                    0.05875268605440603,
                    0.06151947823021329,
                ],
            ],
        },
        MwCase {
            seed_x: 21,
            n: 40,
            seed_y: 22,
            m: 35,
            levels: 3,
            shift_x: 0.0,
            u: 647.0,
            auto_is_exact: false,
            p: [
                [0.5459817695377447, 0.5459817695377447, f64::NAN],
                [0.730819399881833, 0.730819399881833, f64::NAN],
                [0.27299088476887234, 0.27299088476887234, f64::NAN],
            ],
        },
        MwCase {
            seed_x: 23,
            n: 12,
            seed_y: 24,
            m: 5,
            levels: 0,
            shift_x: 0.0,
            u: 22.0,
            auto_is_exact: true,
            p: [
                [0.4421460892049127, 0.42919530044034926, 0.4421460892049127],
                [0.8086619263089851, 0.8148679224102469, 0.8086619263089851],
                [
                    0.22107304460245636,
                    0.21459765022017463,
                    0.22107304460245636,
                ],
            ],
        },
        MwCase {
            seed_x: 25,
            n: 60,
            seed_y: 26,
            m: 60,
            levels: 0,
            shift_x: 0.0,
            u: 1810.0,
            auto_is_exact: false,
            p: [
                [0.9602323044738406, 0.9602323044738406, 0.9603818387204276],
                [0.4801161522369203, 0.4801161522369203, 0.4801909193602138],
                [0.521974867125948, 0.521974867125948, 0.5218922674269096],
            ],
        },
    ];
    const ERFC_SCIPY: &[(f64, f64)] = &[
        (0.0, 1.0),
        (1e-10, 0.999999999887162),
        (0.1, 0.8875370839817152),
        (0.5, 0.4795001221869535),
        (1.0, 0.15729920705028516),
        (1.5, 0.03389485352468927),
        (1.99, 0.004888586800383002),
        (2.0, 0.004677734981047266),
        (2.01, 0.004475150644751764),
        (2.5, 0.00040695201744495886),
        (3.0, 2.2090496998585445e-05),
        (4.0, 1.541725790028002e-08),
        (5.0, 1.5374597944280347e-12),
        (7.5, 2.7766493860305694e-26),
        (10.0, 2.0884875837625446e-45),
        (15.0, 7.212994172451209e-100),
        (20.0, 5.395865611607901e-176),
        (26.0, 5.663192408856145e-296),
        (-0.5, 1.5204998778130465),
        (-1.0, 1.8427007929497148),
        (-3.0, 1.9999779095030015),
    ];
    const NORM_SF_SCIPY: &[(f64, f64)] = &[
        (0.0, 0.5),
        (0.5, 0.3085375387259869),
        (1.0, 0.15865525393145707),
        (1.959963984540054, 0.025),
        (3.0, 0.0013498980316300933),
        (5.0, 2.866515718791933e-07),
        (8.0, 6.22096057427174e-16),
        (12.0, 1.776482112077653e-33),
        (20.0, 2.7536241186061556e-89),
        (37.0, 5.7255712225239266e-300),
        (-2.0, 0.9772498680518208),
    ];
    const T_PPF_SCIPY: &[(f64, f64, f64)] = &[
        (0.975, 1.0, 12.706204736174694),
        (0.975, 2.0, 4.302652729749462),
        (0.975, 4.0, 2.7764451051977934),
        (0.975, 9.0, 2.262157162798205),
        (0.975, 49.0, 2.0095752371292392),
        (0.975, 1000.0, 1.9623390808264083),
        (0.995, 3.0, 5.840909309733355),
        (0.9, 0.5, 10.27032441023451),
        (0.6, 7.0, 0.2631668613520229),
        (0.999999, 2.0, 707.1057205157672),
        (0.025, 12.0, -2.1788128296672293),
        (0.95, 100000.0, 1.6448688647849696),
    ];
    const T_SF_SCIPY: &[(f64, f64, f64)] = &[
        (0.0, 3.0, 0.5),
        (0.1, 5.0, 0.4621150705773302),
        (1.0, 1.0, 0.25000000000000006),
        (2.5, 10.0, 0.01572342211830441),
        (10.0, 4.0, 0.0002810018113579955),
        (50.0, 30.0, 9.357708829611355e-31),
        (-1.5, 2.0, 0.8638034375544994),
        (3.0, 100000.0, 0.0013502304420323617),
    ];
    const LGAMMA_PYTHON: &[(f64, f64)] = &[
        (0.1, 2.2527126517342055),
        (0.5, 0.5723649429247004),
        (1.5, -0.12078223763524543),
        (2.5, 0.2846828704729196),
        (4.0, 1.7917594692280554),
        (10.0, 12.801827480081467),
        (24.5, 53.19049452616927),
        (100.0, 359.1342053695754),
        (5000.5, 37586.88488728106),
    ];
    const HOLM_STATSMODELS: &[(&[f64], &[f64])] = &[
        (&[0.01, 0.04, 0.03, 0.005], &[0.03, 0.06, 0.06, 0.02]),
        (
            &[0.2, 0.2, 0.01, 0.9, 0.04],
            &[0.6000000000000001, 0.6000000000000001, 0.05, 0.9, 0.16],
        ),
        (&[0.001], &[0.001]),
        (&[0.5, 0.6, 0.7], &[1.0, 1.0, 1.0]),
        (
            &[0.012, 0.011, 0.013, 0.3, 0.0001, 0.049],
            &[
                0.05499999999999999,
                0.05499999999999999,
                0.05499999999999999,
                0.3,
                0.0006000000000000001,
                0.098,
            ],
        ),
    ];
    const BETALN_MPMATH: &[(f64, f64, f64)] = &[
        (0.5, 0.5, 1.1447298858494002),
        (2.5, 0.5, 0.16390063283767395),
        (12.0, 0.5, -0.6596747231378598),
        (50000.0, 0.5, -4.837521699280441),
        (3.0, 40.0, -10.446973958541667),
        (15.5, 22.25, -25.73981817878256),
        (10000000.0, 2.0, -32.236191401916635),
    ];
}
