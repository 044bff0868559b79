//! Lanes = runs: a group of [`L`] runs of the batch stepped together, so that the per-action
//! arithmetic of the decision (the averaged distribution's entropy, the softmax, the moving
//! average) runs on `[f64; L]` arrays, one element per run, which LLVM turns into vector
//! instructions (4 doubles per AVX2 instruction where the CPU has it, 2 per SSE2 one otherwise).
//!
//! Bit-identity with the one-run step ([`super::step`]) is the contract: every lane performs the
//! same floating-point operations in the same order as the scalar code on its own run, and draws
//! from its own run's random stream in the same order, so a run's results do not depend on
//! whether it was stepped alone or in a group, nor on which runs shared its group. Everything
//! where runs diverge (reset steps, the inference cost, the action draw, the environment,
//! learning, checkpoints) is the scalar code, called lane by lane.
//!
//! Lane groups are formed only for runs without anything human (no schedule, no interaction,
//! the environment's reward) whose controller is `mf`, on environments with [`GROUP_ACTIONS`]
//! actions; the others, and what is left of a batch after its groups, take the one-run step.

use std::array::from_fn;

use super::step::{self, MF};
use super::{RunView, initial_state, uniform};
use crate::env::Spec;
use crate::expert::{draw, normalise_bits};
use crate::meta::Choice;
use crate::params::{Controller, Params};

/// Runs per lane group: 4 doubles fill an AVX2 register.
pub(super) const L: usize = 4;

/// The action count lane groups are compiled for (the tidy tasks'); rows of a length known at
/// compile time make the per-action loops straight-line code.
pub(super) const GROUP_ACTIONS: usize = 7;

/// One value per lane.
type Lanes = [f64; L];

/// What runs must share to be stepped in one group: the same loop structure (controller, step
/// counts, checkpoint interval) and the same position in it. Per-run parameters (`tau`, the
/// filter, the learning rates) may differ: each lane reads its own.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(super) struct GroupKey {
    controller: Controller,
    babbling: u32,
    steps: u32,
    checkpoint: u32,
    t: u64,
}

/// The key under which `run` can join a lane group, or `None` when it must take the one-run
/// step.
pub(super) fn group_key(spec: &Spec, params: &Params, run: &RunView<'_>) -> Option<GroupKey> {
    let eligible = spec.n_actions == GROUP_ACTIONS
        && params.controller == Controller::Mf
        && !step::human_can_act(params, run);
    eligible.then_some(GroupKey {
        controller: params.controller,
        babbling: params.babbling,
        steps: params.steps,
        checkpoint: params.checkpoint,
        t: run.cursor.t,
    })
}

/// Advances a group of runs with equal [`GroupKey`]s until their `cursor.t` reaches `end` (or
/// they end), with AVX2 where the CPU has it.
pub(super) fn run_group_until(
    spec: &Spec,
    params: [&Params; L],
    window_cap: usize,
    runs: &mut [RunView<'_>; L],
    end: u64,
) {
    #[cfg(target_arch = "x86_64")]
    if std::is_x86_feature_detected!("avx2") {
        // SAFETY: the CPU supports AVX2, checked just above.
        unsafe { group_avx2(spec, params, window_cap, runs, end) };
        return;
    }
    group(spec, params, window_cap, runs, end);
}

/// [`group`] compiled for AVX2. The crate targets baseline x86-64 (SSE2), so the wider
/// registers are used only when detected at run time. Results are the same either way: no
/// fused multiply-add is enabled, and Rust never contracts `a * b + c` on its own.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
fn group_avx2(
    spec: &Spec,
    params: [&Params; L],
    window_cap: usize,
    runs: &mut [RunView<'_>; L],
    end: u64,
) {
    group(spec, params, window_cap, runs, end);
}

/// [`run_group_until`] for the group's controller.
#[inline(always)]
fn group(
    spec: &Spec,
    params: [&Params; L],
    window_cap: usize,
    runs: &mut [RunView<'_>; L],
    end: u64,
) {
    debug_assert!(spec.n_actions == GROUP_ACTIONS);
    match params[0].controller {
        Controller::Mf => group_loop::<MF, GROUP_ACTIONS>(spec, params, window_cap, runs, end),
        _ => unreachable!("group_key admits only mf"),
    }
}

/// The lanes' per-run parameters that the vector arithmetic reads.
struct LaneParams {
    tau: Lanes,
    filter_alpha: Lanes,
}

/// `run_loop` of the one-run step for a group: babbling, the reset that ends it, then the
/// experiment with its checkpoint rows, the loops shared by the lanes (their keys are equal).
#[inline(always)]
fn group_loop<const KIND: u8, const NA: usize>(
    spec: &Spec,
    params: [&Params; L],
    window_cap: usize,
    runs: &mut [RunView<'_>; L],
    end: u64,
) {
    let per_lane = LaneParams {
        tau: params.map(|p| p.tau),
        filter_alpha: params.map(|p| p.filter_alpha),
    };
    let first = params[0];
    let babbling = u64::from(first.babbling);
    let end = end.min(babbling + u64::from(first.steps));
    let babble_end = end.min(babbling);
    let t = runs[0].cursor.t;
    debug_assert!(runs.iter().all(|r| r.cursor.t == t));
    if t < babble_end {
        for _ in t..babble_end {
            group_step::<KIND, NA, true>(spec, &params, &per_lane, window_cap, runs, 0);
        }
        if babble_end == babbling {
            // End of babbling: back to the start; a pending reset step is dropped (SPEC 7).
            for run in runs.iter_mut() {
                run.cursor.pending_reset = false;
                run.cursor.state = initial_state(spec, run.rng);
            }
        }
    }
    let t = runs[0].cursor.t;
    if t >= end {
        return;
    }
    let mut t_exp = (t - babbling) as u32;
    let last = first.steps;
    let every = first.checkpoint;
    let next_row = |t: u32| {
        t.checked_div(every)
            .map_or(u32::MAX, |k| (k + 1).saturating_mul(every).min(last))
    };
    let mut row_at = next_row(t_exp);
    for _ in t..end {
        t_exp += 1;
        group_step::<KIND, NA, false>(spec, &params, &per_lane, window_cap, runs, t_exp);
        if t_exp == row_at {
            for run in runs.iter_mut() {
                step::record_checkpoint(run, t_exp);
            }
            row_at = next_row(t_exp);
        }
    }
}

/// One step of every lane (SPEC 3.4) at experiment step `t_exp` (0 while babbling): the reset
/// steps lane by lane, then for the deciding lanes the MC's entropy, the softmax and the moving
/// average in lanes, then the rest of the step lane by lane.
#[inline(always)]
fn group_step<const KIND: u8, const NA: usize, const BABBLING: bool>(
    spec: &Spec,
    params: &[&Params; L],
    per_lane: &LaneParams,
    window_cap: usize,
    runs: &mut [RunView<'_>; L],
    t_exp: u32,
) {
    let mut s = [0usize; L];
    let mut deciding = [false; L];
    for (l, run) in runs.iter_mut().enumerate() {
        s[l] = run.cursor.state as usize;
        run.cursor.t += 1;
        if run.cursor.pending_reset {
            // 1. The reset step: time passes, nothing is decided or learned (SPEC 2.1).
            run.cursor.pending_reset = false;
            run.cursor.state = initial_state(spec, run.rng);
        } else {
            deciding[l] = true;
        }
    }
    if !any(deciding) {
        return;
    }

    // The lanes' rows, transposed to one `Lanes` per action. A resetting lane's row is read too
    // (its state is valid) but nothing computed from it is written.
    let pavg = transpose::<NA>(from_fn(|l| row::<NA>(runs[l].pavg_mf, s[l])));
    let q = transpose::<NA>(from_fn(|l| row::<NA>(runs[l].q_mf, s[l])));

    // 3. Selection: MF controls; the entropy of its averaged distribution, as stored before this
    // step, is only reported (not while babbling).
    let bits = if BABBLING {
        [0.0; L]
    } else {
        entropy_bits(&pavg)
    };
    // 5. The MF softmax (no human: no bonus) and its moving average.
    let p = softmax(&q, per_lane.tau);
    let averaged: [Lanes; NA] = from_fn(|i| ema(pavg[i], p[i], per_lane.filter_alpha));

    for l in 0..L {
        if !deciding[l] {
            continue;
        }
        let (run, params, s) = (&mut runs[l], params[l], s[l]);
        let choice = Choice {
            use_mb: false,
            p_mb: 0.0,
            chosen_entropy: normalise_bits(bits[l], NA),
        };
        // 4. Inference (the cost average; MF inference is reading the row, done above).
        let (cost_mf, cost_mb) = step::infer::<KIND, NA>(spec, params, run, s, choice.use_mb);
        let avg = &mut run.pavg_mf[s * NA..(s + 1) * NA];
        for (i, a) in avg.iter_mut().enumerate() {
            *a = averaged[i][l];
        }
        let p_lane: [f64; NA] = from_fn(|i| p[i][l]);
        let a = draw(&p_lane, uniform(run.rng));
        step::record_decision::<BABBLING>(run, &choice, cost_mf, cost_mb);
        let at = (s, a, t_exp);
        step::after_decision::<KIND, false, NA, BABBLING>(spec, params, window_cap, run, at, false);
    }
}

/// A value per lane, from `f(lane)`. A plain indexed loop (rather than `array::from_fn`) is what
/// LLVM turns into vector instructions most reliably.
#[inline(always)]
fn lanes(f: impl Fn(usize) -> f64) -> Lanes {
    let mut out = [0.0; L];
    for (l, o) in out.iter_mut().enumerate() {
        *o = f(l);
    }
    out
}

/// A condition per lane, from `f(lane)`.
#[inline(always)]
fn mask(f: impl Fn(usize) -> bool) -> [bool; L] {
    let mut out = [false; L];
    for (l, o) in out.iter_mut().enumerate() {
        *o = f(l);
    }
    out
}

/// Whether any lane's condition holds (an unrolled OR, not a search loop).
#[inline(always)]
fn any(m: [bool; L]) -> bool {
    let mut a = false;
    for &m in &m {
        a |= m;
    }
    a
}

/// Row `s` of a run's `[state, action]` table.
#[inline(always)]
fn row<const NA: usize>(table: &[f64], s: usize) -> &[f64; NA] {
    table[s * NA..(s + 1) * NA]
        .try_into()
        .expect("rows of NA actions")
}

/// One `Lanes` per action from one row per lane.
#[inline(always)]
fn transpose<const NA: usize>(rows: [&[f64; NA]; L]) -> [Lanes; NA] {
    let mut out = [[0.0; L]; NA];
    for (i, o) in out.iter_mut().enumerate() {
        *o = lanes(|l| rows[l][i]);
    }
    out
}

/// `exp` of the lanes where `need` is set (the others' results are unspecified). Every
/// exponential of the lane kernels goes through here: with the C library's scalar `exp`, lane by
/// lane, only where needed.
#[inline(always)]
fn exp_lanes(x: Lanes, need: [bool; L]) -> Lanes {
    lanes(|l| if need[l] { x[l].exp() } else { 0.0 })
}

/// `log2` of the lanes where `need` is set (the others' results are unspecified). Every
/// logarithm of the lane kernels goes through here, as [`exp_lanes`] for `exp`.
#[inline(always)]
fn log2_lanes(x: Lanes, need: [bool; L]) -> Lanes {
    lanes(|l| if need[l] { x[l].log2() } else { 0.0 })
}

/// `crate::expert::ema` in lanes: `(1 - alpha) * old + alpha * new`.
#[inline(always)]
fn ema(old: Lanes, new: Lanes, alpha: Lanes) -> Lanes {
    lanes(|l| (1.0 - alpha[l]) * old[l] + alpha[l] * new[l])
}

/// `crate::expert::entropy_bits` of each lane's distribution (given by action), with the same
/// operations in the same order: `h -= x log2 x` over the positive probabilities, then `max(0)`.
#[inline(always)]
fn entropy_bits<const NA: usize>(p: &[Lanes; NA]) -> Lanes {
    let mut h = [0.0; L];
    let mut memo = RecentLanes::new();
    for x in p {
        let positive = mask(|l| x[l] > 0.0);
        let term = memo.get_or(*x, positive, |x, need| {
            let log = log2_lanes(x, need);
            lanes(|l| x[l] * log[l])
        });
        h = lanes(|l| if positive[l] { h[l] - term[l] } else { h[l] });
    }
    lanes(|l| h[l].max(0.0))
}

/// `crate::expert::softmax_biased` of each lane's row (given by action) without a bonus, with
/// the same operations in the same order: `q + 0` (the scalar code's `bonus * g` is +0 without a
/// human, which turns a -0 into +0), the maximum, `(v - max) / tau`, `exp` (1 for 0), the sum in
/// action order and the division by it.
#[inline(always)]
fn softmax<const NA: usize>(q: &[Lanes; NA], tau: Lanes) -> [Lanes; NA] {
    let mut biased = [[0.0; L]; NA];
    let mut max = [f64::NEG_INFINITY; L];
    for (b, q) in biased.iter_mut().zip(q) {
        *b = lanes(|l| q[l] + 0.0);
        max = lanes(|l| max[l].max(b[l]));
    }
    let mut memo = RecentLanes::new();
    let mut sum = [0.0; L];
    let mut e = [[0.0; L]; NA];
    for (e, b) in e.iter_mut().zip(&biased) {
        let x = lanes(|l| (b[l] - max[l]) / tau[l]);
        let nonzero = mask(|l| x[l] != 0.0);
        let value = memo.get_or(x, nonzero, exp_lanes);
        *e = lanes(|l| if nonzero[l] { value[l] } else { 1.0 });
        sum = lanes(|l| sum[l] + e[l]);
    }
    for e in &mut e {
        *e = lanes(|l| e[l] / sum[l]);
    }
    e
}

/// The lanes' form of the scalar code's memo (`Recent`): per lane, the results of a pure
/// function for the last two distinct arguments, so repeated values in a row (untried actions,
/// uniform averages) cost no call. A memo never changes a value, only whether it is computed;
/// the function is called, for the lanes that miss, only when some lane misses.
///
/// Arguments are compared as numbers, not bits: the wanted ones are never zero and a NaN never
/// matches, and two other doubles that compare equal have the same bits.
struct RecentLanes {
    keys: [Lanes; 2],
    values: [Lanes; 2],
}

impl RecentLanes {
    /// Nothing remembered. The empty slots hold 0.0, which no caller wants.
    #[inline(always)]
    fn new() -> RecentLanes {
        RecentLanes {
            keys: [[0.0; L]; 2],
            values: [[0.0; L]; 2],
        }
    }

    /// `f(x)` in the lanes where `wanted` (the others' results are unspecified), from memory
    /// where a lane's argument is one of its last two; `f` gets the lanes it must compute.
    #[inline(always)]
    fn get_or(
        &mut self,
        x: Lanes,
        wanted: [bool; L],
        f: impl Fn(Lanes, [bool; L]) -> Lanes,
    ) -> Lanes {
        let [k0, k1] = self.keys;
        let [v0, v1] = self.values;
        let remembered = lanes(|l| if x[l] == k0[l] { v0[l] } else { v1[l] });
        let need = mask(|l| wanted[l] && x[l] != k0[l] && x[l] != k1[l]);
        if !any(need) {
            return remembered;
        }
        let fresh = f(x, need);
        self.keys = [
            lanes(|l| if need[l] { x[l] } else { k0[l] }),
            lanes(|l| if need[l] { k0[l] } else { k1[l] }),
        ];
        self.values = [
            lanes(|l| if need[l] { fresh[l] } else { v0[l] }),
            lanes(|l| if need[l] { v0[l] } else { v1[l] }),
        ];
        lanes(|l| if need[l] { fresh[l] } else { remembered[l] })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::expert::{entropy_bits as scalar_entropy, softmax_biased};

    /// Rows with repeats, zeros, signed zeros, tiny and huge values, one per lane.
    fn rows() -> [[f64; GROUP_ACTIONS]; L] {
        [
            [0.0, 0.0, 0.1, 0.1, 0.0, -0.0, 0.05],
            [1e300, -1e300, 5.0, 5.0, 5.0, 0.0, 1e-300],
            [-0.0, -0.0, -0.0, -0.0, -0.0, -0.0, -0.0],
            [0.3, 0.2, 0.1, 0.0, -0.1, 0.2, 0.3],
        ]
    }

    #[test]
    fn softmax_lanes_equal_the_scalar_softmax_bit_for_bit() {
        let rows = rows();
        let tau = [0.1, 1e-6, 0.02, 3.0];
        let p = softmax(&transpose(from_fn(|l| &rows[l])), tau);
        for l in 0..L {
            let mut want = [0.0; GROUP_ACTIONS];
            softmax_biased(&rows[l], &[0; GROUP_ACTIONS], 0.0, tau[l], &mut want);
            for i in 0..GROUP_ACTIONS {
                assert_eq!(p[i][l].to_bits(), want[i].to_bits(), "lane {l}, action {i}");
            }
        }
    }

    #[test]
    fn entropy_lanes_equal_the_scalar_entropy_bit_for_bit() {
        let mut rows = rows().map(|r| {
            let mut p = [0.0; GROUP_ACTIONS];
            softmax_biased(&r, &[0; GROUP_ACTIONS], 0.0, 0.05, &mut p);
            p
        });
        rows[2] = [1.0 / 7.0; GROUP_ACTIONS];
        rows[3] = [0.5, 0.25, 0.0, 0.25, 0.0, 0.0, 0.0];
        let h = entropy_bits(&transpose(from_fn(|l| &rows[l])));
        for l in 0..L {
            assert_eq!(
                h[l].to_bits(),
                scalar_entropy(&rows[l]).to_bits(),
                "lane {l}"
            );
        }
        assert_eq!(h[3], 1.5);
    }
}
