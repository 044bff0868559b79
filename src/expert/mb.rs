//! Model-based expert: a windowed transition model, a reward memory and value iteration
//! (SPEC 3.2, Eqs. 1–2).
//!
//! The model of a run is kept per *observable outcome* ([`Observable`], a CSR table shared by the
//! batch): for each state-action pair, a ring buffer of the outcomes of its last N executions, how
//! many times each outcome appears in that window, the last reward received on it and whether that
//! arrival was terminal (SPEC 10). Without changes during the run the observable outcomes are
//! exactly the environment's; with a schedule they are the union over every world the run can
//! meet, plus the outcomes a nuisance human can produce. T(s,a,s') is the window count over the
//! number kept; outcomes the run can never observe are never stored.
//!
//! Value iteration is incremental but exact. A pair's new value depends only on its own model
//! (changed by [`Model::learn`]) and on the row maxima max_b Q(s', b) of its next states, so a
//! pair none of whose inputs changed since it was last computed would get the same value again,
//! bit for bit, and add exactly 0 to the sweep's |dQ|. Each sweep therefore recomputes only the
//! *dirty* pairs (learned since, or with a next state whose row maximum changed since), in the
//! same ascending order, and charges every term of the model in `ops` as a full sweep does: Q,
//! the sweep count and the cost are those of sweeping everything (`value_iteration_reference`
//! in the tests is the plain version they are checked against).

use std::sync::Arc;

use super::max_of;
use crate::env::{Spec, StateId};

/// The outcomes a run's MB expert can observe, per state-action pair, in CSR form: the outcomes
/// of `sa = s * n_actions + a` are `outcomes(sa)`, next states strictly ascending. Shared by every
/// run of a batch; the model's per-outcome arrays are indexed by it.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Observable {
    n_states: usize,
    n_actions: usize,
    start: Vec<u32>,
    state: Vec<StateId>,
    preds: Predecessors,
}

impl Observable {
    /// The table of per-pair next-state lists (sorted and deduplicated here).
    pub fn new(n_states: usize, n_actions: usize, mut lists: Vec<Vec<StateId>>) -> Observable {
        assert_eq!(lists.len(), n_states * n_actions);
        let mut start = Vec::with_capacity(lists.len() + 1);
        let mut state = Vec::new();
        start.push(0u32);
        for list in &mut lists {
            list.sort_unstable();
            list.dedup();
            state.extend_from_slice(list);
            start.push(state.len() as u32);
        }
        let mut table = Observable {
            n_states,
            n_actions,
            start,
            state,
            preds: Predecessors {
                start: Vec::new(),
                pairs: Vec::new(),
            },
        };
        table.preds = Predecessors::new(&table);
        table
    }

    /// Exactly the outcomes of `spec`'s table (a run without changes).
    pub fn of(spec: &Spec) -> Observable {
        Observable::union([spec], std::iter::empty())
    }

    /// The union of the outcomes of several worlds of the same spaces, plus `extra` (pair, next
    /// state) outcomes no world lists (a nuisance's).
    pub fn union<'s>(
        worlds: impl IntoIterator<Item = &'s Spec>,
        extra: impl IntoIterator<Item = (usize, StateId)>,
    ) -> Observable {
        let mut dims = None;
        let mut lists: Vec<Vec<StateId>> = Vec::new();
        for spec in worlds {
            let (n_s, n_a) = (spec.n_states, spec.n_actions);
            match dims {
                None => {
                    dims = Some((n_s, n_a));
                    lists = vec![Vec::new(); n_s * n_a];
                }
                Some(d) => assert_eq!(d, (n_s, n_a), "worlds of one run share their spaces"),
            }
            for (sa, list) in lists.iter_mut().enumerate() {
                list.extend(spec.outcomes(sa).map(|o| spec.outcome_state[o]));
            }
        }
        let (n_s, n_a) = dims.expect("at least one world");
        for (sa, next) in extra {
            lists[sa].push(next);
        }
        Observable::new(n_s, n_a, lists)
    }

    /// Number of states.
    #[inline(always)]
    pub fn n_states(&self) -> usize {
        self.n_states
    }

    /// Number of actions.
    #[inline(always)]
    pub fn n_actions(&self) -> usize {
        self.n_actions
    }

    /// Number of observable outcomes, all pairs together.
    pub fn len(&self) -> usize {
        self.state.len()
    }

    /// Whether no outcome is observable (never, for a valid table).
    pub fn is_empty(&self) -> bool {
        self.state.is_empty()
    }

    /// Range of outcome indices of the pair `sa`.
    #[inline(always)]
    pub fn outcomes(&self, sa: usize) -> std::ops::Range<usize> {
        self.start[sa] as usize..self.start[sa + 1] as usize
    }

    /// Next state of outcome `o`.
    #[inline(always)]
    pub fn next_state(&self, o: usize) -> usize {
        self.state[o] as usize
    }

    /// Index of the outcome of `sa` that arrives in `next`. A pair's list is short (one entry for
    /// a deterministic pair), so a scan is cheaper than any map.
    #[inline(always)]
    pub fn find(&self, sa: usize, next: usize) -> usize {
        let range = self.outcomes(sa);
        let first = range.start;
        let local = self.state[range]
            .iter()
            .position(|&x| x as usize == next)
            .expect("every outcome a run can observe is in its table");
        first + local
    }

    /// The predecessor lists of this table.
    #[inline(always)]
    pub fn preds(&self) -> &Predecessors {
        &self.preds
    }

    /// Words of a bit set over the state-action pairs.
    pub fn dirty_words(&self) -> usize {
        (self.n_states * self.n_actions).div_ceil(64)
    }
}

/// For each state, the state-action pairs that can lead to it (from the observable outcomes, so
/// a superset of what a run learns): whose values to recompute when its row maximum changes.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Predecessors {
    start: Vec<u32>,
    pairs: Vec<u32>,
}

impl Predecessors {
    /// The reverse of an outcome table, pairs ascending for each state.
    fn new(table: &Observable) -> Predecessors {
        let n_states = table.n_states;
        let mut start = vec![0u32; n_states + 1];
        for &next in &table.state {
            start[next as usize + 1] += 1;
        }
        for s in 0..n_states {
            start[s + 1] += start[s];
        }
        let mut fill = start.clone();
        let mut pairs = vec![0u32; table.state.len()];
        for sa in 0..n_states * table.n_actions {
            for o in table.outcomes(sa) {
                let next = table.state[o] as usize;
                pairs[fill[next] as usize] = sa as u32;
                fill[next] += 1;
            }
        }
        Predecessors { start, pairs }
    }

    /// Pairs that have `s` among their outcomes.
    #[inline(always)]
    pub fn of(&self, s: usize) -> &[u32] {
        &self.pairs[self.start[s] as usize..self.start[s + 1] as usize]
    }
}

/// One run's learned model, as mutable views into the batch's arrays.
pub struct Model<'a> {
    /// Slots per pair in [`ring`](Model::ring): the largest window N of the batch's runs (a run's
    /// own N may be smaller; its pair's ring then leaves the last slots unused).
    pub window_cap: usize,
    /// Per pair, `window_cap` slots of outcome indices local to the pair (ring buffer).
    pub ring: &'a mut [u16],
    /// Per pair, how many executions the window holds (at most N).
    pub ring_len: &'a mut [u16],
    /// Per pair, the ring slot the next execution overwrites.
    pub ring_pos: &'a mut [u16],
    /// Per observable outcome, its occurrences in the pair's window.
    pub count: &'a mut [u16],
    /// Per observable outcome, the most recent reward received on it.
    pub reward: &'a mut [f64],
    /// Per observable outcome, whether its most recent arrival was terminal (SPEC 10).
    pub terminal: &'a mut [bool],
    /// Per state, whether some learned transition starts there (the states VI sweeps).
    pub known: &'a mut [bool],
    /// Per state, max_b Q(s, b) of the MB's Q table as value iteration last left it, or NaN
    /// where not computed yet (see [`Model::value_iteration_cached`]).
    pub best: &'a mut [f64],
    /// Bit set over pairs ([`Observable::dirty_words`] words): the pair must be recomputed at
    /// the next sweep. No padding bit is ever set.
    pub dirty: &'a mut [u64],
    /// Number of outcomes with a non-zero count: the terms one sweep evaluates.
    pub active_terms: &'a mut u64,
    /// The outcomes the run can observe, and their predecessor lists.
    pub obs: &'a Observable,
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
    /// The call changed a value of the Q table (bit for bit).
    pub changed: bool,
}

impl Model<'_> {
    /// Empties the model: nothing observed, every row maximum unknown, no pair to recompute.
    pub fn clear(&mut self) {
        self.ring.fill(0);
        self.ring_len.fill(0);
        self.ring_pos.fill(0);
        self.count.fill(0);
        self.reward.fill(0.0);
        self.terminal.fill(false);
        self.known.fill(false);
        self.best.fill(f64::NAN);
        self.dirty.fill(0);
        *self.active_terms = 0;
    }

    /// Forgets what the incremental value iteration knows about the Q table (row maxima, which
    /// pairs are up to date): needed after changing the Q table given to
    /// [`value_iteration_cached`](Model::value_iteration_cached) by other means.
    pub fn forget_row_maxima(&mut self) {
        self.best.fill(f64::NAN);
        self.dirty_set().mark_all();
    }

    /// The dirty-pair set.
    #[inline(always)]
    fn dirty_set(&mut self) -> DirtySet<'_> {
        DirtySet::new(self.dirty, self.obs.n_states * self.obs.n_actions)
    }

    #[inline(always)]
    fn mark(&mut self, sa: usize) {
        self.dirty_set().mark(sa);
    }

    /// Records one execution of (s, a) that arrived in `next` with reward `r`, `terminal` when
    /// that arrival ended the episode (SPEC 10). `window_n` is this run's N <= the model's
    /// `window_cap`.
    #[inline(always)]
    pub fn learn(
        &mut self,
        window_n: usize,
        s: usize,
        a: usize,
        next: usize,
        r: f64,
        terminal: bool,
    ) {
        let obs = self.obs;
        let sa = s * obs.n_actions + a;
        let first = obs.start[sa] as usize;
        let outcome = obs.find(sa, next);
        let cap = self.window_cap;
        let ring = &mut self.ring[sa * cap..sa * cap + window_n];
        let pos = self.ring_pos[sa] as usize;
        let kept = &mut self.ring_len[sa];
        // The outcome that leaves a full window is the one that arrives, with the reward and
        // end it had: the pair's terms (Eq. 2) are unchanged, so its Q value needs no update.
        let same = (*kept as usize) == window_n
            && first + ring[pos] as usize == outcome
            && self.reward[outcome].to_bits() == r.to_bits()
            && self.terminal[outcome] == terminal;
        // The ring cursor wraps by a comparison: a division per learned step costs more.
        let after = pos + 1;
        self.ring_pos[sa] = if after == window_n { 0 } else { after as u16 };
        if same {
            return;
        }
        if (*kept as usize) < window_n {
            *kept += 1;
        } else {
            let old = first + ring[pos] as usize;
            self.count[old] -= 1;
            if self.count[old] == 0 {
                *self.active_terms -= 1;
            }
        }
        ring[pos] = (outcome - first) as u16;
        let count = &mut self.count[outcome];
        if *count == 0 {
            *self.active_terms += 1;
        }
        *count += 1;
        self.reward[outcome] = r;
        self.terminal[outcome] = terminal;
        self.known[s] = true;
        self.mark(sa);
    }

    /// T(s,a,s') of a global outcome index (Eq. 1); 0 for untried pairs.
    pub fn probability(&self, sa: usize, outcome: usize) -> f64 {
        debug_assert!(self.obs.outcomes(sa).contains(&outcome));
        let n = self.ring_len[sa];
        if n == 0 {
            0.0
        } else {
            f64::from(self.count[outcome]) / f64::from(n)
        }
    }

    /// R(s,a) = sum over s' of T(s,a,s') * r(s,a,s').
    #[inline]
    pub fn expected_reward(&self, sa: usize) -> f64 {
        let n = f64::from(self.ring_len[sa]);
        let mut r = 0.0;
        for o in self.obs.outcomes(sa) {
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
    /// Q(s,a) = sum_s' T(s,a,s') (R(s,a) + gamma * max_b Q(s',b)), outcomes whose last arrival
    /// was terminal contributing no future value. Stops when a sweep's summed |dQ| is below
    /// `epsilon`, or after `max_sweeps`.
    ///
    /// Only the dirty pairs are recomputed, trusting what the previous calls left (the row
    /// maxima in `best`, the `dirty` pairs): the engine's path, where only value iteration ever
    /// writes the MB's Q table. Every entry of `best` must be NaN (unknown) or the maximum of
    /// its row of `q`, and every pair whose value could differ from its entry in `q` must be
    /// dirty; [`Model::learn`] and each call keep it so. Whoever changes `q` otherwise must call
    /// [`forget_row_maxima`](Model::forget_row_maxima) first.
    pub fn value_iteration_cached(
        &mut self,
        q: &mut [f64],
        gamma: f64,
        epsilon: f64,
        max_sweeps: u32,
    ) -> ViReport {
        self.value_iteration_noting(q, gamma, epsilon, max_sweeps, |_| {})
    }

    /// [`value_iteration_cached`](Model::value_iteration_cached), calling `row_changed(s)`
    /// whenever a value of row `s` of `q` changes (bit for bit), so that what was computed from
    /// the other rows can be kept: at steady state a call changes a few rows, if any.
    pub fn value_iteration_noting(
        &mut self,
        q: &mut [f64],
        gamma: f64,
        epsilon: f64,
        max_sweeps: u32,
        mut row_changed: impl FnMut(usize),
    ) -> ViReport {
        let obs = self.obs;
        let n_actions = obs.n_actions;
        let n_pairs = obs.n_states * n_actions;
        // Views cut to their lengths once, so that indexing by a pair below `n_pairs` (or by a
        // state of the table) needs no further bounds check in the loop.
        let q = &mut q[..n_pairs];
        let ring_len = &self.ring_len[..n_pairs];
        let mut dirty = DirtySet::new(self.dirty, n_pairs);
        let terms = Terms {
            obs,
            count: self.count,
            reward: self.reward,
            terminal: self.terminal,
        };
        let mut report = ViReport::default();
        // At steady state most calls find no pair dirty: one OR over the words (which the
        // compiler vectorises) says so without walking the set a word at a time, and a sweep that
        // computes nothing marks nothing, so every sweep of such a call is empty.
        let clean = dirty.is_empty();
        loop {
            let mut delta = 0.0;
            if !clean {
                // Ascending over the dirty pairs, re-reading the bit set as it goes: pairs
                // marked ahead of the cursor are computed in this sweep (as a full sweep would
                // read the new maximum), pairs marked behind it in the next.
                let mut next_pair = 0;
                // The state of the current pair, followed as pairs ascend (a division per pair
                // would cost more than the arithmetic of a deterministic pair).
                let (mut s, mut row_end) = (0, n_actions);
                while let Some(sa) = dirty.next_from(next_pair) {
                    next_pair = sa + 1;
                    dirty.clear(sa);
                    let kept = ring_len[sa];
                    if kept == 0 {
                        continue;
                    }
                    if sa >= row_end {
                        s = if sa < row_end + n_actions {
                            s + 1
                        } else {
                            sa / n_actions
                        };
                        row_end = (s + 1) * n_actions;
                    }
                    let value = pair_value(&terms, self.best, sa, kept, q, gamma);
                    let old = q[sa];
                    delta += (value - old).abs();
                    if value.to_bits() != old.to_bits() {
                        let before = row_max(self.best, q, s, n_actions);
                        q[sa] = value;
                        report.changed = true;
                        row_changed(s);
                        // The new maximum without rereading the row when the changed entry
                        // decides it: a larger value is the new maximum; an entry below the
                        // maximum left it in place. Otherwise (the maximum itself fell, ties,
                        // NaN) reread the row.
                        let after = if value > before {
                            value
                        } else if old < before {
                            before
                        } else {
                            max_of(&q[s * n_actions..(s + 1) * n_actions])
                        };
                        self.best[s] = after;
                        if after.to_bits() != before.to_bits() {
                            for &p in obs.preds.of(s) {
                                dirty.mark(p as usize);
                            }
                        }
                    }
                    if !value.is_finite() {
                        // A full sweep would meet it again (and a NaN or infinite |dQ|) next time.
                        dirty.mark(sa);
                    }
                }
            }
            if sweep_ends(&mut report, delta, epsilon, max_sweeps) {
                break;
            }
        }
        // Every sweep is charged for every term of the model (SPEC 6), computed or not.
        report.ops = u64::from(report.sweeps) * *self.active_terms * (1 + n_actions as u64);
        report
    }
}

/// The per-outcome arrays of a model that value iteration reads (the sums of Eq. 2).
struct Terms<'b> {
    obs: &'b Observable,
    count: &'b [u16],
    reward: &'b [f64],
    terminal: &'b [bool],
}

/// Q(s, a) of Eq. 2 for the pair `sa` (tried `kept` times), from the row maxima.
#[inline(always)]
fn pair_value(
    terms: &Terms<'_>,
    best: &mut [f64],
    sa: usize,
    kept: u16,
    q: &[f64],
    gamma: f64,
) -> f64 {
    let obs = terms.obs;
    let n_actions = obs.n_actions;
    let outcomes = obs.outcomes(sa);
    // One range check per array for the pair, none per outcome.
    let count = &terms.count[outcomes.clone()];
    let reward = &terms.reward[outcomes.clone()];
    let terminal = &terms.terminal[outcomes.clone()];
    let next = &obs.state[outcomes];
    if count.len() == 1 && count[0] == kept {
        // A deterministic pair: T = kept / kept = 1 exactly, so the general formula below
        // reduces to these operations, bit for bit.
        let r_sa = 0.0 + reward[0];
        let future = if terminal[0] {
            0.0
        } else {
            row_max(best, q, next[0] as usize, n_actions)
        };
        return 0.0 + (r_sa + gamma * future);
    }
    let n = f64::from(kept);
    // T(s,a,s') of the first outcomes, computed once for both sums (same division, same
    // value); pairs with more outcomes divide again in the second.
    const KEEP: usize = 16;
    let mut t = [0.0; KEEP];
    let mut r_sa = 0.0;
    for (i, (&c, &r)) in count.iter().zip(reward).enumerate() {
        if c > 0 {
            let p = f64::from(c) / n;
            if i < KEEP {
                t[i] = p;
            }
            r_sa += p * r;
        }
    }
    let mut value = 0.0;
    for (i, ((&c, &end), &next)) in count.iter().zip(terminal).zip(next).enumerate() {
        if c == 0 {
            continue;
        }
        let future = if end {
            0.0
        } else {
            row_max(best, q, next as usize, n_actions)
        };
        let p = if i < KEEP { t[i] } else { f64::from(c) / n };
        value += p * (r_sa + gamma * future);
    }
    value
}

/// Counts the sweep just made and says whether value iteration stops there: converged (summed
/// |dQ| below `epsilon`), or at the sweep cap (`capped`). A NaN sum can only come from
/// non-finite values: stop rather than loop forever.
#[inline(always)]
fn sweep_ends(report: &mut ViReport, delta: f64, epsilon: f64, max_sweeps: u32) -> bool {
    report.sweeps += 1;
    if delta < epsilon || delta.is_nan() {
        return true;
    }
    if report.sweeps >= max_sweeps {
        report.capped = true;
        return true;
    }
    false
}

/// The dirty-pair set of a model, a bit per pair, ascending.
struct DirtySet<'d> {
    words: &'d mut [u64],
    n_pairs: usize,
}

impl<'d> DirtySet<'d> {
    /// The set stored in `dirty` ([`Observable::dirty_words`] words) over `n_pairs` pairs.
    #[inline(always)]
    fn new(words: &'d mut [u64], n_pairs: usize) -> Self {
        DirtySet { words, n_pairs }
    }

    #[inline(always)]
    fn mark(&mut self, sa: usize) {
        self.words[sa / 64] |= 1 << (sa % 64);
    }

    #[inline(always)]
    fn clear(&mut self, sa: usize) {
        self.words[sa / 64] &= !(1 << (sa % 64));
    }

    /// Whether no pair is dirty.
    #[inline(always)]
    fn is_empty(&self) -> bool {
        self.words.iter().fold(0, |any, &w| any | w) == 0
    }

    /// Every pair dirty, and no padding bit (so that every set bit is a pair).
    fn mark_all(&mut self) {
        self.words.fill(u64::MAX);
        let used = self.n_pairs % 64;
        if let (Some(last), true) = (self.words.last_mut(), used != 0) {
            *last = (1u64 << used) - 1;
        }
    }

    /// The first dirty pair at or after `from`, if any.
    #[inline(always)]
    fn next_from(&self, from: usize) -> Option<usize> {
        let mut w = from / 64;
        let mut word = *self.words.get(w)? & (u64::MAX << (from % 64));
        while word == 0 {
            w += 1;
            word = *self.words.get(w)?;
        }
        let sa = w * 64 + word.trailing_zeros() as usize;
        // Every set bit is a pair (no padding bits): saying so lets the optimiser drop the
        // bounds checks of the per-pair arrays indexed by `sa`.
        (sa < self.n_pairs).then_some(sa)
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

/// Owned storage for one run's model, for tests and the naive reference.
#[derive(Debug, Clone)]
pub struct OwnedModel {
    /// See [`Model::window_cap`].
    pub window_cap: usize,
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
    /// See [`Model::terminal`].
    pub terminal: Vec<bool>,
    /// See [`Model::known`].
    pub known: Vec<bool>,
    /// See [`Model::best`].
    pub best: Vec<f64>,
    /// See [`Model::dirty`].
    pub dirty: Vec<u64>,
    /// See [`Model::active_terms`].
    pub active_terms: u64,
    /// See [`Model::obs`].
    pub obs: Arc<Observable>,
}

impl OwnedModel {
    /// An empty model over exactly `spec`'s outcomes, with ring stride `window_cap`.
    pub fn new(spec: &Spec, window_cap: usize) -> Self {
        OwnedModel::over(Arc::new(Observable::of(spec)), window_cap)
    }

    /// An empty model over the observable outcomes `obs`, with ring stride `window_cap`.
    pub fn over(obs: Arc<Observable>, window_cap: usize) -> Self {
        let pairs = obs.n_states * obs.n_actions;
        OwnedModel {
            window_cap,
            ring: vec![0; pairs * window_cap],
            ring_len: vec![0; pairs],
            ring_pos: vec![0; pairs],
            count: vec![0; obs.len()],
            reward: vec![0.0; obs.len()],
            terminal: vec![false; obs.len()],
            known: vec![false; obs.n_states],
            best: vec![f64::NAN; obs.n_states],
            dirty: vec![0; obs.dirty_words()],
            active_terms: 0,
            obs,
        }
    }

    /// A view usable by [`Model`]'s methods.
    pub fn view(&mut self) -> Model<'_> {
        Model {
            window_cap: self.window_cap,
            ring: &mut self.ring,
            ring_len: &mut self.ring_len,
            ring_pos: &mut self.ring_pos,
            count: &mut self.count,
            reward: &mut self.reward,
            terminal: &mut self.terminal,
            known: &mut self.known,
            best: &mut self.best,
            dirty: &mut self.dirty,
            active_terms: &mut self.active_terms,
            obs: &self.obs,
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
            crate::env::Goal {
                state: 2,
                reward: 1.0,
            },
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
            m.learn(3, 0, 0, next, 0.0, next == 2);
        }
        assert!((m.probability(0, 0) - 1.0 / 3.0).abs() < 1e-15);
        assert!((m.probability(0, 1) - 2.0 / 3.0).abs() < 1e-15);
        let row: f64 = spec.outcomes(0).map(|o| m.probability(0, o)).sum();
        assert!((row - 1.0).abs() < 1e-12);
    }

    #[test]
    fn a_transition_that_leaves_a_full_window_as_it_was_marks_nothing() {
        let spec = toy();
        let mut owned = OwnedModel::new(&spec, 2);
        let mut m = owned.view();
        m.learn(2, 0, 0, 1, 0.0, false);
        m.learn(2, 0, 0, 1, 0.0, false);
        let mut q = vec![0.0; 3];
        m.value_iteration_cached(&mut q, 0.9, 1e-9, 100);
        assert!(m.dirty.iter().all(|&w| w == 0));
        // The window is full of s1: s1 again, same reward and end, changes no term.
        m.learn(2, 0, 0, 1, 0.0, false);
        assert!(m.dirty.iter().all(|&w| w == 0));
        // Another reward for it does, and so does another outcome (after which the window
        // keeps s1, s2: T = 1/2 each).
        m.learn(2, 0, 0, 1, 2.0, false);
        assert_ne!(m.dirty[0], 0);
        m.value_iteration_cached(&mut q, 0.9, 1e-9, 100);
        m.learn(2, 0, 0, 2, 0.0, true);
        assert_ne!(m.dirty[0], 0);
        assert!((m.probability(0, 1) - 0.5).abs() < 1e-15);
    }

    #[test]
    fn reward_model_weights_the_last_reward_of_each_outcome() {
        let spec = toy();
        let mut owned = OwnedModel::new(&spec, 10);
        let mut m = owned.view();
        m.learn(10, 0, 0, 1, 5.0, false); // to s1, r 5
        m.learn(10, 0, 0, 2, 0.0, true); // to s2, r 0
        m.learn(10, 0, 0, 2, 3.0, true); // to s2, r 3 (replaces 0)
        // R = 1/3 * 5 + 2/3 * 3 = 11/3.
        assert!((m.expected_reward(0) - 11.0 / 3.0).abs() < 1e-12);
    }

    #[test]
    fn one_value_iteration_sweep_on_a_3_state_toy_matches_hand_values() {
        let spec = toy();
        let mut owned = OwnedModel::new(&spec, 10);
        let mut m = owned.view();
        m.learn(10, 0, 0, 1, 0.0, false); // 0 -> 1
        m.learn(10, 0, 0, 2, 0.0, true); // 0 -> 2 (goal, reward withheld: 0)
        m.learn(10, 1, 0, 2, 1.0, true); // 1 -> 2 (goal), r 1
        let mut q = vec![0.0; 3];
        // One sweep (max_sweeps 1): state 0 first: 0.5 * (0 + 0.9 * Q1 = 0) + 0.5 * (0 + 0) = 0;
        // then state 1: 1 * (1 + 0) = 1. ops: (2 + 1 terms) * (1 + 1) = 6.
        let report = m.value_iteration_cached(&mut q, 0.9, 1e-9, 1);
        assert_eq!(q, vec![0.0, 1.0, 0.0]);
        assert_eq!(
            report,
            ViReport {
                ops: 6,
                sweeps: 1,
                capped: true,
                changed: true,
            }
        );
        // Second sweep: Q0 = 0.5 * 0.9 * 1 = 0.45, then a sweep with no change ends it.
        let report = m.value_iteration_cached(&mut q, 0.9, 1e-9, 100);
        assert!((q[0] - 0.45).abs() < 1e-15);
        assert_eq!(report.sweeps, 2);
        assert!(!report.capped && report.changed);
        // Converged: a call changes nothing, and says so.
        let report = m.value_iteration_cached(&mut q, 0.9, 1e-9, 100);
        assert!(!report.changed);
    }

    /// Value iteration as SPEC 3.2 words it: every sweep recomputes every tried pair of every
    /// known state from live row maxima. The incremental version must match it bit for bit.
    fn value_iteration_reference(
        m: &OwnedModel,
        spec: &Spec,
        q: &mut [f64],
        gamma: f64,
        epsilon: f64,
        max_sweeps: u32,
    ) -> ViReport {
        let n_actions = spec.n_actions;
        let obs = &m.obs;
        let mut report = ViReport::default();
        loop {
            let mut delta = 0.0;
            for s in 0..spec.n_states {
                if !m.known[s] {
                    continue;
                }
                for a in 0..n_actions {
                    let sa = s * n_actions + a;
                    let kept = m.ring_len[sa];
                    if kept == 0 {
                        continue;
                    }
                    let n = f64::from(kept);
                    let mut r_sa = 0.0;
                    for o in obs.outcomes(sa) {
                        if m.count[o] > 0 {
                            r_sa += f64::from(m.count[o]) / n * m.reward[o];
                        }
                    }
                    let mut value = 0.0;
                    for o in obs.outcomes(sa) {
                        let c = m.count[o];
                        if c == 0 {
                            continue;
                        }
                        let next = obs.next_state(o);
                        let future = if m.terminal[o] {
                            0.0
                        } else {
                            max_of(&q[next * n_actions..(next + 1) * n_actions])
                        };
                        value += f64::from(c) / n * (r_sa + gamma * future);
                        report.ops += 1 + n_actions as u64;
                    }
                    delta += (value - q[sa]).abs();
                    report.changed |= value.to_bits() != q[sa].to_bits();
                    q[sa] = value;
                }
            }
            if sweep_ends(&mut report, delta, epsilon, max_sweeps) {
                break;
            }
        }
        report
    }

    /// Learns `steps` random transitions of `spec` (uniform pair, outcome drawn by its
    /// probability, reward 1 on the goal with probability `reward_prob`), calling both value
    /// iterations every `every` steps, and asserts that Q and the reports never differ.
    fn incremental_matches_reference(
        spec: &Spec,
        seed: u64,
        steps: usize,
        every: usize,
        window_n: usize,
        gamma: f64,
        epsilon: f64,
        max_sweeps: u32,
        q_init: f64,
    ) {
        use rand_core::SeedableRng;
        let mut rng = rand_xoshiro::Xoshiro256PlusPlus::seed_from_u64(seed);
        let mut u = || crate::batch::uniform(&mut rng);
        let pairs = spec.n_states * spec.n_actions;
        let mut owned = OwnedModel::new(spec, window_n);
        let mut q_inc = vec![q_init; pairs];
        let mut q_ref = q_inc.clone();
        for step in 1..=steps {
            let s = loop {
                let s = (u() * spec.n_states as f64) as usize;
                if Some(s as StateId) != spec.goal_state() {
                    break s;
                }
            };
            let a = (u() * spec.n_actions as f64) as usize;
            let o = spec.pick_outcome(spec.sa(s, a), u());
            let r = if u() < 0.5 {
                spec.arrival[o].reward
            } else {
                0.0
            };
            let next = spec.outcome_state[o];
            owned
                .view()
                .learn(window_n, s, a, next as usize, r, spec.arrival[o].terminal());
            if step % every == 0 {
                let before = q_inc.clone();
                let mut noted = vec![false; spec.n_states];
                let inc = owned.view().value_iteration_noting(
                    &mut q_inc,
                    gamma,
                    epsilon,
                    max_sweeps,
                    |s| noted[s] = true,
                );
                // The rows noted are exactly those whose values changed.
                for (s, &noted) in noted.iter().enumerate() {
                    let row = s * spec.n_actions..(s + 1) * spec.n_actions;
                    let changed = (q_inc[row.clone()].iter().zip(&before[row]))
                        .any(|(x, y)| x.to_bits() != y.to_bits());
                    assert_eq!(noted, changed, "{} step {step}: row {s}", spec.name);
                }
                assert_eq!(inc.changed, noted.contains(&true));
                let reference =
                    value_iteration_reference(&owned, spec, &mut q_ref, gamma, epsilon, max_sweeps);
                assert_eq!(inc, reference, "{} step {step}: reports differ", spec.name);
                for (i, (x, y)) in q_inc.iter().zip(&q_ref).enumerate() {
                    assert_eq!(
                        x.to_bits(),
                        y.to_bits(),
                        "{} step {step}: Q[{i}] {x} != {y}",
                        spec.name
                    );
                }
            }
        }
    }

    #[test]
    fn incremental_value_iteration_equals_full_sweeps_bit_for_bit() {
        let tidy1 = crate::env::load("tidy1").unwrap();
        let tidy2 = crate::env::load("tidy2").unwrap();
        let grid = crate::env::grid::build(30).unwrap();
        for (seed, spec) in [(1, &tidy1), (2, &tidy2), (3, &grid)] {
            // The defaults, VI after every step.
            incremental_matches_reference(spec, seed, 3000, 1, 10, 0.95, 0.01, 10_000, 0.0);
            // Sparse calls (as EC makes them), a short window, q_init 1, tight epsilon.
            incremental_matches_reference(spec, seed + 10, 3000, 7, 3, 0.9, 1e-9, 10_000, 1.0);
            // Calls stopped by the sweep cap leave pairs to finish in later calls.
            incremental_matches_reference(spec, seed + 20, 2000, 3, 5, 0.99, 1e-12, 2, 0.5);
        }
    }

    #[test]
    fn forgetting_the_cache_makes_an_externally_changed_q_safe() {
        let spec = crate::env::grid::build(20).unwrap();
        let mut owned = OwnedModel::new(&spec, 10);
        for (s, a) in [
            (0, 1),
            (1, 2),
            (5, 2),
            (6, 1),
            (7, 2),
            (12, 2),
            (13, 2),
            (18, 1),
        ] {
            let sa = spec.sa(s, a);
            let next = spec.outcome_state[spec.outcomes(sa).start] as usize;
            let terminal = spec.arrival[spec.outcomes(sa).start].terminal();
            owned.view().learn(10, s, a, next, 1.0, terminal);
        }
        let mut q = vec![0.0; spec.n_states * spec.n_actions];
        owned
            .view()
            .value_iteration_cached(&mut q, 0.95, 1e-9, 1000);
        // Change Q behind the cache's back, then forget the cache.
        q.iter_mut().for_each(|v| *v = 0.25);
        let mut q_ref = q.clone();
        let mut m = owned.view();
        m.forget_row_maxima();
        let inc = m.value_iteration_cached(&mut q, 0.95, 1e-9, 1000);
        let reference = value_iteration_reference(&owned, &spec, &mut q_ref, 0.95, 1e-9, 1000);
        assert_eq!(inc, reference);
        assert_eq!(q, q_ref);
    }

    #[test]
    fn the_dirty_set_holds_exactly_the_pairs_marked_and_no_padding() {
        for n_pairs in [1usize, 63, 64, 65, 128, 130] {
            let mut words = vec![0u64; n_pairs.div_ceil(64)];
            let mut set = DirtySet::new(&mut words, n_pairs);
            set.mark_all();
            let all: Vec<usize> =
                std::iter::successors(set.next_from(0), |&sa| set.next_from(sa + 1)).collect();
            assert_eq!(all, (0..n_pairs).collect::<Vec<_>>(), "{n_pairs} pairs");
            for sa in 0..n_pairs {
                set.clear(sa);
            }
            assert_eq!(set.next_from(0), None);
            set.mark(n_pairs - 1);
            set.mark(0);
            assert_eq!(set.next_from(0), Some(0));
            assert_eq!(set.next_from(1), Some(n_pairs - 1).filter(|&x| x >= 1));
        }
    }

    #[test]
    fn predecessors_list_every_pair_that_can_reach_a_state() {
        let spec = toy();
        let obs = Observable::of(&spec);
        let preds = obs.preds();
        assert_eq!(preds.of(0), &[] as &[u32]);
        assert_eq!(preds.of(1), &[0]);
        assert_eq!(preds.of(2), &[0, 1, 2]);
    }

    #[test]
    fn observable_outcomes_are_the_union_of_the_worlds_plus_the_extra_ones() {
        let spec = toy();
        // Another world of the same spaces where 1 -> 0, and an extra outcome 2 -> 1.
        let other = Spec::from_outcomes(
            "other".into(),
            3,
            1,
            vec![vec![(2, 1.0)], vec![(0, 1.0)], vec![(2, 1.0)]],
            vec![0],
            crate::env::Goal {
                state: 2,
                reward: 1.0,
            },
            vec!["a".into(), "b".into(), "g".into()],
            None,
        );
        let obs = Observable::union([&spec, &other], [(2, 1)]);
        let next =
            |sa: usize| -> Vec<usize> { obs.outcomes(sa).map(|o| obs.next_state(o)).collect() };
        assert_eq!(next(0), vec![1, 2]);
        assert_eq!(next(1), vec![0, 2]);
        assert_eq!(next(2), vec![1, 2]);
        assert_eq!(obs.len(), 6);
        assert_eq!(obs.find(1, 2), 3);
        assert_eq!(obs.preds().of(0), &[1]);
        assert_eq!(obs.preds().of(1), &[0, 2]);
        // Without extra worlds the table is the spec's own, index for index.
        let own = Observable::of(&spec);
        assert_eq!(own.len(), spec.outcome_state.len());
        for o in 0..own.len() {
            assert_eq!(own.next_state(o), spec.outcome_state[o] as usize);
        }
    }
}
