//! Model-free expert: tabular Q-learning (SPEC 3.1, Eq. 4).

use super::max_of;

/// Q(s,a) += alpha * (r + gamma * future - Q(s,a)), where `future` is [`future`]'s value of the
/// arrival.
///
/// `q` is the run's whole table, row-major `[state, action]`.
#[allow(clippy::too_many_arguments)]
#[inline]
pub fn learn(
    q: &mut [f64],
    n_actions: usize,
    s: usize,
    a: usize,
    r: f64,
    future: f64,
    alpha: f64,
    gamma: f64,
) {
    let sa = s * n_actions + a;
    q[sa] += alpha * (r + gamma * future - q[sa]);
}

/// max_b Q(next, b), or 0 when `next_terminal` (Eq. 4's future term).
#[inline]
pub fn future(q: &[f64], n_actions: usize, next: usize, next_terminal: bool) -> f64 {
    if next_terminal {
        0.0
    } else {
        max_of(&q[next * n_actions..(next + 1) * n_actions])
    }
}

/// Cost in `ops` of one MF inference: the |A| values of the row it reads (SPEC 6).
#[inline(always)]
pub fn inference_ops(n_actions: usize) -> u64 {
    n_actions as u64
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn q_learning_update_matches_eq4_by_hand() {
        // 2 states x 2 actions; Q(1,.) = (0.5, 1.0). Update (0, 1) with r = 1:
        // 0.2 + 0.6 * (1 + 0.9 * 1.0 - 0.2) = 0.2 + 0.6 * 1.7 = 1.22.
        let mut q = vec![0.0, 0.2, 0.5, 1.0];
        assert_eq!(future(&q, 2, 1, false), 1.0);
        let f = future(&q, 2, 1, false);
        learn(&mut q, 2, 0, 1, 1.0, f, 0.6, 0.9);
        assert!((q[1] - 1.22).abs() < 1e-12);
        // Into a terminal state only the reward counts: 1.22 + 0.6 * (1 - 1.22) = 1.088.
        assert_eq!(future(&q, 2, 1, true), 0.0);
        let f = future(&q, 2, 1, true);
        learn(&mut q, 2, 0, 1, 1.0, f, 0.6, 0.9);
        assert!((q[1] - 1.088).abs() < 1e-12);
    }
}
