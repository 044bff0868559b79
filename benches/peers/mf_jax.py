"""Peer: MF alone on tidy1 in JAX: `jax.jit` over `lax.scan` of a batched step, float32.

The same work as mf_numpy.py (SPEC 3.1, 3.3, 3.4, 7): per decision the softmax of the MF's Q row
(tau = 0.02, the maximum subtracted), a draw, the fold into the per-state averaged distribution
(filter_alpha 0.6) and its normalised base-2 entropy (read before the fold, summed into the
result so XLA cannot drop it), Q-learning (alpha 0.6, gamma 0.9, the goal terminal); the reset
step after the goal; 1,000 babbling steps with reward withheld, a reset, then the experiment.
The uniforms of every step are drawn inside the compiled function (threefry, one [T, B] array).

The step is written over the whole batch (not `vmap` of a one-run step): the tables are [B * S, A]
with rows b * S + s, rows are gathered and scattered with `indices_are_sorted` and
`unique_indices` (one row per run, ascending), and Q(s, a) is taken with `take_along_axis`. On
this machine that form took about 30 % less CPU than a `vmap`ed one-run step, with the same
results (benches/peers/README.md).
Nothing is passed into the compiled function but a seed, so there is no buffer to donate.

Timing excludes compilation: the function is compiled ahead of time (`jit(...).lower().compile()`)
and called once as a warm-up with another seed before the timed call.

  python mf_jax.py [--runs B] [--steps N] [--babbling N] [--seed S] [--check] [--json]
"""

import os
import time

import numpy as np

import tidy1

# One thread unless the caller says otherwise (run.py sets the same flags).
os.environ.setdefault("XLA_FLAGS", "--xla_cpu_multi_thread_eigen=false intra_op_parallelism_threads=1")

import jax  # noqa: E402
import jax.numpy as jnp  # noqa: E402
from jax import lax  # noqa: E402

TAU, ALPHA, GAMMA, FILTER = 0.02, 0.6, 0.9, 0.6


def build(n_runs, steps, babbling, last=500, unroll=1):
    """The jitted batch: seed -> per-run (reward over the last `last` steps, total reward,
    decisions, summed normalised entropy)."""
    nxt_np, goal, _ = tidy1.build()
    n_s, n_a = nxt_np.shape
    nxt = jnp.asarray(nxt_np.reshape(-1), jnp.int32)
    tiny = jnp.finfo(jnp.float32).tiny
    inv_log2_a = np.float32(1.0 / np.log2(n_a))
    base = jnp.arange(n_runs, dtype=jnp.int32) * n_s  # row of (run b, state 0)
    rows = dict(indices_are_sorted=True, unique_indices=True, mode="promise_in_bounds")
    actions = jnp.arange(n_a)[None, :]

    def step(carry, x, experiment):
        # qs is Q(s, .) of the current state, carried from the previous step's gather of the
        # next state's row (needed there for max_b Q(s', b)): one row gather per step saved.
        u, in_last = x
        q, qs, pavg, s, r_last, r_total, dec, h_sum = carry
        row = base + s
        decide = s != goal  # the reset step decides and learns nothing
        e = jnp.exp((qs - qs.max(axis=1, keepdims=True)) / TAU)
        cum = jnp.cumsum(e, axis=1)
        total = cum[:, -1:]
        p = e / total
        a = jnp.minimum(jnp.sum(cum < u[:, None] * total, axis=1), n_a - 1)
        pa = pavg.at[row].get(**rows)
        h = -jnp.sum(pa * jnp.log2(jnp.maximum(pa, tiny)), axis=1) * inv_log2_a  # 0 log 0 = 0
        pavg = pavg.at[row].set(jnp.where(decide[:, None], pa + FILTER * (p - pa), pa), **rows)
        nxt_s = jnp.where(decide, nxt.at[s * n_a + a].get(mode="promise_in_bounds"), 0)
        terminal = nxt_s == goal
        qn = q.at[base + nxt_s].get(**rows)
        future = jnp.where(terminal, 0.0, qn.max(axis=1))
        r = jnp.where(terminal & experiment, 1.0, 0.0).astype(jnp.float32)
        qsa = jnp.take_along_axis(qs, a[:, None], axis=1)[:, 0]
        new = jnp.where(decide, qsa + ALPHA * (r + GAMMA * future - qsa), qsa)
        q = q.reshape(-1).at[row * n_a + a].set(new, **rows).reshape(q.shape)
        # A self-loop changed the row just gathered.
        qn = jnp.where((nxt_s == s)[:, None] & (actions == a[:, None]), new[:, None], qn)
        if experiment:
            r_total = r_total + r
            r_last = r_last + jnp.where(in_last, r, 0.0)
            dec = dec + decide.astype(jnp.int32)
            h_sum = h_sum + jnp.where(decide, h, 0.0)
        return (q, qn, pavg, nxt_s, r_last, r_total, dec, h_sum), None

    def phase(carry, us, experiment, in_last):
        carry, _ = lax.scan(lambda c, x: step(c, x, experiment), carry, (us, in_last), unroll=unroll)
        return carry

    def simulate(seed):
        key = jax.random.PRNGKey(seed)
        k_bab, k_exp = jax.random.split(key)
        carry = (
            jnp.zeros((n_runs * n_s, n_a), jnp.float32),
            jnp.zeros((n_runs, n_a), jnp.float32),
            jnp.full((n_runs * n_s, n_a), 1.0 / n_a, jnp.float32),
            jnp.zeros(n_runs, jnp.int32),
            jnp.zeros(n_runs, jnp.float32),
            jnp.zeros(n_runs, jnp.float32),
            jnp.zeros(n_runs, jnp.int32),
            jnp.zeros(n_runs, jnp.float32),
        )
        in_last = jnp.arange(1, steps + 1) > steps - last
        if babbling > 0:
            us = jax.random.uniform(k_bab, (babbling, n_runs), jnp.float32)
            carry = phase(carry, us, False, jnp.zeros(babbling, bool))
            # Back to the start (and its Q row).
            carry = (carry[0], carry[0][base], carry[2], jnp.zeros(n_runs, jnp.int32)) + carry[4:]
        us = jax.random.uniform(k_exp, (steps, n_runs), jnp.float32)
        carry = phase(carry, us, True, in_last)
        return carry[4:]

    return jax.jit(simulate).lower(jnp.int32(0)).compile()


def main():
    ap = tidy1.arguments(__doc__, runs=512)
    ap.add_argument("--unroll", type=int, default=1, help="lax.scan unroll factor")
    args = ap.parse_args()
    t0 = time.perf_counter()
    fn = build(args.runs, args.steps, args.babbling, unroll=args.unroll)
    compile_s = time.perf_counter() - t0
    jax.block_until_ready(fn(jnp.int32(args.seed + 1000)))  # warm-up call, not timed
    out, seconds, cpu_seconds = tidy1.timed(lambda: jax.block_until_ready(fn(jnp.int32(args.seed))))
    last, tot, dec, h_sum = (np.asarray(x) for x in out)
    agent_steps = args.runs * (args.babbling + args.steps)
    if args.json:
        tidy1.print_timing("jax-mf", seconds, cpu_seconds, agent_steps, last.mean(), compile_s=compile_s)
        return
    print(f"jax {jax.__version__} on {jax.devices()[0].platform} (compile {compile_s:.1f} s, not timed)")
    print(f"JAX MF (float32): {args.runs} runs x ({args.babbling} + {args.steps}) steps in {seconds:.2f} s"
          f" = {agent_steps / seconds:,.0f} agent-steps/s")
    mean_h = h_sum / np.maximum(dec, 1)
    print(f"  reward over the last 500 steps, mean per run: {last.mean():.2f} (sd {last.std():.2f}); "
          f"total {tot.mean():.1f}; decisions {dec.mean():.0f}; mean entropy {mean_h.mean():.3f}")
    if args.check:
        import tempfile

        out = tidy1.run_mbmf("mf", args.runs, args.steps, args.babbling, tempfile.mkdtemp(prefix="peers-mf-"))
        ref, table = tidy1.mbmf_last(out, args.steps)
        print(f"  mbmf: last 500 steps {ref.mean():.2f} (sd {ref.std():.2f}); total "
              f"{np.mean(table['total_reward']):.1f}; decisions {np.mean(table['decisions']):.0f}; "
              f"mean entropy {np.mean(table['mean_entropy_chosen']):.3f}")
        tidy1.print_verdict(last.mean(), ref.mean())


if __name__ == "__main__":
    main()
