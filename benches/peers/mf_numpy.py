"""Peer: MF alone on tidy1 in numpy, vectorised across runs (batch = runs, arrays [B, S, A]).

Per decision, as SPEC 3.1, 3.3, 3.4 and 7 say: softmax of the MF's Q row (tau = 0.02, the maximum
subtracted), a draw, the per-state averaged distribution (filter_alpha 0.6) and its normalised
base-2 entropy (read before the fold, as the MC reads it; summed so it is really computed),
Q-learning (alpha 0.6, gamma 0.9, the goal terminal). The step after arriving in the goal is the
reset step (back to the start, nothing decided or learned). 1,000 babbling steps with reward
withheld, then a reset to the start, then the experiment.

float32 throughout (for speed: half the memory traffic of float64, and numpy's SIMD exp and log are
faster in float32; Q values stay in [0, 1], so nothing underflows at tau = 0.02).

Reset lanes are masked, not compacted: their softmax and draw are computed and discarded.

  python mf_numpy.py [--runs B] [--steps N] [--babbling N] [--seed S] [--check] [--json]
"""


import numpy as np

import tidy1

DT = np.float32
TAU, ALPHA, GAMMA, FILTER = 0.02, 0.6, 0.9, 0.6
CHUNK = 250  # uniforms drawn per call of the generator, [CHUNK, B]
TINY = np.finfo(DT).tiny


def simulate(n_runs, steps, babbling, seed, last=500):
    """Runs the batch; returns per-run (reward over the last `last` steps, total reward,
    decisions, mean normalised entropy of the averaged distribution)."""
    nxt, goal, _ = tidy1.build()
    n_s, n_a = nxt.shape
    w = 8  # rows padded to 8 columns: Q = -inf and probability 0 in the pad, never drawn
    nxt_flat = nxt.reshape(-1)
    rng = np.random.default_rng(seed)
    q = np.zeros((n_runs * n_s, w), DT)  # [B, S, A] flattened to rows b * S + s
    q[:, n_a:] = -np.inf
    pavg = np.zeros((n_runs * n_s, w), DT)
    pavg[:, :n_a] = 1.0 / n_a
    qf = q.reshape(-1)
    # Rows of 8 float32 seen as 32-byte items: numpy scatters whole items much faster than rows.
    pavg_rows = pavg.view(np.dtype((np.void, 4 * w))).reshape(-1)
    base = np.arange(n_runs, dtype=np.int64) * n_s
    state = np.zeros(n_runs, np.int64)
    inv_tau = DT(1.0 / TAU)
    alpha, gamma, filt = DT(ALPHA), DT(GAMMA), DT(FILTER)
    # Row sums, cumulative sums and the entropy's sum as small matrix products (BLAS): numpy's
    # reductions along a short last axis cost far more per element than a product.
    ones = np.ones(w, DT)
    upper = np.triu(np.ones((w, w), DT))
    to_bits = ones / DT(np.log(2.0))
    reward_last = np.zeros(n_runs, DT)
    reward_total = np.zeros(n_runs, DT)
    decisions = np.zeros(n_runs, np.int64)
    entropy_sum = np.zeros(n_runs, DT)
    total = babbling + steps
    u_block = None
    for t in range(total):
        k = t % CHUNK
        if k == 0:
            u_block = rng.random((CHUNK, n_runs), dtype=DT)
        experiment = t >= babbling
        t_exp = t - babbling + 1
        row = base + state
        decide = state != goal  # the reset step decides and learns nothing
        qs = q.take(row, axis=0)  # [B, 8]
        m = np.maximum(qs[:, 0], qs[:, 1])
        for c in range(2, n_a):
            np.maximum(m, qs[:, c], out=m)
        e = qs - m[:, None]
        e *= inv_tau
        np.exp(e, out=e)
        cum = e @ upper
        total_e = cum[:, w - 1]
        p = e / total_e[:, None]
        # Draw: the number of cumulative weights below u * sum (a byte per action, counted as bits).
        below = cum < (u_block[k] * total_e)[:, None]
        action = np.bitwise_count(below.view(np.uint64)).reshape(n_runs).astype(np.int64)
        np.minimum(action, n_a - 1, out=action)
        # Averaged distribution of this state: its entropy as read before the fold, then the fold.
        pa = pavg.take(row, axis=0)
        h = (pa * np.log(np.maximum(pa, TINY))) @ to_bits  # -H in bits; 0 log 0 = 0
        d = decide.astype(DT)
        p -= pa
        p *= (filt * d)[:, None]
        p += pa
        pavg_rows[row] = p.view(pavg_rows.dtype).reshape(-1)  # (1 - a) * old + a * new where deciding
        # Environment, reward, Q-learning.
        sa = state * n_a + action
        nxt_s = np.where(decide, nxt_flat[sa], 0)
        terminal = nxt_s == goal
        qn = q.take(base + nxt_s, axis=0)
        future = np.maximum(qn[:, 0], qn[:, 1])
        for c in range(2, n_a):
            np.maximum(future, qn[:, c], out=future)
        future[terminal] = 0
        r = terminal.astype(DT) if experiment else np.zeros(n_runs, DT)
        idx = row * w + action
        qsa = qf[idx]
        qf[idx] = qsa + (alpha * d) * (r + gamma * future - qsa)
        state = nxt_s
        if experiment:
            reward_total += r
            decisions += decide
            entropy_sum -= h * d
            if t_exp > steps - last:
                reward_last += r
        if t == babbling - 1:
            state = np.zeros(n_runs, np.int64)  # end of babbling: back to the start
    mean_h = entropy_sum / DT(np.log2(n_a)) / np.maximum(decisions, 1)
    return reward_last, reward_total, decisions, mean_h


def main():
    args = tidy1.arguments(__doc__, runs=512).parse_args()
    out, seconds, cpu_seconds = tidy1.timed(lambda: simulate(args.runs, args.steps, args.babbling, args.seed))
    last, tot, dec, mean_h = out
    agent_steps = args.runs * (args.babbling + args.steps)
    if args.json:
        tidy1.print_timing("numpy-mf", seconds, cpu_seconds, agent_steps, last.mean())
        return
    nxt, goal, _ = tidy1.build()
    print(f"tidy1: {nxt.shape[0]} states, goal {goal}; {tidy1.check_against_authors_format(nxt, goal)}")
    print(f"numpy MF ({np.dtype(DT).name}): {args.runs} runs x ({args.babbling} + {args.steps}) steps "
          f"in {seconds:.2f} s = {agent_steps / seconds:,.0f} agent-steps/s")
    print(f"  reward over the last 500 steps, mean per run: {last.mean():.2f} (sd {last.std():.2f}); "
          f"total {tot.mean():.1f}; decisions {dec.mean():.0f}; mean entropy {mean_h.mean():.3f}")
    if args.check:
        import tempfile

        out = tidy1.run_mbmf("mf", args.runs, args.steps, args.babbling, tempfile.mkdtemp(prefix="peers-mf-"))
        ref, table = tidy1.mbmf_last(out, args.steps)
        ref_dec = np.mean(table["decisions"])
        ref_h = np.mean(table["mean_entropy_chosen"])
        print(f"  mbmf: last 500 steps {ref.mean():.2f} (sd {ref.std():.2f}); total "
              f"{np.mean(table['total_reward']):.1f}; decisions {ref_dec:.0f}; mean entropy {ref_h:.3f}")
        tidy1.print_verdict(last.mean(), ref.mean())


if __name__ == "__main__":
    main()
