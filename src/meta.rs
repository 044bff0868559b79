//! The meta-controller (SPEC 4): which expert controls the next action.

use std::cmp::Ordering;

use crate::arbiter::{Choice, Inputs};
use crate::expert::{entropy_bits, normalise_bits};
use crate::params::{Controller, Params, Selection};

/// Costs are divided by the larger of the two; when both are 0, by this (SPEC 4, code).
pub const TINY_COST: f64 = 1e-12;

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
        params.controller == Controller::Ec,
        entropy_bits(pavg_mf),
        entropy_bits(pavg_mb),
        pavg_mf.len(),
        cost_mf,
        cost_mb,
    )
}

/// [`expert_values`] from the two distributions' entropies in bits over `n_actions` actions:
/// `ec`'s with the cost term, `entropy`'s without.
#[inline(always)]
fn values_from_bits(
    params: &Params,
    with_cost: bool,
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
    match with_cost {
        true => {
            // Eq. 7: kappa uses the MF entropy in bits, never normalised (SPEC 4).
            let kappa = (-params.kappa_coeff * bits_mf).exp();
            let scale = cost_mf.max(cost_mb);
            let scale = if scale > 0.0 { scale } else { TINY_COST };
            (
                -(h_mf + kappa * (cost_mf / scale)),
                -(h_mb + kappa * (cost_mb / scale)),
            )
        }
        false => (-h_mf, -h_mb),
    }
}

/// Softmax probability of MB over two values: 1 / (1 + exp((v_mf - v_mb) / tau)), overflow-safe.
#[inline]
pub fn p_mb_softmax(v_mf: f64, v_mb: f64, tau: f64) -> f64 {
    // SPEC 4's literal form: exp overflowing to infinity gives exactly 0, never NaN.
    1.0 / (1.0 + ((v_mf - v_mb) / tau).exp())
}

/// Whether MB acts, given P(MB) = `p_mb` (SPEC 12.1): with softmax selection a draw below it;
/// with argmax selection the better expert by `order` (how MB's value compares with MF's), a
/// draw only on a tie.
#[inline(always)]
pub fn pick(
    selection: Selection,
    p_mb: f64,
    order: Option<Ordering>,
    uniform: impl FnOnce() -> f64,
) -> bool {
    match selection {
        Selection::Softmax => uniform() < p_mb,
        Selection::Argmax => match order {
            Some(Ordering::Equal) => uniform() < 0.5,
            o => o == Some(Ordering::Greater),
        },
    }
}

/// The choice of `ec` (`with_cost`) and `entropy` in one state (SPEC 4): the softmax
/// probability of MB over the two values of Eq. 6, and MB drawn with it (or the better value,
/// with argmax selection).
#[inline(always)]
pub fn by_values(inputs: &mut Inputs<'_>, with_cost: bool) -> Choice {
    let (p_mb, (v_mf, v_mb), (bits_mf, bits_mb)) = values(inputs, with_cost);
    let use_mb = pick(
        inputs.params.selection,
        p_mb,
        v_mb.partial_cmp(&v_mf),
        || inputs.uniform(),
    );
    inputs.choice(use_mb, p_mb, Some(if use_mb { bits_mb } else { bits_mf }))
}

/// What `ec` (`with_cost`) and `entropy` compute in one state before choosing: the softmax
/// probability of MB, the two values of Eq. 6 (MF's, MB's) and the two entropies in bits.
#[inline(always)]
pub fn values(inputs: &mut Inputs<'_>, with_cost: bool) -> (f64, (f64, f64), (f64, f64)) {
    let (bits_mf, bits_mb) = (inputs.bits_mf(), inputs.bits_mb());
    let params = inputs.params;
    let n = inputs.n_actions;
    let (cost_mf, cost_mb) = if with_cost {
        (inputs.cost_mf(), inputs.cost_mb())
    } else {
        (0.0, 0.0)
    };
    let (v_mf, v_mb) = values_from_bits(params, with_cost, bits_mf, bits_mb, n, cost_mf, cost_mb);
    let p_mb = p_mb_softmax(v_mf, v_mb, params.tau);
    (p_mb, (v_mf, v_mb), (bits_mf, bits_mb))
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
        let draws = std::cell::Cell::new(0);
        let draw = || {
            draws.set(draws.get() + 1);
            0.9
        };
        // P(MB) does not matter to argmax, only the order of the values.
        assert!(pick(Selection::Argmax, 0.0, Some(Ordering::Greater), draw));
        assert!(!pick(Selection::Argmax, 1.0, Some(Ordering::Less), draw));
        assert_eq!(draws.get(), 0);
        // A tie draws: 0.9 is not below 1/2, so MF.
        assert!(!pick(Selection::Argmax, 0.5, Some(Ordering::Equal), draw));
        assert_eq!(draws.get(), 1);
        // Softmax selection always draws, against P(MB).
        assert!(pick(Selection::Softmax, 0.95, Some(Ordering::Less), draw));
        assert!(!pick(
            Selection::Softmax,
            0.9,
            Some(Ordering::Greater),
            draw
        ));
        assert_eq!(draws.get(), 3);
    }

    #[test]
    fn p_mb_softmax_never_overflows() {
        assert_eq!(p_mb_softmax(0.0, 1.0, 1e-9), 1.0);
        assert_eq!(p_mb_softmax(1.0, 0.0, 1e-9), 0.0);
    }
}
