"""mbmf.sweep: from a file or a dict, shards, resume, read back."""

from __future__ import annotations

import polars as pl
import pytest

import mbmf

SWEEP = {
    "seeds": 2,
    "master_seed": 3,
    "fixed": {"steps": 300, "babbling": 50, "checkpoint": 100},
    "grid": {"controller": ["mf", "ec"], "alpha_mf": [0.3, 0.6]},
}


def test_a_dict_sweep_equals_its_file(tmp_path) -> None:
    report = mbmf.sweep(SWEEP, out=tmp_path / "dict", progress=False)
    assert (report.total, report.ran, report.done_before) == (8, 8, 0)
    file = tmp_path / "sweep.toml"
    file.write_text(
        "seeds = 2\nmaster_seed = 3\n[fixed]\nsteps = 300\nbabbling = 50\ncheckpoint = 100\n"
        "[grid]\ncontroller = [\"mf\", \"ec\"]\nalpha_mf = [0.3, 0.6]\n"
    )
    mbmf.sweep(file, out=tmp_path / "file", progress=False)
    a = pl.DataFrame(mbmf.read(tmp_path / "dict")).drop("wall_time_s")
    b = pl.DataFrame(mbmf.read(tmp_path / "file")).drop("wall_time_s")
    assert a.height == 8
    assert sorted(a["alpha_mf"].unique().to_list()) == [0.3, 0.6]
    assert a.sort("run_index").equals(b.sort("run_index"))


def test_shards_and_resume(tmp_path) -> None:
    out = tmp_path / "sharded"
    first = mbmf.sweep(SWEEP, out=out, shard=(0, 2), progress=False)
    assert first.ran == 4 and "other shards add the rest" in first.line
    # An unfinished sweep is refused by read unless asked for.
    with pytest.raises(ValueError):
        mbmf.read(out)
    with pytest.warns(UserWarning):
        assert pl.DataFrame(mbmf.read(out, allow_incomplete=True)).height == 4
    with pytest.raises(ValueError):
        mbmf.sweep(SWEEP, out=out, shard=(0, 2), progress=False)
    again = mbmf.sweep(SWEEP, out=out, shard=(0, 2), resume=True, progress=False)
    assert again.ran == 0
    mbmf.sweep(SWEEP, out=out, shard="1/2", progress=False)
    assert pl.DataFrame(mbmf.read(out)).height == 8
    # One filter as a string is one filter, as a list of one is.
    one = pl.DataFrame(mbmf.read(out, where="controller=ec"))
    assert one.height == 4 and one["controller"].unique().to_list() == ["ec"]
    assert one.equals(pl.DataFrame(mbmf.read(out, where=["controller=ec"])))


def test_bad_sweeps_raise_value_error(tmp_path) -> None:
    with pytest.raises(ValueError, match="alpha_mf"):
        mbmf.sweep({"grid": {"alpha_mf": [2.0]}}, out=tmp_path / "bad", progress=False)
    with pytest.raises(ValueError, match="shard"):
        mbmf.sweep(SWEEP, out=tmp_path / "s", shard=(2, 2), progress=False)
    with pytest.raises(ValueError, match="numbered from 0, so shard=\\(INDEX, COUNT\\) needs INDEX < COUNT"):
        mbmf.sweep(SWEEP, out=tmp_path / "s", shard="2/2", progress=False)
    with pytest.raises(ValueError, match="expected INDEX/COUNT such as"):
        mbmf.sweep(SWEEP, out=tmp_path / "s", shard="half", progress=False)


def test_min_budget_equals_the_command_line(tmp_path, mbmf_bin) -> None:
    import subprocess

    import pyarrow.parquet as pq

    out = tmp_path / "budgets"
    mbmf.sweep({"seeds": 3, "fixed": {"steps": 300, "babbling": 50, "controller": "ec",
                                      "interaction": "takeover"},
                "grid": {"budget": [0, 5, 50]}}, out=out, progress=False)
    py = mbmf.min_budget(out, output="pyarrow")
    subprocess.run([str(mbmf_bin), "min-budget", str(out)], check=True, capture_output=True)
    cli = pq.read_table(out / "analysis" / "min_budget.parquet")
    assert py.num_rows == cli.num_rows >= 1
    assert py.select(cli.column_names).to_pylist() == cli.to_pylist()
    # where= is --where: COLUMN=VALUE filters, here one that keeps every run, then none.
    assert mbmf.min_budget(out, where=["controller=ec"], output="pyarrow").equals(py)
    with pytest.raises(ValueError, match="no run matches --where 'controller=mf'"):
        mbmf.min_budget(out, where=["controller=mf"])
    with pytest.raises(ValueError, match="no_such_column|metric"):
        mbmf.min_budget(out, metric="no_such_column")
