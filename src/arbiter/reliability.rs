//! `reliability` (SPEC 12.3, Lee, Shimojo & O'Doherty 2014): one P_MB per run, moved after
//! every executed transition by the reliabilities of the two experts' predictions: MB's state
//! prediction errors (a Dirichlet over the classes of the last few) and MF's mean |RPE|.

use super::{Arbiter, Choice, Inputs, Model, Own, Transition};
use crate::expert::mf;
use crate::meta::pick;
use crate::params::Params;

/// Classes of a state prediction error: zero, positive, negative (K = 3).
const K: usize = 3;
/// The time step of the transition-rate dynamics (SPEC 12.3).
const DT: f64 = 0.1;

// The run's scalars: P_MB, Omega, the class counts, the ring's length and next slot, the
// memory of the last rates ([`Rates`]), then the ring of the last `rel_memory` classes.
const P_MB: usize = 0;
const OMEGA: usize = 1;
const COUNTS: usize = 2;
const LEN: usize = COUNTS + K;
const POS: usize = LEN + 1;
const RATES: usize = POS + 1;
const RING: usize = RATES + Rates::LEN;

/// Reliability-based arbitration.
pub struct Reliability;

/// chi_MB of SPEC 12.3 from the class counts `n` (zero, positive, negative) of the remembered
/// transitions: the zero class's mean/variance ratio over the sum of all classes'.
pub fn chi_mb(n: [f64; K]) -> f64 {
    let total: f64 = n.iter().sum();
    let kn = K as f64 + total;
    let ratio = |n_k: f64| {
        let mean = (1.0 + n_k) / kn;
        let var = (1.0 + n_k) * (kn - 1.0 - n_k) / (kn * kn * (kn + 1.0));
        mean / var
    };
    ratio(n[0]) / (ratio(n[0]) + ratio(n[1]) + ratio(n[2]))
}

/// chi_MF = clamp((R_max - Omega) / R_max, 0, 1). A task without reward (R_max = 0) has
/// nothing for MF to mispredict: 1.
pub fn chi_mf(omega: f64, r_max: f64) -> f64 {
    if r_max > 0.0 {
        ((r_max - omega) / r_max).clamp(0.0, 1.0)
    } else {
        1.0
    }
}

/// [`Rates::next_p_mb`] computed afresh: the reference a run's remembered rates are checked
/// against.
#[cfg(test)]
pub fn next_p_mb(params: &Params, p_mb: f64, chi_mf: f64, chi_mb: f64) -> f64 {
    let mut rates = Rates::FORGOTTEN;
    Rates(&mut rates).next_p_mb(params, p_mb, chi_mf, chi_mb)
}

/// The three exponentials of SPEC 12.3's P_MB update for the last arguments they were
/// computed for, as (argument, value) pairs in a run's scalars: once learning has settled, the
/// reliabilities stop moving (every SPE zero, Omega shrunk past R_max's rounding) and the rates
/// are the same at every transition, bit for bit, so a transition costs no `exp`.
struct Rates<'a>(&'a mut [f64]);

impl Rates<'_> {
    /// Scalars: chi_MF, alpha, chi_MB, beta, alpha + beta, exp(-dt (alpha + beta)).
    const LEN: usize = 6;
    /// No argument seen: -1 is no reliability (both lie in [0, 1] or are NaN) and no rate sum
    /// (rates are positive or NaN).
    const FORGOTTEN: [f64; Rates::LEN] = [-1.0, 0.0, -1.0, 0.0, -1.0, 0.0];

    /// `f(x)`, from the pair at `at` when `x` is its argument (compared bit for bit).
    #[inline(always)]
    fn recall(&mut self, at: usize, x: f64, f: impl FnOnce(f64) -> f64) -> f64 {
        if self.0[at].to_bits() != x.to_bits() {
            self.0[at] = x;
            self.0[at + 1] = f(x);
        }
        self.0[at + 1]
    }

    /// P_MB after one transition with reliabilities `chi_mf` and `chi_mb`: the transition rates
    /// alpha (MF to MB) and beta (MB to MF), and P_MB relaxing towards alpha / (alpha + beta)
    /// over dt; with both rates 0 (zero amplitudes) it stays. Only the exponentials whose
    /// arguments changed are computed.
    #[inline(always)]
    fn next_p_mb(&mut self, params: &Params, p_mb: f64, chi_mf: f64, chi_mb: f64) -> f64 {
        let alpha = self.recall(0, chi_mf, |chi| {
            params.rel_a_mf_mb / (1.0 + (params.rel_b_mf_mb * chi).exp())
        });
        let beta = self.recall(2, chi_mb, |chi| {
            params.rel_a_mb_mf / (1.0 + (params.rel_b_mb_mf * chi).exp())
        });
        let rate = alpha + beta;
        if rate > 0.0 {
            let p_inf = alpha / rate;
            p_inf + (p_mb - p_inf) * self.recall(4, rate, |rate| (-DT * rate).exp())
        } else {
            p_mb
        }
    }
}

/// The SPE class of SPEC 12.3: 0 zero, 1 positive, 2 negative.
pub fn spe_class(spe: f64, threshold: f64) -> usize {
    if spe.abs() < threshold {
        0
    } else if spe >= threshold {
        1
    } else {
        2
    }
}

impl Arbiter for Reliability {
    const OBSERVES: bool = true;
    const COMBINES: bool = true;
    const PARAMS: &'static [&'static str] = &[
        "spe_threshold",
        "rel_memory",
        "rel_eta",
        "rel_a_mf_mb",
        "rel_b_mf_mb",
        "rel_a_mb_mf",
        "rel_b_mb_mf",
        "rel_p0",
    ];

    fn run_scalars(params: &Params) -> usize {
        RING + params.rel_memory as usize
    }

    fn start(params: &Params, own: &mut Own<'_>) {
        own.run[P_MB] = params.rel_p0;
        own.run[RATES..RING].copy_from_slice(&Rates::FORGOTTEN);
    }

    #[inline(always)]
    fn weight(inputs: &mut Inputs<'_>) -> f64 {
        inputs.own.run[P_MB]
    }

    #[inline(always)]
    fn choose(inputs: &mut Inputs<'_>) -> Choice {
        let p_mb = inputs.own.run[P_MB];
        // Argmax: MB iff P_MB > 1/2, a fair draw at exactly 1/2 (SPEC 12.1).
        let use_mb = pick(
            inputs.params.selection,
            p_mb,
            p_mb.partial_cmp(&0.5),
            || inputs.uniform(),
        );
        inputs.choice(use_mb, p_mb, None)
    }

    #[inline(always)]
    fn observe(
        params: &Params,
        own: &mut Own<'_>,
        t: &Transition,
        q_mf: &[f64],
        model: &Model<'_>,
    ) {
        let run = &mut *own.run;
        let n_a = t.n_actions;
        let sa = t.s * n_a + t.a;
        // SPE: MB's probability of the observed outcome, before learning it (0 if untried).
        let spe = 1.0 - model.probability(sa, model.obs.find(sa, t.next));
        let rpe = t.r + params.gamma_mf * mf::future(q_mf, n_a, t.next, t.terminal) - q_mf[sa];

        // The class memory: the oldest class leaves once `rel_memory` are kept.
        let memory = params.rel_memory as usize;
        let class = spe_class(spe, params.spe_threshold);
        let (len, pos) = (run[LEN] as usize, run[POS] as usize);
        if len == memory {
            run[COUNTS + run[RING + pos] as usize] -= 1.0;
        } else {
            run[LEN] += 1.0;
        }
        run[RING + pos] = class as f64;
        run[COUNTS + class] += 1.0;
        run[POS] = ((pos + 1) % memory) as f64;
        let chi_b = chi_mb([run[COUNTS], run[COUNTS + 1], run[COUNTS + 2]]);

        run[OMEGA] += params.rel_eta * (rpe.abs() - run[OMEGA]);
        let chi_f = chi_mf(run[OMEGA], t.r_max);
        let p_mb = run[P_MB];
        run[P_MB] = Rates(&mut run[RATES..RING]).next_p_mb(params, p_mb, chi_f, chi_b);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn chi_mb_by_hand() {
        // No transition yet: n = 0, K + n = 3, every class has mean 1/3 and the same variance:
        // chi = 1/3.
        assert!((chi_mb([0.0; 3]) - 1.0 / 3.0).abs() < 1e-15);
        // Ten zero-class SPEs: K + n = 13. mean/var = (K+n)(K+n+1)/(K+n-1-n_k):
        // zero 13*14/2 = 91, others 13*14/12 = 15.1666..: chi = 91 / (91 + 2 * 182/12).
        let chi = chi_mb([10.0, 0.0, 0.0]);
        assert!(
            (chi - 91.0 / (91.0 + 2.0 * 182.0 / 12.0)).abs() < 1e-14,
            "{chi}"
        );
        assert!((chi - 0.75).abs() < 1e-14);
        // Five and five: K + n = 13; zero and positive 182/7 = 26, negative 182/12:
        // chi = 26 / (52 + 15.1666..) = 0.38709677...
        let chi = chi_mb([5.0, 5.0, 0.0]);
        assert!((chi - 26.0 / (52.0 + 182.0 / 12.0)).abs() < 1e-14, "{chi}");
    }

    #[test]
    fn chi_mf_is_clamped_and_defined_without_reward() {
        assert_eq!(chi_mf(0.0, 1.0), 1.0);
        assert!((chi_mf(0.25, 1.0) - 0.75).abs() < 1e-15);
        assert_eq!(chi_mf(3.0, 1.0), 0.0);
        assert_eq!(chi_mf(0.3, 0.0), 1.0);
    }

    #[test]
    fn p_mb_after_given_rates_by_hand() {
        let params = Params::default();
        // Defaults: alpha = 1.2 / (1 + e^(10 * 1)) = 5.44774e-5 at chi_MF = 1; beta = 1 / (1 + e^(2
        // * 0.75)) = 0.182426 at chi_MB = 0.75. P_inf = alpha / (alpha + beta) = 2.98539e-4;
        // P = P_inf + (0.7 - P_inf) e^(-0.1 (alpha + beta)) = 0.6873476 (python's math.exp)
        let alpha = 1.2 / (1.0 + 10f64.exp());
        let beta = 1.0 / (1.0 + 1.5f64.exp());
        assert!((alpha - 5.447_744_244e-5).abs() < 1e-14);
        assert!((beta - 0.182_425_523_8).abs() < 1e-10);
        let p_inf = alpha / (alpha + beta);
        let p = next_p_mb(&params, 0.7, 1.0, 0.75);
        assert!((p - (p_inf + (0.7 - p_inf) * (-0.1 * (alpha + beta)).exp())).abs() < 1e-15);
        assert!((p - 0.687_347_638_890_393).abs() < 1e-13, "{p}");
        // Zero amplitudes: no rate, P_MB stays.
        let frozen = Params {
            rel_a_mf_mb: 0.0,
            rel_a_mb_mf: 0.0,
            ..Params::default()
        };
        assert_eq!(next_p_mb(&frozen, 0.7, 0.2, 0.3), 0.7);
    }

    #[test]
    fn remembered_rates_are_the_computed_ones_bit_for_bit() {
        let params = Params::default();
        let mut memory = Rates::FORGOTTEN;
        let (mut kept, mut fresh) = (0.7, 0.7);
        // Arguments that repeat, change and come back, as a run's reliabilities do.
        let chis = [
            (1.0, 0.75),
            (1.0, 0.75),
            (0.9, 0.75),
            (0.9, 0.5),
            (1.0, 0.75),
            (1.0, 0.75),
        ];
        for (chi_f, chi_b) in chis {
            kept = Rates(&mut memory).next_p_mb(&params, kept, chi_f, chi_b);
            fresh = next_p_mb(&params, fresh, chi_f, chi_b);
            assert_eq!(kept.to_bits(), fresh.to_bits(), "at chi ({chi_f}, {chi_b})");
            assert_eq!(memory[0].to_bits(), chi_f.to_bits());
            assert_eq!(memory[2].to_bits(), chi_b.to_bits());
        }
        // What is remembered is what is used: a wrong value under a matching argument shows.
        memory[1] = 0.0;
        let p = Rates(&mut memory).next_p_mb(&params, 0.7, 1.0, 0.75);
        assert_ne!(p.to_bits(), next_p_mb(&params, 0.7, 1.0, 0.75).to_bits());
    }

    #[test]
    fn spe_classes_follow_the_threshold() {
        assert_eq!(spe_class(0.0, 0.5), 0);
        assert_eq!(spe_class(0.49, 0.5), 0);
        assert_eq!(spe_class(0.5, 0.5), 1);
        assert_eq!(spe_class(1.0, 0.5), 1);
        assert_eq!(spe_class(-0.5, 0.5), 2);
    }
}
