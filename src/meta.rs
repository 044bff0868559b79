//! The meta-controller (SPEC 4): which expert controls the next action.

use crate::expert::{entropy_bits, normalise_bits};
use crate::params::{Controller, Params, Selection};

/// Costs are divided by the larger of the two; when both are 0, by this (SPEC 4, code).
pub const TINY_COST: f64 = 1e-12;

/// What the MC read and decided in one state.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Choice {
    /// The MB expert controls this step.
    pub use_mb: bool,
    /// Softmax probability of MB over the two values (0.5 for `rnd`, 0 for `mf`, 1 for `mb`).
    pub p_mb: f64,
    /// Normalised entropy of the chosen expert's averaged distribution, as read before this step.
    pub chosen_entropy: f64,
}

/// Expert values of Eq. 6 for `ec` and `entropy`, from the averaged distributions and per-state
/// costs of state s. Returns (value of MF, value of MB).
#[inline]
pub fn expert_values(
    params: &Params,
    pavg_mf: &[f64],
    pavg_mb: &[f64],
    cost_mf: f64,
    cost_mb: f64,
) -> (f64, f64) {
    values_from_bits(
        params,
        params.controller,
        entropy_bits(pavg_mf),
        entropy_bits(pavg_mb),
        pavg_mf.len(),
        cost_mf,
        cost_mb,
    )
}

/// [`expert_values`] from the two distributions' entropies in bits over `n_actions` actions.
#[inline(always)]
fn values_from_bits(
    params: &Params,
    controller: Controller,
    bits_mf: f64,
    bits_mb: f64,
    n_actions: usize,
    cost_mf: f64,
    cost_mb: f64,
) -> (f64, f64) {
    let (h_mf, h_mb) = if params.normalise_entropy {
        (
            normalise_bits(bits_mf, n_actions),
            normalise_bits(bits_mb, n_actions),
        )
    } else {
        (bits_mf, bits_mb)
    };
    match controller {
        Controller::Ec => {
            // Eq. 7: kappa uses the MF entropy in bits, never normalised (SPEC 4).
            let kappa = (-params.kappa_coeff * bits_mf).exp();
            let scale = cost_mf.max(cost_mb);
            let scale = if scale > 0.0 { scale } else { TINY_COST };
            (
                -(h_mf + kappa * (cost_mf / scale)),
                -(h_mb + kappa * (cost_mb / scale)),
            )
        }
        _ => (-h_mf, -h_mb),
    }
}

/// Softmax probability of MB over two values: 1 / (1 + exp((v_mf - v_mb) / tau)), overflow-safe.
#[inline]
pub fn p_mb_softmax(v_mf: f64, v_mb: f64, tau: f64) -> f64 {
    // SPEC 4's literal form: exp overflowing to infinity gives exactly 0, never NaN.
    1.0 / (1.0 + ((v_mf - v_mb) / tau).exp())
}

/// The MC's choice in one state for `controller` (the run's, passed apart so that a step compiled
/// for one controller folds the match), over `n_actions` actions. `bits_mf` and `bits_mb` give
/// the entropies in bits of the two experts' averaged distributions in that state; each is asked
/// at most once, and only when the controller reads it (the engine keeps them between visits).
/// `uniform` draws a number in [0, 1) when a draw is needed: once for `rnd` and softmax
/// selection, and only on a tie for argmax selection.
#[allow(clippy::too_many_arguments)]
#[inline(always)]
pub fn choose(
    params: &Params,
    controller: Controller,
    n_actions: usize,
    bits_mf: impl FnOnce() -> f64,
    bits_mb: impl FnOnce() -> f64,
    cost_mf: f64,
    cost_mb: f64,
    mut uniform: impl FnMut() -> f64,
) -> Choice {
    let n = n_actions;
    let (use_mb, p_mb, chosen_bits) = match controller {
        Controller::Mf => (false, 0.0, bits_mf()),
        Controller::Mb => (true, 1.0, bits_mb()),
        Controller::Rnd => {
            let use_mb = uniform() < 0.5;
            (use_mb, 0.5, if use_mb { bits_mb() } else { bits_mf() })
        }
        Controller::Ec | Controller::Entropy => {
            let (bits_mf, bits_mb) = (bits_mf(), bits_mb());
            let (v_mf, v_mb) =
                values_from_bits(params, controller, bits_mf, bits_mb, n, cost_mf, cost_mb);
            let p_mb = p_mb_softmax(v_mf, v_mb, params.tau);
            let use_mb = match params.selection {
                Selection::Softmax => uniform() < p_mb,
                Selection::Argmax => {
                    if v_mb == v_mf {
                        uniform() < 0.5
                    } else {
                        v_mb > v_mf
                    }
                }
            };
            (use_mb, p_mb, if use_mb { bits_mb } else { bits_mf })
        }
    };
    Choice {
        use_mb,
        p_mb,
        chosen_entropy: normalise_bits(chosen_bits, n),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ec_values_follow_eqs_6_and_7_by_hand() {
        // Two actions: MF averaged (0.5, 0.5): 1 bit, normalised 1; MB (1, 0): 0 bits.
        // kappa = exp(-2 * 1) with kappa_coeff 2. Costs 2 (MF) and 8 (MB): normalised 0.25, 1.
        let params = Params {
            kappa_coeff: 2.0,
            ..Params::default()
        };
        let (v_mf, v_mb) = expert_values(&params, &[0.5, 0.5], &[1.0, 0.0], 2.0, 8.0);
        let kappa = (-2.0f64).exp();
        assert!((v_mf - -(1.0 + kappa * 0.25)).abs() < 1e-12);
        assert!((v_mb - -(kappa * 1.0)).abs() < 1e-12);
        // tau = 0.02: P(MB) = 1 / (1 + exp((v_mf - v_mb) / 0.02)).
        let p = p_mb_softmax(v_mf, v_mb, 0.02);
        assert!((p - 1.0 / (1.0 + ((v_mf - v_mb) / 0.02).exp())).abs() < 1e-12);
    }

    #[test]
    fn kappa_uses_unnormalised_bits_even_when_entropy_is_normalised() {
        // Uniform over 4 actions: 2 bits. kappa = exp(-1 * 2), not exp(-1 * 1).
        let params = Params {
            kappa_coeff: 1.0,
            ..Params::default()
        };
        let u = [0.25; 4];
        let (v_mf, _) = expert_values(&params, &u, &u, 1.0, 0.0);
        assert!((v_mf - -(1.0 + (-2.0f64).exp())).abs() < 1e-12);
    }

    #[test]
    fn zero_costs_give_equal_values_and_a_fair_softmax() {
        let params = Params::default();
        let u = [1.0 / 7.0; 7];
        let (v_mf, v_mb) = expert_values(&params, &u, &u, 0.0, 0.0);
        assert_eq!(v_mf, v_mb);
        assert_eq!(p_mb_softmax(v_mf, v_mb, 0.02), 0.5);
    }

    #[test]
    fn argmax_prefers_the_better_value_and_draws_only_on_ties() {
        let params = Params {
            selection: Selection::Argmax,
            ..Params::default()
        };
        let mut draws = 0;
        let c = choose(
            &params,
            params.controller,
            2,
            || entropy_bits(&[0.5, 0.5]),
            || entropy_bits(&[1.0, 0.0]),
            0.0,
            0.0,
            || {
                draws += 1;
                0.9
            },
        );
        assert!(c.use_mb);
        assert_eq!(draws, 0);
        assert_eq!(c.chosen_entropy, 0.0);
    }

    #[test]
    fn p_mb_softmax_never_overflows() {
        assert_eq!(p_mb_softmax(0.0, 1.0, 1e-9), 1.0);
        assert_eq!(p_mb_softmax(1.0, 0.0, 1e-9), 0.0);
    }
}
