"""Times each peer and the matching `mbmf run` on the same work, pinned to one core.

Jobs, in this order within each repeat (so repeats are interleaved):
  mbmf-mf, numpy-mf, jax-mf   (tidy1, MF alone, --mf-runs runs x (babbling + steps))
  mbmf-ec, numpy-ec           (tidy1, EC, --ec-runs runs x (babbling + steps))
Each job runs as its own process under `taskset -c CORE` with one thread everywhere
(XLA_FLAGS single-threaded Eigen, OMP/OPENBLAS/MKL_NUM_THREADS=1, `mbmf --threads 1`).

What is timed:
- mbmf: the whole `mbmf run` command (process start to exit, Parquet writing included), after
  one untimed 1-run job per controller (so the binary's pages are in memory, as JAX gets a
  warm-up call).
- peers: the simulation inside the process (array allocation to per-run results), so the
  interpreter start, imports and JAX compilation are not counted; JAX is compiled ahead of time
  and called once as a warm-up before the timed call.
The figure per job is the median of the repeats; agent-steps = runs x (babbling + steps) for all.
CPU seconds (of the process, all threads) are shown too: on a machine shared with other jobs they
move less than wall time.

  benches/peers/run.sh [--repeats 3] [--mf-runs 4096] [--ec-runs 256] [--steps 2000] [--quick]
  benches/peers/run.sh --early   # EC's early phase: 1,024 runs x 1,000 steps, no babbling
"""

import argparse
import datetime
import json
import os
import platform
import shutil
import statistics
import subprocess
import sys
import tempfile
import time

import tidy1

HERE = os.path.dirname(os.path.abspath(__file__))


def child_env(numpy_peer):
    env = dict(os.environ)
    env.update({
        "XLA_FLAGS": "--xla_cpu_multi_thread_eigen=false intra_op_parallelism_threads=1",
        "OMP_NUM_THREADS": "1",
        "OPENBLAS_NUM_THREADS": "1",
        "MKL_NUM_THREADS": "1",
        "PYTHONPATH": HERE,
    })
    if numpy_peer:
        # Set on some processors of this workplace for old OpenBLAS builds; they slow a current
        # numpy (see the environment notes), so the benchmark's numpy runs without them.
        env.pop("OPENBLAS_CORETYPE", None)
        env.pop("OPENBLAS_L2_SIZE", None)
    return env


def timed(cmd, env):
    """Runs cmd; returns (wall seconds, child CPU seconds, stdout)."""
    started = time.perf_counter()
    proc = subprocess.Popen(cmd, env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    _, status, usage = os.wait4(proc.pid, 0)
    wall = time.perf_counter() - started
    out, err = proc.stdout.read(), proc.stderr.read()
    proc.returncode = os.waitstatus_to_exitcode(status)
    if proc.returncode != 0:
        raise SystemExit(f"command failed ({proc.returncode}): {' '.join(cmd)}\n{err}")
    return wall, usage.ru_utime + usage.ru_stime, out


def run_mbmf(core, controller, runs, steps, babbling):
    out_dir = tempfile.mkdtemp(prefix=f"peers-bench-{controller}-")
    try:
        cmd = ["taskset", "-c", str(core), tidy1.mbmf_binary(), "run", "--task", "tidy1",
               "--controller", controller, "--runs", str(runs), "--steps", str(steps),
               "--babbling", str(babbling), "--threads", "1", "--quiet", "--out", out_dir]
        wall, cpu, _ = timed(cmd, child_env(False))
        last, _ = tidy1.mbmf_last(out_dir, steps)
        return {"seconds": wall, "cpu_seconds": cpu, "reward_last500": float(last.mean())}
    finally:
        shutil.rmtree(out_dir, ignore_errors=True)


def run_peer(core, script, runs, steps, babbling, seed):
    cmd = ["taskset", "-c", str(core), sys.executable, os.path.join(HERE, script), "--runs", str(runs),
           "--steps", str(steps), "--babbling", str(babbling), "--seed", str(seed), "--json"]
    _, _, out = timed(cmd, child_env(True))
    return json.loads(out.strip().splitlines()[-1])


def blas_info():
    code = ("import numpy, threadpoolctl, json; "
            "print(json.dumps([(i['internal_api'], i.get('version'), i.get('architecture'), i['num_threads'])"
            " for i in threadpoolctl.threadpool_info()]))")
    out = subprocess.run([sys.executable, "-c", code], env=child_env(True), capture_output=True, text=True)
    return out.stdout.strip() or out.stderr.strip()


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--mf-runs", type=int, default=4096)
    ap.add_argument("--ec-runs", type=int, default=256)
    ap.add_argument("--steps", type=int, default=2000)
    ap.add_argument("--babbling", type=int, default=1000)
    ap.add_argument("--core", type=int, default=0, help="the core every job is pinned to")
    ap.add_argument("--only", default="mf,ec", help="mf, ec or mf,ec")
    ap.add_argument("--early", action="store_true",
                    help="EC's early phase, the workload judged: --only ec --ec-runs 1024 --steps 1000 --babbling 0")
    ap.add_argument("--quick", action="store_true", help="a smoke test: 1 repeat, 256 MF runs, 32 EC runs, 100 babbling + 600 steps")
    args = ap.parse_args()
    if args.early:
        args.only, args.ec_runs, args.steps, args.babbling = "ec", 1024, 1000, 0
    if args.quick:
        args.repeats, args.mf_runs, args.ec_runs, args.steps, args.babbling = 1, 256, 32, 600, 100
    if not os.access(tidy1.mbmf_binary(), os.X_OK):
        raise SystemExit(f"mbmf binary {tidy1.mbmf_binary()} not found: run `cargo build --release` "
                         "in the repository, or set MBMF=/path/to/mbmf")
    if args.steps < 500:
        raise SystemExit("--steps must be >= 500 (the reward over the last 500 steps is compared)")

    groups = [g.strip() for g in args.only.split(",") if g.strip()]
    jobs = []
    if "mf" in groups:
        jobs += [("mbmf-mf", "mf", args.mf_runs, None), ("numpy-mf", "mf", args.mf_runs, "mf_numpy.py"),
                 ("jax-mf", "mf", args.mf_runs, "mf_jax.py")]
    if "ec" in groups:
        jobs += [("mbmf-ec", "ec", args.ec_runs, None), ("numpy-ec", "ec", args.ec_runs, "ec_numpy.py")]

    load = os.getloadavg()
    print(f"# peer benchmark, {datetime.datetime.now(datetime.timezone.utc):%Y-%m-%d %H:%M} UTC")
    print(f"machine: {platform.processor() or platform.machine()}, {os.cpu_count()} cores, "
          f"load average {load[0]:.2f} at start; every job pinned to core {args.core}")
    print(f"mbmf: {tidy1.mbmf_binary()}; python {platform.python_version()}; BLAS {blas_info()}")
    print(f"work: tidy1, {args.babbling} babbling + {args.steps} steps; MF {args.mf_runs} runs, "
          f"EC {args.ec_runs} runs; median of {args.repeats} interleaved repeats\n", flush=True)

    # One untimed mbmf job per controller first, as JAX gets its warm-up call: the first start of
    # a freshly built (large, debug-info) binary reads its pages from disk.
    for name, controller, _, script in jobs:
        if script is None:
            run_mbmf(args.core, controller, 1, args.steps, args.babbling)

    results = {name: [] for name, *_ in jobs}
    for rep in range(args.repeats):
        for name, controller, runs, script in jobs:
            if script is None:
                res = run_mbmf(args.core, controller, runs, args.steps, args.babbling)
            else:
                res = run_peer(args.core, script, runs, args.steps, args.babbling, seed=1 + rep)
            res["agent_steps"] = runs * (args.babbling + args.steps)
            results[name].append(res)
            print(f"  repeat {rep + 1}: {name:9} {res['seconds']:8.2f} s wall, {res['cpu_seconds']:8.2f} s CPU, "
                  f"{res['agent_steps'] / res['seconds']:>13,.0f} agent-steps/s, "
                  f"reward last 500 {res['reward_last500']:.2f}"
                  + (f" (compile {res['compile_s']:.1f} s, not timed)" if "compile_s" in res else ""), flush=True)

    med = {}
    print("\n| implementation | runs | agent-steps | median s (wall) | agent-steps/s | agent-steps/s by CPU s "
          "| reward, last 500 steps |")
    print("|---|---:|---:|---:|---:|---:|---:|")
    for name, controller, runs, _ in jobs:
        rs = results[name]
        wall = statistics.median(r["seconds"] for r in rs)
        cpu = statistics.median(r["cpu_seconds"] for r in rs)
        steps_ = rs[0]["agent_steps"]
        med[name] = (steps_ / wall, steps_ / cpu)
        reward = statistics.mean(r["reward_last500"] for r in rs)
        print(f"| {name} | {runs} | {steps_:,} | {wall:.2f} | {steps_ / wall:,.0f} | {steps_ / cpu:,.0f} | {reward:.2f} |")
    print("\n| ratio | by wall time | by CPU time |")
    print("|---|---:|---:|")
    for mbmf_name, peer in (("mbmf-mf", "numpy-mf"), ("mbmf-mf", "jax-mf"), ("mbmf-ec", "numpy-ec")):
        if mbmf_name in med and peer in med:
            print(f"| {mbmf_name} / {peer} | {med[mbmf_name][0] / med[peer][0]:.2f}x "
                  f"| {med[mbmf_name][1] / med[peer][1]:.2f}x |")


if __name__ == "__main__":
    main()
