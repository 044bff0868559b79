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

/// One run's replacing eligibility trace (SPEC 3.1, `lambda_mf` > 0): e(s, a) per pair, and
/// the pairs with e > 0 this episode (the first `len` of `pairs`, in the order they entered),
/// so that an update visits the episode's pairs rather than the whole table.
pub struct Eligibility<'a> {
    /// e(s, a), row-major `[state, action]`.
    pub e: &'a mut [f64],
    /// The pairs with e > 0, as indices into `e`.
    pub pairs: &'a mut [u32],
    /// How many of `pairs` are in use.
    pub len: &'a mut u32,
}

impl Eligibility<'_> {
    /// Learns (s, a, r, s') for the pair `sa` whose TD error is `delta` (r + gamma * future -
    /// Q(s, a), before any update): e(s, a) = 1, every pair with e > 0 gets Q += alpha * delta *
    /// e, then every e is multiplied by `decay` (gamma_mf * lambda_mf), or all are cleared when
    /// the transition was `terminal`. `changed(pair)` is called for each pair whose Q changed.
    /// The current pair's update is bit for bit Eq. 4's (e = 1).
    #[inline]
    pub fn learn(
        &mut self,
        q: &mut [f64],
        sa: usize,
        delta: f64,
        alpha: f64,
        decay: f64,
        terminal: bool,
        mut changed: impl FnMut(usize),
    ) {
        if self.e[sa] == 0.0 {
            self.pairs[*self.len as usize] = sa as u32;
            *self.len += 1;
        }
        self.e[sa] = 1.0;
        let step = alpha * delta;
        for &pair in &self.pairs[..*self.len as usize] {
            let pair = pair as usize;
            let before = q[pair];
            q[pair] += step * self.e[pair];
            if q[pair].to_bits() != before.to_bits() {
                changed(pair);
            }
        }
        if terminal {
            self.clear();
            return;
        }
        // Decay, dropping the pairs whose trace vanished (decay 0, or underflow), so that a
        // pair is listed at most once.
        let mut kept = 0;
        for i in 0..*self.len as usize {
            let pair = self.pairs[i] as usize;
            self.e[pair] *= decay;
            if self.e[pair] > 0.0 {
                self.pairs[kept] = pair as u32;
                kept += 1;
            }
        }
        *self.len = kept as u32;
    }

    /// Clears every trace (after a terminal transition, at a reset step, at the end of
    /// babbling).
    #[inline]
    pub fn clear(&mut self) {
        for &pair in &self.pairs[..*self.len as usize] {
            self.e[pair as usize] = 0.0;
        }
        *self.len = 0;
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

    #[test]
    fn the_replacing_trace_carries_a_reward_back_over_an_episode_by_hand() {
        // 3 states x 2 actions, alpha 0.5, gamma 0.9, lambda 0.5: decay 0.45. Q starts at 0
        // but Q(2, 1) = 1 so that a future term shows.
        let (alpha, gamma, lambda) = (0.5, 0.9, 0.5);
        let decay = gamma * lambda;
        let mut q = vec![0.0; 6];
        q[5] = 1.0;
        let mut e = vec![0.0; 6];
        let mut pairs = vec![0u32; 6];
        let mut len = 0;
        let mut trace = Eligibility {
            e: &mut e,
            pairs: &mut pairs,
            len: &mut len,
        };
        let mut changed = Vec::new();
        // Step 1: (0, 1) -> 1, r = 0. delta = 0 + 0.9 * max Q(1, .) - 0 = 0: nothing moves.
        let delta = 0.0 + gamma * future(&q, 2, 1, false) - q[1];
        trace.learn(&mut q, 1, delta, alpha, decay, false, |p| changed.push(p));
        assert_eq!(q, [0.0, 0.0, 0.0, 0.0, 0.0, 1.0]);
        assert!(changed.is_empty());
        assert_eq!(trace.e[1], 0.45);
        // Step 2: (1, 0) -> 2, r = 0. delta = 0.9 * 1 - 0 = 0.9; e(1, 0) = 1, e(0, 1) = 0.45.
        // Q(1, 0) = 0.5 * 0.9 = 0.45; Q(0, 1) = 0.5 * 0.9 * 0.45 = 0.2025.
        let delta = 0.0 + gamma * future(&q, 2, 2, false) - q[2];
        trace.learn(&mut q, 2, delta, alpha, decay, false, |p| changed.push(p));
        assert!((q[2] - 0.45).abs() < 1e-15);
        assert!((q[1] - 0.2025).abs() < 1e-15);
        assert_eq!(changed, [1, 2]);
        assert!((trace.e[1] - 0.2025).abs() < 1e-15 && (trace.e[2] - 0.45).abs() < 1e-15);
        // Step 3: (2, 1) -> terminal, r = 2: delta = 2 - Q(2, 1) = 1 (no future term).
        // Q(2, 1) = 1.5; Q(1, 0) = 0.45 + 0.5 * 0.45 = 0.675; Q(0, 1) = 0.2025 + 0.5 * 0.2025
        // = 0.30375. Then every trace is cleared.
        let delta = 2.0 + gamma * future(&q, 2, 0, true) - q[5];
        trace.learn(&mut q, 5, delta, alpha, decay, true, |_| {});
        assert!((q[5] - 1.5).abs() < 1e-15);
        assert!((q[2] - 0.675).abs() < 1e-15);
        assert!((q[1] - 0.30375).abs() < 1e-15);
        assert_eq!(*trace.len, 0);
        assert!(trace.e.iter().all(|&e| e == 0.0));
        // Revisiting a pair replaces its trace (1, not 1 + decay) and lists it once.
        trace.learn(&mut q, 0, 0.0, alpha, decay, false, |_| {});
        trace.learn(&mut q, 0, 0.0, alpha, decay, false, |_| {});
        assert_eq!((*trace.len, trace.e[0]), (1, 0.45));
        // A decay of 0 (lambda 0) leaves nothing listed: the same pair is never listed twice.
        trace.learn(&mut q, 0, 0.0, alpha, 0.0, false, |_| {});
        assert_eq!(*trace.len, 0);
    }
}
