"""mbmf.pareto and mbmf.stats compute what `mbmf pareto` and `mbmf stats` compute."""

from __future__ import annotations

import json
import subprocess

import polars as pl
import pyarrow.parquet as pq
import pytest

import mbmf


@pytest.fixture(scope="module")
def dataset(tmp_path_factory, mbmf_bin):
    """Four controllers, two humans: 5 runs each."""
    out = tmp_path_factory.mktemp("analysis") / "data"
    subprocess.run(
        [str(mbmf_bin), "sweep", "-q", "--out", str(out), str(_sweep(out.parent))],
        check=True, capture_output=True,
    )
    return out


def _sweep(folder):
    path = folder / "sweep.toml"
    path.write_text(
        'seeds = 5\n[fixed]\nsteps = 400\nbabbling = 50\nbudget = 20\nforget_prob = 0.0\n'
        '[grid]\ncontroller = ["mf", "mb", "ec", "rnd"]\ninteraction = ["none", "takeover"]\n'
    )
    return path


def _cli(mbmf_bin, *args) -> dict:
    done = subprocess.run([str(mbmf_bin), *map(str, args)], check=True, capture_output=True, text=True)
    return json.loads(done.stdout)


@pytest.mark.parametrize(
    "options",
    [
        {},
        {"objectives": "total_reward:max,cost_total:min", "by": ["interaction"]},
    ],
)
def test_pareto_equals_the_command_line(dataset, tmp_path, mbmf_bin, options) -> None:
    args = ["pareto", dataset, "--json", "--no-plot", "--out", tmp_path]
    if "objectives" in options:
        args += ["--objectives", options["objectives"]]
    for b in options.get("by", []):
        args += ["--by", b]
    cli = _cli(mbmf_bin, *args)
    # The table's name says what was analysed (the defaults: pareto.parquet).
    (path,) = cli["files"]
    name = "pareto" + "".join(f"-{o.replace(':', '.')}" for o in options.get("objectives", "").split(",") if o)
    name += "".join(f"-by-{b}" for b in options.get("by", []))
    assert path == str(tmp_path / f"{name}.parquet")
    written = pq.read_table(path)
    # From the path, and from a table in memory (polars, then the capsule of mbmf.read).
    runs = mbmf.read(dataset, output="polars")
    for data in (dataset, runs, mbmf.read(dataset)):
        table = mbmf.pareto(data, output="pyarrow", **options)
        assert table.schema.remove_metadata() == written.schema.remove_metadata()
        assert table.equals(written)
    table = pl.DataFrame(mbmf.pareto(dataset, **options))
    groups = cli["groups"] if "groups" in cli else [dict(cli, group={})]
    fronts = table.filter(pl.col("front"))
    assert fronts.height == sum(len(g["front"]) for g in groups)
    objectives = [o.split(":")[0] for o in cli["objectives"]]
    for g in groups:
        for row in g["front"]:
            match = fronts
            # The group's values and the configuration's varying parameters (text columns).
            for key, value in {**g["group"], **row}.items():
                if key in ("controller", "interaction") and value is not None:
                    match = match.filter(pl.col(key) == value)
            assert match.height == 1, row
            mine = match.row(0, named=True)
            assert mine["n"] == row["n"]
            assert mine["knee"] == row["knee"]
            for o in objectives:
                assert mine[f"{o}_mean"] == row[f"{o}_mean"]


def test_pareto_refuses_bad_objectives_and_columns(dataset) -> None:
    with pytest.raises(ValueError, match="objectives"):
        mbmf.pareto(dataset, "total_reward:up")
    with pytest.raises(ValueError, match="did you mean 'interaction'"):
        mbmf.pareto(dataset, by="interacton")
    with pytest.raises(TypeError, match="a dataset's path or an Arrow table"):
        mbmf.pareto(42)


def test_stats_equals_the_command_line(dataset, mbmf_bin) -> None:
    where = ["interaction=takeover"]
    cli = _cli(mbmf_bin, "stats", dataset, "--by", "controller", "--metric", "cost_total",
               "--where", where[0], "--json")
    for data in (dataset, mbmf.read(dataset, output="polars")):
        result = mbmf.stats(data, "controller", "cost_total", where=where, output="polars")
        assert isinstance(result, mbmf.Stats)
        groups = result.groups.to_dicts()
        assert [g["controller"] for g in groups] == [g["value"] for g in cli["groups"]]
        for mine, theirs in zip(groups, cli["groups"]):
            for key in ("n", "missing", "mean", "sd", "median"):
                assert mine[key] == theirs[key], key
        pairs = result.pairs.to_dicts()
        assert len(pairs) == len(cli["pairs"]) == 6
        for mine, theirs in zip(pairs, cli["pairs"]):
            for key in ("a", "b", "u", "p", "p_holm", "effect", "method"):
                assert mine[key] == theirs[key], key
        assert result.also_varying == cli["also_varying"]
        assert result.left_out == cli["left_out"]


def test_stats_names_the_groups_that_mix_conditions(dataset) -> None:
    result = mbmf.stats(dataset, by="controller")
    assert result.also_varying == ["interaction"]
