"""Tidy task 1 (SPEC 2.1) as arrays, shared by the peers, and the mbmf reference check.

Three cubes (red, green, blue), each on the table, in one of the three boxes or in the hand (at
most one cube in the hand): 112 states. Seven actions: take red/green/blue, put the held cube in
the red/green/blue box, put it on the table. A take with a full hand and a put with an empty hand
change nothing. State ids are breadth-first from the start (all cubes on the table) trying the
actions in index order, so the start is 0.
"""

import argparse
import json
import os
import sys
import time
from collections import deque

import numpy as np

TABLE, RED_BOX, GREEN_BOX, BLUE_BOX, HAND = range(5)
N_ACTIONS = 7
START = (TABLE, TABLE, TABLE)
GOAL = (RED_BOX, GREEN_BOX, BLUE_BOX)

HERE = os.path.dirname(os.path.abspath(__file__))
REPO = os.path.dirname(os.path.dirname(HERE))


def apply(state, action):
    """Next places of the three cubes after `action` (deterministic)."""
    places = list(state)
    held = places.index(HAND) if HAND in places else None
    if action < 3:
        if held is None:
            places[action] = HAND
    elif held is not None:
        places[held] = TABLE if action == 6 else RED_BOX + (action - 3)
    return tuple(places)


def build():
    """(next_state [S, A] int64, goal id, state tuples), ids breadth-first from the start."""
    ids = {START: 0}
    order = [START]
    queue = deque([START])
    while queue:
        st = queue.popleft()
        for a in range(N_ACTIONS):
            nxt = apply(st, a)
            if nxt not in ids:
                ids[nxt] = len(order)
                order.append(nxt)
                queue.append(nxt)
    nxt = np.array([[ids[apply(st, a)] for a in range(N_ACTIONS)] for st in order], dtype=np.int64)
    assert len(order) == 112, len(order)
    return nxt, ids[GOAL], order


def check_against_authors_format(nxt, goal, data_dir=None):
    """Compares with ../shared/data/tidy1 (the same task in the authors' JSON format; $TIDY1_DATA
    overrides the folder) if present.

    Returns a one-line verdict; raises on a mismatch. Nothing is copied from those files.
    """
    data_dir = data_dir or os.environ.get("TIDY1_DATA") or os.path.join(REPO, "..", "shared", "data", "tidy1")
    path = os.path.join(data_dir, "tidy1.json")
    if not os.path.exists(path):
        return f"({path} absent: not compared)"
    with open(path) as f:
        model = json.load(f)
    for entry in model["transitionActions"]:
        s = entry["state"]
        for tr in entry["transitions"]:
            if nxt[s, tr["action"]] != tr["state"]:
                raise SystemExit(f"tidy1 mismatch at state {s} action {tr['action']}")
    with open(os.path.join(data_dir, "keyStates.txt")) as f:
        goal_line = [ln.split() for ln in f if ln.startswith("goal")][0]
    if int(goal_line[1]) != goal:
        raise SystemExit(f"goal {goal} != authors' {goal_line[1]}")
    return "matches the authors' tidy1.json and keyStates.txt"


def keep_freed_memory():
    """Asks glibc's malloc to keep freed memory instead of returning it to the system.

    numpy allocates a fresh array per operation; above 128 KiB glibc maps and unmaps each one,
    so every large temporary costs page faults (measured: a third of the numpy EC peer's time
    in the kernel). Same arithmetic, only fewer system calls. No-op where glibc is absent.
    """
    import ctypes

    try:
        libc = ctypes.CDLL("libc.so.6")
    except OSError:
        return False
    m_trim_threshold, m_mmap_threshold = -1, -3
    return bool(libc.mallopt(m_mmap_threshold, 1 << 30)) and bool(libc.mallopt(m_trim_threshold, 1 << 30))


def mbmf_binary():
    """The mbmf binary: $MBMF, else the repository's target/release/mbmf."""
    return os.environ.get("MBMF", os.path.join(REPO, "target", "release", "mbmf"))


def mbmf_last(out_dir, steps, last=500):
    """Per-run reward over the last `last` steps and the runs table, from an `mbmf run` output."""
    import pyarrow.parquet as pq

    series = pq.read_table(os.path.join(out_dir, "series.parquet"),
                           columns=["run_index", "step", "cum_reward"]).to_pydict()
    at = {}
    for r, st, c in zip(series["run_index"], series["step"], series["cum_reward"]):
        at[(r, st)] = c
    runs = sorted({r for r, _ in at})
    per_run = np.array([at[(r, steps)] - at[(r, steps - last)] for r in runs])
    table = pq.read_table(os.path.join(out_dir, "runs.parquet")).to_pydict()
    return per_run, table


def run_mbmf(controller, runs, steps, babbling, out_dir, seed=1):
    """Runs `mbmf run` on tidy1 (one thread) and returns its output folder."""
    import subprocess

    cmd = [mbmf_binary(), "run", "--task", "tidy1", "--controller", controller,
           "--steps", str(steps), "--babbling", str(babbling), "--runs", str(runs),
           "--seed", str(seed), "--threads", "1", "--quiet", "--out", out_dir]
    subprocess.run(cmd, check=True)
    return out_dir


def verdict(peer, ref, tolerance=0.15):
    """'near' when the peer's mean is within `tolerance` (relative) of mbmf's."""
    rel = abs(peer - ref) / max(abs(ref), 1e-12)
    return ("near" if rel <= tolerance else "FAR") + f" ({100 * rel:.1f}% apart)"


def arguments(description, runs):
    """The command line every peer takes: --runs (default `runs`), --steps, --babbling, --seed,
    --check and --json; a peer adds its own before parsing."""
    ap = argparse.ArgumentParser(description=description, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--runs", type=int, default=runs)
    ap.add_argument("--steps", type=int, default=2000)
    ap.add_argument("--babbling", type=int, default=1000)
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--check", action="store_true", help="also run mbmf on the same work and compare")
    ap.add_argument("--json", action="store_true", help="print one JSON line of timing for run.py")
    return ap


def timed(work):
    """`work()` with the wall-clock and CPU seconds it took: (result, seconds, cpu_seconds)."""
    started, cpu_started = time.perf_counter(), time.process_time()
    out = work()
    return out, time.perf_counter() - started, time.process_time() - cpu_started


def print_timing(impl, seconds, cpu_seconds, agent_steps, reward_last500, **extra):
    """The JSON line run.py reads: the timing, any `extra` fields, the mean reward of the end."""
    print(json.dumps({"impl": impl, "seconds": seconds, "cpu_seconds": cpu_seconds, "agent_steps": agent_steps,
                      **extra, "reward_last500": float(reward_last500)}))


def print_verdict(peer, ref):
    """Prints how near the peer's mean is to mbmf's, and fails the process when it is far."""
    v = verdict(peer, ref)
    print(f"  verdict: {v}")
    if v.startswith("FAR"):
        sys.exit(1)
