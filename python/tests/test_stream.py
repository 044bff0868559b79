"""mbmf.stream yields, batch by batch, the rows mbmf.run returns."""

from __future__ import annotations

import polars as pl
import pytest

import mbmf

SMALL = dict(steps=300, babbling=50, checkpoint=100, interaction="takeover", budget=10)
ABOUT_THE_WRITING = ["wall_time_s"]


def test_stream_yields_the_rows_of_run_batch_by_batch() -> None:
    whole = mbmf.run(controller=["mf", "ec"], runs=5, seed=3, output="polars", **SMALL)
    parts = list(mbmf.stream(controller=["mf", "ec"], runs=5, seed=3, batch_size=4,
                             output="polars", **SMALL))
    # 10 runs in batches of 4: 4, 4, 2.
    assert [p.runs.height for p in parts] == [4, 4, 2]
    assert all(isinstance(p, mbmf.Result) for p in parts)
    runs = pl.concat([p.runs for p in parts])
    series = pl.concat([p.series for p in parts])
    assert runs["run_index"].to_list() == list(range(10))
    assert runs.drop(ABOUT_THE_WRITING).equals(whole.runs.drop(ABOUT_THE_WRITING))
    assert series.columns == whole.series.columns
    assert series.drop(ABOUT_THE_WRITING, strict=False).equals(
        whole.series.drop(ABOUT_THE_WRITING, strict=False))


def test_leaving_the_loop_stops_the_simulation() -> None:
    stream = mbmf.stream(controller="ec", runs=64, batch_size=1, steps=2000)
    first = next(stream)
    assert pl.DataFrame(first.runs).height == 1
    stream.close()
    # At most the batches already simulated (two ahead of the reader) come after a close.
    assert len(list(stream)) <= 3


def test_stream_checks_its_inputs_when_called() -> None:
    with pytest.raises(ValueError, match="invalid value '-1' for 'alpha_mf'"):
        mbmf.stream(controller="ec", alpha_mf=-1)
    with pytest.raises(TypeError, match="stream\\(\\) got an unexpected keyword argument 'stps'"):
        mbmf.stream(controller="ec", stps=10)


LONG_STREAM = """
import sys
import mbmf
stream = mbmf.stream(controller="ec", runs=100000, steps=100000, batch_size=1)
try:
    for i, part in enumerate(stream):
        if i == 0:
            print("first", flush=True)
except KeyboardInterrupt:
    print("interrupted", flush=True)
    sys.exit(0)
sys.exit(1)
"""


def test_ctrl_c_stops_a_stream() -> None:
    import signal
    import subprocess
    import sys

    child = subprocess.Popen([sys.executable, "-c", LONG_STREAM], stdout=subprocess.PIPE, text=True)
    assert child.stdout is not None
    assert child.stdout.readline().strip() == "first"
    child.send_signal(signal.SIGINT)
    assert child.stdout.readline().strip() == "interrupted"
    assert child.wait(timeout=60) == 0
