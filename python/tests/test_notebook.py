"""Behaving in a notebook: Ctrl-C, the GIL, threads, fork."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import textwrap
import threading
import time

import mbmf

SMALL = dict(steps=300, babbling=50, checkpoint=100)

LONG_RUN = textwrap.dedent(
    """
    import sys, time, mbmf
    print("started", flush=True)
    t = time.monotonic()
    try:
        mbmf.run(controller="ec", runs=100000, steps=100000, out=sys.argv[1], progress=False)
    except KeyboardInterrupt:
        print("interrupted %.3f" % time.monotonic(), flush=True)
        sys.exit(0)
    print("finished", flush=True)
    sys.exit(1)
    """
)


def test_ctrl_c_raises_keyboard_interrupt_within_a_second_and_writes_nothing(tmp_path) -> None:
    out = tmp_path / "out"
    child = subprocess.Popen([sys.executable, "-c", LONG_RUN, str(out)], stdout=subprocess.PIPE, text=True)
    assert child.stdout is not None
    assert child.stdout.readline().strip() == "started"
    time.sleep(2.0)  # well into the simulation
    sent = time.monotonic()
    child.send_signal(signal.SIGINT)
    line = child.stdout.readline().split()
    assert child.wait(timeout=30) == 0, line
    assert line[0] == "interrupted"
    assert float(line[1]) - sent < 1.0, f"took {float(line[1]) - sent:.2f} s"
    # The output folder may exist (it is created first) but holds nothing, not even staging.
    left = list(out.iterdir()) if out.exists() else []
    assert left == [], left


def test_the_gil_is_released_while_simulating() -> None:
    ticks = 0
    done = threading.Event()

    def tick() -> None:
        nonlocal ticks
        while not done.is_set():
            ticks += 1
            time.sleep(0.001)

    thread = threading.Thread(target=tick)
    thread.start()
    started = time.monotonic()
    mbmf.run(controller="ec", runs=64, steps=3000, babbling=100, threads=1, progress=False)
    elapsed = time.monotonic() - started
    done.set()
    thread.join()
    # A thread holding the GIL for the whole call would let the other tick only a handful of times.
    assert ticks > 0.3 * elapsed * 1000 / 2, (ticks, elapsed)


def test_a_forked_child_runs_after_the_parent_did() -> None:
    mbmf.run(controller="mf", runs=4, threads=2, **SMALL)
    pid = os.fork()
    if pid == 0:
        code = 1
        try:
            runs, _ = mbmf.run(controller="mf", runs=4, threads=2, output="pyarrow", **SMALL)
            code = 0 if runs.num_rows == 4 else 1
        finally:
            os._exit(code)
    deadline = time.monotonic() + 60
    while time.monotonic() < deadline:
        done, status = os.waitpid(pid, os.WNOHANG)
        if done:
            assert os.waitstatus_to_exitcode(status) == 0
            return
        time.sleep(0.05)
    os.kill(pid, signal.SIGKILL)
    raise AssertionError("the forked child hung")


def test_threads_is_checked() -> None:
    import pytest

    with pytest.raises(ValueError, match="invalid value '0' for 'threads'"):
        mbmf.run(controller="ec", runs=1, threads=0)
