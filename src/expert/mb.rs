//! Model-based expert: a windowed transition model, a reward memory and value iteration
//! (SPEC 3.2, Eqs. 1–2).
//!
//! The model of a run is kept per *environment outcome* (the CSR layout of [`Spec`]): for each
//! state-action pair, a ring buffer of the outcomes of its last N executions, how many times each
//! outcome appears in that window, and the last reward received on it. T(s,a,s') is the window
//! count over the number kept; outcomes the environment cannot produce are never stored.

use crate::env::Spec;

/// One run's learned model, as mutable views into the batch's arrays.
pub struct Model<'a> {
    /// Per pair, `window_cap` slots of outcome indices local to the pair (ring buffer).
    pub ring: &'a mut [u16],
    /// Per pair, how many executions the window holds (at most N).
    pub ring_len: &'a mut [u16],
    /// Per pair, the ring slot the next execution overwrites.
    pub ring_pos: &'a mut [u16],
    /// Per environment outcome, its occurrences in the pair's window.
    pub count: &'a mut [u16],
    /// Per environment outcome, the most recent reward received on it.
    pub reward: &'a mut [f64],
    /// Per state, whether some learned transition starts there (the states VI sweeps).
    pub known: &'a mut [bool],
    /// Per state, max_b Q(s, b) of the MB's Q table as value iteration last left it, or NaN
    /// where not computed yet (see [`Model::value_iteration_cached`]).
    pub best: &'a mut [f64],
}

/// What one value-iteration call did.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct ViReport {
    /// Cost in `ops`: 1 + |A| per (s, a, s') term evaluated, over all sweeps (SPEC 6).
    pub ops: u64,
    /// Sweeps made.
    pub sweeps: u32,
    /// The call stopped at the sweep cap before converging.
    pub capped: bool,
}

impl Model<'_> {
    /// Marks every cached row maximum unknown: needed after changing the Q table given to
    /// [`value_iteration_cached`](Model::value_iteration_cached) by other means.
    pub fn forget_row_maxima(&mut self) {
        self.best.fill(f64::NAN);
    }

    /// Records one execution of (s, a) that ended in environment outcome `outcome` with reward
    /// `r`. `window_cap` is the ring stride of the batch, `window_n` this run's N <= `window_cap`.
    #[inline]
    pub fn learn(
        &mut self,
        spec: &Spec,
        window_cap: usize,
        window_n: usize,
        s: usize,
        a: usize,
        outcome: usize,
        r: f64,
    ) {
        let sa = spec.sa(s, a);
        let first = spec.outcome_start[sa] as usize;
        let local = (outcome - first) as u16;
        let ring = &mut self.ring[sa * window_cap..sa * window_cap + window_n];
        let pos = self.ring_pos[sa] as usize;
        if (self.ring_len[sa] as usize) < window_n {
            self.ring_len[sa] += 1;
        } else {
            self.count[first + ring[pos] as usize] -= 1;
        }
        ring[pos] = local;
        self.count[outcome] += 1;
        self.ring_pos[sa] = ((pos + 1) % window_n) as u16;
        self.reward[outcome] = r;
        self.known[s] = true;
    }

    /// T(s,a,s') of a global outcome index (Eq. 1); 0 for untried pairs.
    pub fn probability(&self, spec: &Spec, sa: usize, outcome: usize) -> f64 {
        debug_assert!(spec.outcomes(sa).contains(&outcome));
        let n = self.ring_len[sa];
        if n == 0 {
            0.0
        } else {
            f64::from(self.count[outcome]) / f64::from(n)
        }
    }

    /// R(s,a) = sum over s' of T(s,a,s') * r(s,a,s').
    #[inline]
    pub fn expected_reward(&self, spec: &Spec, sa: usize) -> f64 {
        let n = f64::from(self.ring_len[sa]);
        let mut r = 0.0;
        for o in spec.outcomes(sa) {
            let c = self.count[o];
            if c > 0 {
                r += f64::from(c) / n * self.reward[o];
            }
        }
        r
    }

    /// In-place value iteration over the learned model (Eq. 2), warm-started from `q`.
    ///
    /// Sweeps the known states in ascending id and, in each, the tried actions in ascending id:
    /// Q(s,a) = sum_s' T(s,a,s') (R(s,a) + gamma * max_b Q(s',b)), the goal contributing no
    /// future value. Stops when a sweep's summed |dQ| is below `epsilon`, or after `max_sweeps`.
    pub fn value_iteration(
        &mut self,
        spec: &Spec,
        q: &mut [f64],
        gamma: f64,
        epsilon: f64,
        max_sweeps: u32,
    ) -> ViReport {
        self.best.fill(f64::NAN);
        self.value_iteration_cached(spec, q, gamma, epsilon, max_sweeps)
    }

    /// [`value_iteration`](Model::value_iteration) that trusts the row maxima in `best` from the
    /// previous call instead of recomputing them: the engine's path, where only value iteration
    /// ever writes the MB's Q table.
    ///
    /// Every entry of `best` must be NaN (unknown) or the maximum of its row of `q` as
    /// `value_iteration` computes it; each call leaves them so. Whoever changes `q` otherwise
    /// must call [`forget_row_maxima`](Model::forget_row_maxima) (or use `value_iteration`).
    pub fn value_iteration_cached(
        &mut self,
        spec: &Spec,
        q: &mut [f64],
        gamma: f64,
        epsilon: f64,
        max_sweeps: u32,
    ) -> ViReport {
        let n_actions = spec.n_actions;
        let goal = spec.goal as usize;
        let term_ops = 1 + n_actions as u64;
        let mut report = ViReport::default();
        // (s, a, s') terms evaluated, over all sweeps.
        let mut terms: u64 = 0;
        // `best[s]` caches max_b Q(s, b), so a term reads one value instead of a row. It is exact:
        // a row only changes while its own state is swept, and `best` is refreshed from the row
        // (with the same fold) whenever the row may have changed, before anyone reads it.
        let best = &mut *self.best;
        loop {
            let mut delta = 0.0;
            for s in 0..spec.n_states {
                if !self.known[s] {
                    continue;
                }
                let row = s * n_actions..(s + 1) * n_actions;
                // Some Q(s, .) changed since best[s] was last refreshed.
                let mut stale = false;
                for a in 0..n_actions {
                    let sa = s * n_actions + a;
                    let kept = self.ring_len[sa];
                    if kept == 0 {
                        continue;
                    }
                    let outcomes = spec.outcomes(sa);
                    let first = outcomes.start;
                    let value = if outcomes.len() == 1 && self.count[first] == kept {
                        // A deterministic pair: T = kept / kept = 1 exactly, so the general
                        // formula below reduces to these operations, bit for bit.
                        let r_sa = 0.0 + self.reward[first];
                        let next = spec.outcome_state[first] as usize;
                        let future = if next == goal {
                            0.0
                        } else {
                            if next == s && stale {
                                best[s] = max_of(&q[row.clone()]);
                                stale = false;
                            }
                            row_max(best, q, next, n_actions)
                        };
                        terms += 1;
                        0.0 + (r_sa + gamma * future)
                    } else {
                        let n = f64::from(kept);
                        let mut r_sa = 0.0;
                        for o in outcomes.clone() {
                            let c = self.count[o];
                            if c > 0 {
                                r_sa += f64::from(c) / n * self.reward[o];
                            }
                        }
                        let mut value = 0.0;
                        for o in outcomes {
                            let c = self.count[o];
                            if c == 0 {
                                continue;
                            }
                            let next = spec.outcome_state[o] as usize;
                            let future = if next == goal {
                                0.0
                            } else {
                                if next == s && stale {
                                    best[s] = max_of(&q[row.clone()]);
                                    stale = false;
                                }
                                row_max(best, q, next, n_actions)
                            };
                            value += f64::from(c) / n * (r_sa + gamma * future);
                            terms += 1;
                        }
                        value
                    };
                    delta += (value - q[sa]).abs();
                    stale |= value.to_bits() != q[sa].to_bits();
                    q[sa] = value;
                }
                if stale {
                    best[s] = max_of(&q[row]);
                }
            }
            report.sweeps += 1;
            // A NaN delta can only come from non-finite values: stop rather than loop forever.
            if delta < epsilon || delta.is_nan() {
                break;
            }
            if report.sweeps >= max_sweeps {
                report.capped = true;
                break;
            }
        }
        report.ops = terms * term_ops;
        report
    }
}

/// `best[s]`, computed from row `s` of `q` first if unknown (NaN: `max_of` is never NaN).
#[inline(always)]
fn row_max(best: &mut [f64], q: &[f64], s: usize, n_actions: usize) -> f64 {
    let b = best[s];
    if b.is_nan() {
        let m = max_of(&q[s * n_actions..(s + 1) * n_actions]);
        best[s] = m;
        m
    } else {
        b
    }
}

/// Maximum of a row; NaN entries are skipped and an empty or all-NaN row gives -inf, so the
/// result is never NaN.
#[inline(always)]
fn max_of(row: &[f64]) -> f64 {
    row.iter().copied().fold(f64::NEG_INFINITY, f64::max)
}

/// Owned storage for one run's model, for tests and the naive reference.
#[derive(Debug, Clone)]
pub struct OwnedModel {
    /// See [`Model::ring`].
    pub ring: Vec<u16>,
    /// See [`Model::ring_len`].
    pub ring_len: Vec<u16>,
    /// See [`Model::ring_pos`].
    pub ring_pos: Vec<u16>,
    /// See [`Model::count`].
    pub count: Vec<u16>,
    /// See [`Model::reward`].
    pub reward: Vec<f64>,
    /// See [`Model::known`].
    pub known: Vec<bool>,
    /// See [`Model::best`].
    pub best: Vec<f64>,
}

impl OwnedModel {
    /// An empty model for `spec` with ring stride `window_cap`.
    pub fn new(spec: &Spec, window_cap: usize) -> Self {
        let pairs = spec.n_states * spec.n_actions;
        OwnedModel {
            ring: vec![0; pairs * window_cap],
            ring_len: vec![0; pairs],
            ring_pos: vec![0; pairs],
            count: vec![0; spec.outcome_state.len()],
            reward: vec![0.0; spec.outcome_state.len()],
            known: vec![false; spec.n_states],
            best: vec![f64::NAN; spec.n_states],
        }
    }

    /// A view usable by [`Model`]'s methods.
    pub fn view(&mut self) -> Model<'_> {
        Model {
            ring: &mut self.ring,
            ring_len: &mut self.ring_len,
            ring_pos: &mut self.ring_pos,
            count: &mut self.count,
            reward: &mut self.reward,
            known: &mut self.known,
            best: &mut self.best,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// 3 states, 1 action. 0 -> {1: w 1, 2: w 1}; 1 -> 2 (goal, reward 1); 2 -> 2.
    fn toy() -> Spec {
        Spec::from_outcomes(
            "toy".into(),
            3,
            1,
            vec![vec![(1, 1.0), (2, 1.0)], vec![(2, 1.0)], vec![(2, 1.0)]],
            vec![0],
            2,
            1.0,
            vec!["a".into(), "b".into(), "g".into()],
            None,
        )
    }

    #[test]
    fn transition_model_is_the_window_frequency_eq1() {
        let spec = toy();
        let mut owned = OwnedModel::new(&spec, 3);
        let mut m = owned.view();
        // Window N = 3; outcomes of (0, 0): s1, s1, s2, s2 -> the window keeps s1, s2, s2.
        for next in [1, 1, 2, 2] {
            let o = spec
                .outcomes(0)
                .find(|&o| spec.outcome_state[o] == next)
                .unwrap();
            m.learn(&spec, 3, 3, 0, 0, o, 0.0);
        }
        assert!((m.probability(&spec, 0, 0) - 1.0 / 3.0).abs() < 1e-15);
        assert!((m.probability(&spec, 0, 1) - 2.0 / 3.0).abs() < 1e-15);
        let row: f64 = spec.outcomes(0).map(|o| m.probability(&spec, 0, o)).sum();
        assert!((row - 1.0).abs() < 1e-12);
    }

    #[test]
    fn reward_model_weights_the_last_reward_of_each_outcome() {
        let spec = toy();
        let mut owned = OwnedModel::new(&spec, 10);
        let mut m = owned.view();
        m.learn(&spec, 10, 10, 0, 0, 0, 5.0); // to s1, r 5
        m.learn(&spec, 10, 10, 0, 0, 1, 0.0); // to s2, r 0
        m.learn(&spec, 10, 10, 0, 0, 1, 3.0); // to s2, r 3 (replaces 0)
        // R = 1/3 * 5 + 2/3 * 3 = 11/3.
        assert!((m.expected_reward(&spec, 0) - 11.0 / 3.0).abs() < 1e-12);
    }

    #[test]
    fn one_value_iteration_sweep_on_a_3_state_toy_matches_hand_values() {
        let spec = toy();
        let mut owned = OwnedModel::new(&spec, 10);
        let mut m = owned.view();
        m.learn(&spec, 10, 10, 0, 0, 0, 0.0); // 0 -> 1
        m.learn(&spec, 10, 10, 0, 0, 1, 0.0); // 0 -> 2 (goal, reward withheld: 0)
        m.learn(&spec, 10, 10, 1, 0, 2, 1.0); // 1 -> 2 (goal), r 1
        let mut q = vec![0.0; 3];
        // One sweep (max_sweeps 1): state 0 first: 0.5 * (0 + 0.9 * Q1 = 0) + 0.5 * (0 + 0) = 0;
        // then state 1: 1 * (1 + 0) = 1. ops: (2 + 1 terms) * (1 + 1) = 6.
        let report = m.value_iteration(&spec, &mut q, 0.9, 1e-9, 1);
        assert_eq!(q, vec![0.0, 1.0, 0.0]);
        assert_eq!(
            report,
            ViReport {
                ops: 6,
                sweeps: 1,
                capped: true
            }
        );
        // Second sweep: Q0 = 0.5 * 0.9 * 1 = 0.45, then a sweep with no change ends it.
        let report = m.value_iteration(&spec, &mut q, 0.9, 1e-9, 100);
        assert!((q[0] - 0.45).abs() < 1e-15);
        assert_eq!(report.sweeps, 2);
        assert!(!report.capped);
    }
}
