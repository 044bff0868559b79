"""Peer: EC (entropy and cost, SPEC 4) on tidy1 in numpy, vectorised across runs (float64, except
the MB's Q, T and R, float32).

Both experts, as SPEC 3, 4 and 6 say:
- MF: Q-learning (alpha 0.6, gamma 0.9); inference reads its row (cost 7 `ops`).
- MB: a windowed model per (s, a) (ring of the last N = 10 outcomes, T = count / kept, the last
  reward per outcome, R(s,a) = sum T r), value iteration warm-started from the previous Q (gamma
  0.95, the goal terminal) repeated until a sweep's summed |dQ| < 0.01, *vectorised across the
  runs that infer at this step*: each sweep updates every pair of every such run at once, and a
  run leaves the loop when its own sweep converged. Cost `ops` = sweeps x (terms with T > 0) x
  (1 + |A|), as SPEC 6 charges a full sweep.
- MC: per state, each expert's averaged distribution (filter_alpha 0.6) and its normalised entropy
  H, the per-state moving average of each expert's inference cost (normalised by the larger),
  kappa = exp(-9 * H_MF in bits), values -(H + kappa C), a softmax over the two (tau 0.02) and a
  draw; both experts infer at the first decision in a state (babbling included); the unselected
  expert does not infer; both compute their softmax, fold it into their averages and learn.
- The reset step after the goal, 1,000 babbling steps with reward withheld, then the experiment.

One difference from mbmf, on purpose (the vectorisable form): the sweeps are synchronous (each
reads the previous sweep's Q, a Jacobi iteration) where SPEC 3.2 sweeps in place in ascending
state order (Gauss-Seidel). The fixed point is the same; the number of sweeps per call, and so the
MB's `ops` cost, can differ a little (the output prints both means).

  python ec_numpy.py [--runs B] [--steps N] [--babbling N] [--seed S] [--check] [--json]
"""


import numpy as np

import tidy1

TAU, ALPHA_MF, GAMMA_MF, GAMMA_MB, FILTER = 0.02, 0.6, 0.9, 0.95, 0.6
WINDOW_N, VI_EPSILON, VI_MAX_SWEEPS, KAPPA_COEFF, TINY_COST = 10, 0.01, 10000, 9.0, 1e-12
CHUNK = 250
# The MB's Q, T and R in float32: value iteration streams them at every MB inference, and half
# the bytes is a quarter less time; everything else is float64.
VI_DT = np.float32


def rowmax(x, out=None):
    """Maximum of each row of a [B, A] array (a chain over columns: faster than axis=1)."""
    m = np.maximum(x[:, 0], x[:, 1], out=out)
    for c in range(2, x.shape[1]):
        np.maximum(m, x[:, c], out=m)
    return m


def softmax_rows(qs, ones):
    """Softmax of each row with temperature TAU, the row maximum subtracted."""
    e = qs - rowmax(qs)[:, None]
    e *= 1.0 / TAU
    np.exp(e, out=e)
    e /= (e @ ones)[:, None]
    return e


def bits(p, ones):
    """Base-2 entropy of each row, 0 log 0 = 0."""
    return -((p * np.log2(np.maximum(p, 1e-300))) @ ones)


def simulate(n_runs, steps, babbling, seed, last=500):
    tidy1.keep_freed_memory()
    nxt, goal, _ = tidy1.build()
    n_s, n_a = nxt.shape
    n_sa = n_s * n_a
    nxt_flat = nxt.reshape(-1)
    # The environment's outcomes, one per pair in tidy1 (deterministic): outcome index = pair
    # index, next state nxt_flat. The model below is nevertheless the windowed one of SPEC 3.2.
    # The MB's arrays index a run's pairs action-major (a * S + s), so that the row maxima of
    # value iteration reduce over contiguous rows of S values.
    nxt_pairs = nxt.T.reshape(-1)
    gamma_future = (GAMMA_MB * (nxt_pairs != goal)).astype(VI_DT)  # the goal contributes no future value
    a_stride = np.arange(n_a) * n_s
    rng = np.random.default_rng(seed)
    ones = np.ones(n_a)
    upper = np.triu(np.ones((n_a, n_a)))
    log2_a = np.log2(n_a)
    base = np.arange(n_runs) * n_s
    runs_sa = np.arange(n_runs) * n_sa

    q_mf = np.zeros((n_runs * n_s, n_a))
    q_mb = np.zeros((n_runs, n_sa), VI_DT)
    q_mb_f = q_mb.reshape(-1)
    pavg_mf = np.full((n_runs * n_s, n_a), 1.0 / n_a)
    pavg_mb = np.full((n_runs * n_s, n_a), 1.0 / n_a)
    cost_mf = np.zeros(n_runs * n_s)
    cost_mb = np.zeros(n_runs * n_s)
    visited = np.zeros(n_runs * n_s, bool)
    # Windowed model: ring of local outcome indices per pair, its length and cursor; per outcome
    # its count in the window and last reward; per pair T (of its one outcome) and R.
    ring = np.zeros((n_runs, n_sa, WINDOW_N), np.int8)
    ring_len = np.zeros((n_runs, n_sa), np.int64)
    ring_pos = np.zeros((n_runs, n_sa), np.int64)
    count = np.zeros((n_runs, n_sa), np.int64)
    last_r = np.zeros((n_runs, n_sa))
    t_model = np.zeros((n_runs, n_sa), VI_DT)
    r_model = np.zeros((n_runs, n_sa), VI_DT)
    active_terms = np.zeros(n_runs, np.int64)
    ring_f, ring_len_f, ring_pos_f, count_f = (x.reshape(-1) for x in (ring, ring_len, ring_pos, count))
    last_r_f, t_model_f, r_model_f = (x.reshape(-1) for x in (last_r, t_model, r_model))
    state = np.zeros(n_runs, np.int64)

    st = {k: np.zeros(n_runs) for k in ("reward_last", "reward", "cost_mf", "cost_mb", "decisions",
                                        "mb_decisions", "p_mb_sum", "vi_calls", "vi_sweeps")}

    def value_iteration(idx):
        """In-place VI of the runs `idx` (synchronous sweeps); returns the sweeps of each."""
        qa, ta, ra = q_mb[idx], t_model[idx], r_model[idx]
        pos = np.arange(idx.size)
        sweeps = np.zeros(idx.size, np.int64)
        while pos.size:
            v = qa.reshape(-1, n_a, n_s).max(axis=1)  # [runs, S]: contiguous rows, fast
            new = v[:, nxt_pairs]
            new *= gamma_future
            new *= ta
            new += ra
            delta = np.abs(new - qa).sum(axis=1)
            qa = new
            sweeps[pos] += 1
            done = (delta < VI_EPSILON) | np.isnan(delta) | (sweeps[pos] >= VI_MAX_SWEEPS)
            if done.any():
                q_mb[idx[pos[done]]] = qa[done]
                keep = ~done
                qa, ta, ra, pos = qa[keep], ta[keep], ra[keep], pos[keep]
        return sweeps

    u_block = None
    for t in range(babbling + steps):
        k = t % CHUNK
        if k == 0:
            u_block = rng.random((CHUNK, 2, n_runs))
        experiment = t >= babbling
        u_mc, u_act = u_block[k]
        row = base + state
        dec = state != goal  # the reset step decides, infers and learns nothing

        # 3. MC, from what earlier visits stored.
        pm, pb = pavg_mf[row], pavg_mb[row]
        bits_mf, bits_mb = bits(pm, ones), bits(pb, ones)
        h_mf = np.clip(bits_mf / log2_a, 0.0, 1.0)
        h_mb = np.clip(bits_mb / log2_a, 0.0, 1.0)
        kappa = np.exp(-KAPPA_COEFF * bits_mf)
        cm, cb = cost_mf[row], cost_mb[row]
        scale = np.maximum(cm, cb)
        scale[scale <= 0] = TINY_COST
        v_mf = -(h_mf + kappa * cm / scale)
        v_mb = -(h_mb + kappa * cb / scale)
        with np.errstate(over="ignore"):
            p_mb = 1.0 / (1.0 + np.exp((v_mf - v_mb) / TAU))
        use_mb = u_mc < p_mb

        # 4. Inference: the chosen expert, both at the first decision in a state.
        first = ~visited[row]
        visited[row] |= dec
        inf_mf = dec & (~use_mb | first)
        inf_mb = dec & (use_mb | first)
        cost_mf[row] = np.where(inf_mf, (1 - FILTER) * cm + FILTER * n_a, cm)
        mb_idx = np.flatnonzero(inf_mb)
        ops = np.zeros(0)
        if mb_idx.size:
            sweeps = value_iteration(mb_idx)
            ops = sweeps * active_terms[mb_idx] * (1 + n_a)
            r_idx = row[mb_idx]
            cost_mb[r_idx] = (1 - FILTER) * cb[mb_idx] + FILTER * ops
            st["vi_calls"][mb_idx] += 1
            st["vi_sweeps"][mb_idx] += sweeps

        # 5. Both experts' softmax, folded into their averages; the action from the chosen one.
        p_f = softmax_rows(q_mf[row], ones)
        p_b = softmax_rows(q_mb_f[(runs_sa + state)[:, None] + a_stride], ones)
        w = (FILTER * dec)[:, None]
        pavg_mf[row] = pm + w * (p_f - pm)
        pavg_mb[row] = pb + w * (p_b - pb)
        chosen = np.where(use_mb[:, None], p_b, p_f)
        action = np.minimum(((chosen @ upper) < u_act[:, None]).sum(axis=1), n_a - 1)

        # 6. Environment.
        sa = state * n_a + action
        nxt_s = np.where(dec, nxt_flat[sa], 0)
        terminal = nxt_s == goal
        r = (terminal & experiment).astype(float)

        # 8. Learning: MF (masked) and the MB model (on the deciding runs).
        future = np.where(terminal, 0.0, rowmax(q_mf[base + nxt_s]))
        qi = row * n_a + action
        qf = q_mf.reshape(-1)
        qf[qi] += (ALPHA_MF * dec) * (r + GAMMA_MF * future - qf[qi])
        d = np.flatnonzero(dec)
        if d.size:
            # Flat indices into the [B, pairs] and [B, outcomes] model arrays; in tidy1 the one
            # outcome of a pair has the pair's index and local index 0.
            fi = runs_sa[d] + action[d] * n_s + state[d]
            fo = fi
            rd = r[d]
            pos = ring_pos_f[fi]
            full = ring_len_f[fi] == WINDOW_N
            if full.any():
                # The outcome leaving the window.
                fold = fo[full] + ring_f[fi[full] * WINDOW_N + pos[full]]
                count_f[fold] -= 1
                active_terms[d[full]] -= count_f[fold] == 0
            ring_f[fi * WINDOW_N + pos] = 0  # local index of the outcome just seen
            cnt = count_f[fo]
            active_terms[d] += cnt == 0
            cnt += 1
            count_f[fo] = cnt
            kept = np.minimum(ring_len_f[fi] + 1, WINDOW_N)
            ring_len_f[fi] = kept
            ring_pos_f[fi] = (pos + 1) % WINDOW_N
            last_r_f[fo] = rd
            t_sa = cnt / kept  # T of the pair's one outcome; R = sum T r
            t_model_f[fi] = t_sa
            r_model_f[fi] = t_sa * last_r_f[fo]

        if experiment:
            st["reward"] += r
            if t - babbling + 1 > steps - last:
                st["reward_last"] += r
            st["decisions"] += dec
            st["mb_decisions"] += dec & use_mb
            st["p_mb_sum"] += np.where(dec, p_mb, 0.0)
            st["cost_mf"] += n_a * inf_mf
            if mb_idx.size:
                st["cost_mb"][mb_idx] += ops
        state = nxt_s
        if t == babbling - 1:
            state = np.zeros(n_runs, np.int64)  # end of babbling: back to the start
    return st


def main():
    args = tidy1.arguments(__doc__, runs=256).parse_args()
    st, seconds, cpu_seconds = tidy1.timed(lambda: simulate(args.runs, args.steps, args.babbling, args.seed))
    agent_steps = args.runs * (args.babbling + args.steps)
    if args.json:
        tidy1.print_timing("numpy-ec", seconds, cpu_seconds, agent_steps, st["reward_last"].mean())
        return
    print(f"numpy EC (float64, MB arrays float32): {args.runs} runs x ({args.babbling} + {args.steps}) steps in {seconds:.2f} s"
          f" = {agent_steps / seconds:,.0f} agent-steps/s")

    def summary(last, total, mb_share, cost_mb, cost_mf, calls, sweeps):
        return (f"last 500 steps {last.mean():.2f} (sd {last.std():.2f}); total {np.mean(total):.1f}; "
                f"MB share {np.mean(mb_share):.3f}; cost MB {np.mean(cost_mb):,.0f} MF {np.mean(cost_mf):,.0f}; "
                f"VI calls {np.mean(calls):.0f}, sweeps per call {np.sum(sweeps) / max(np.sum(calls), 1):.2f}")

    mb_share = st["mb_decisions"] / np.maximum(st["decisions"], 1)
    print("  peer: " + summary(st["reward_last"], st["reward"], mb_share, st["cost_mb"], st["cost_mf"],
                               st["vi_calls"], st["vi_sweeps"]))
    if args.check:
        import tempfile

        out = tidy1.run_mbmf("ec", args.runs, args.steps, args.babbling, tempfile.mkdtemp(prefix="peers-ec-"))
        ref, tb = tidy1.mbmf_last(out, args.steps)
        print("  mbmf: " + summary(ref, tb["total_reward"], tb["mb_share"], tb["cost_mb"], tb["cost_mf"],
                                   tb["vi_calls"], tb["vi_sweeps"]))
        tidy1.print_verdict(st["reward_last"].mean(), ref.mean())


if __name__ == "__main__":
    main()
