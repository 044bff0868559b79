"""mbmf.run / mbmf.read: tables, output types, parameters, messages."""

from __future__ import annotations

import warnings

import polars as pl
import pyarrow as pa
import pytest

import mbmf

SMALL = dict(steps=300, babbling=50, checkpoint=100)


def test_run_returns_runs_and_series_as_capsule_tables() -> None:
    result = mbmf.run(controller=["mf", "ec"], runs=3, seed=5, **SMALL)
    assert isinstance(result, mbmf.Result)
    runs, series = result
    assert hasattr(runs, "__arrow_c_stream__")
    runs_pl = pl.DataFrame(runs)
    # 3 runs per controller, in controller order; 300 / 100 = 3 checkpoints per run.
    assert runs_pl.height == 6
    assert runs_pl["controller"].to_list() == ["mf"] * 3 + ["ec"] * 3
    assert runs_pl["steps"].to_list() == [300] * 6
    assert runs_pl["master_seed"].unique().to_list() == [5]
    assert pl.DataFrame(series).height == 6 * 3
    assert pa.table(series).num_rows == 18


def test_output_types() -> None:
    runs, _ = mbmf.run(controller="ec", runs=2, output="polars", **SMALL)
    assert isinstance(runs, pl.DataFrame)
    runs, _ = mbmf.run(controller="ec", runs=2, output="pyarrow", **SMALL)
    assert isinstance(runs, pa.Table)
    with pytest.raises(ValueError, match="invalid value 'pandas' for 'output': expected one of arrow, polars, pyarrow"):
        mbmf.run(controller="ec", runs=2, output="pandas", **SMALL)


def test_same_seed_same_numbers_and_threads_do_not_matter() -> None:
    one = pa.table(mbmf.run(controller="mf", runs=4, seed=9, threads=1, **SMALL).runs)
    two = pa.table(mbmf.run(controller="mf", runs=4, seed=9, threads=2, **SMALL).runs)
    keep = [c for c in one.column_names if c != "wall_time_s"]
    assert one.select(keep).equals(two.select(keep))
    other = pa.table(mbmf.run(controller="mf", runs=4, seed=10, **SMALL).runs)
    assert not one.select(["total_reward"]).equals(other.select(["total_reward"]))


def test_parameters_follow_the_registry() -> None:
    params = {p[0]: p for p in mbmf.parameters()}
    assert params["alpha_mf"][1:4] == ("float", [], "0.6")
    assert params["interaction"][2][:3] == ["none", "congratulation", "takeover"]
    assert params["forget"][4] == "a probability in [0, 1]"
    assert "paper-takeover" in params["profile"][2]
    # The keywords are the registry's parameters with a flag of `mbmf run`, in column order.
    assert list(params)[:3] == ["selection", "cost_model", "interaction"]
    runs = pl.DataFrame(mbmf.run(controller="ec", runs=1, alpha_mf=0.5, forget=0.2,
                                 interaction="takeover", budget=7, **SMALL).runs)
    assert runs["alpha_mf"].to_list() == [0.5]
    assert runs["forget_prob"].to_list() == [0.2]
    assert runs["interaction"].to_list() == ["takeover"]
    assert runs["budget"].to_list() == [7]
    # Human fields without a profile describe a custom human, as on the command line.
    assert runs["profile"].to_list() == ["custom"]


def test_a_profile_sets_the_human_and_keywords_override_it() -> None:
    runs = pl.DataFrame(mbmf.run(controller=["mf", "ec"], runs=1, profile="paper-takeover",
                                 budget=3, **SMALL).runs)
    assert runs["profile"].to_list() == ["paper-takeover"] * 2
    assert runs["interaction"].to_list() == ["takeover"] * 2
    assert runs["budget"].to_list() == [3, 3]
    # The column name and sweep aliases name the same parameter as the keyword.
    runs = pl.DataFrame(mbmf.run(controller="ec", runs=1, forget_prob=0.3, kappa=4.0, **SMALL).runs)
    assert (runs["forget_prob"][0], runs["kappa_coeff"][0]) == (0.3, 4.0)


def test_bad_values_raise_value_error_naming_the_parameter() -> None:
    with pytest.raises(ValueError, match=r"invalid value '2' for 'alpha_mf': expected .*\(default 0.6\)"):
        mbmf.run(controller="ec", runs=1, alpha_mf=2, **SMALL)
    with pytest.raises(ValueError, match="invalid value 'x' for 'alpha_mf': expected a number"):
        mbmf.run(controller="ec", runs=1, alpha_mf="x", **SMALL)
    with pytest.raises(ValueError, match="invalid value '0' for 'runs': 0 is too small: expected a whole number from 1 to 1000000"):
        mbmf.run(controller="ec", runs=0)
    with pytest.raises(ValueError, match="invalid value '2.5' for 'steps': not a whole number"):
        mbmf.run(controller="ec", runs=1, steps=2.5)
    with pytest.raises(ValueError, match="invalid value 'zz' for 'controller': expected one of mf, mb"):
        mbmf.run(controller=["ec", "zz"], runs=1)
    with pytest.raises(ValueError, match="invalid value 'shouting' for 'interaction': expected one of"):
        mbmf.run(controller="ec", runs=1, interaction="shouting")
    with pytest.raises(ValueError, match="tidy3"):
        mbmf.run(task="tidy3", controller="ec", runs=1)


def test_unknown_keyword_raises_type_error_with_did_you_mean() -> None:
    with pytest.raises(TypeError, match="run\\(\\) got an unexpected keyword argument 'alpah_mf'; did you mean 'alpha_mf'\\?"):
        mbmf.run(controller="ec", runs=1, alpah_mf=0.5)
    with pytest.raises(TypeError, match="unexpected keyword argument 'xyzzy'$"):
        mbmf.run(controller="ec", runs=1, xyzzy=1)


def test_warnings_are_python_warnings() -> None:
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        mbmf.run(controller=["ec", "ec"], runs=1, **SMALL)
    assert any("--controller lists ec twice" in str(w.message) for w in caught)
    # A rule's own parameter given to rules that do not read it: the CLI's warning.
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        mbmf.run(controller="ec", runs=1, w_mb=0.3, **SMALL)
    assert any(
        "--w-mb changes nothing here: only fixed reads it" in str(w.message) for w in caught
    )


def test_out_keeps_the_files_and_read_reads_them(tmp_path) -> None:
    out = tmp_path / "run"
    runs, series = mbmf.run(controller="ec", runs=2, out=out, output="pyarrow", **SMALL)
    assert sorted(p.name for p in out.iterdir()) == ["runs.parquet", "series.parquet"]
    back = mbmf.read(out, output="pyarrow")
    assert back.num_rows == 2
    assert back.column("total_reward").to_pylist() == runs.column("total_reward").to_pylist()
    assert mbmf.read(out, "series", output="polars").height == series.num_rows
    # Earlier results are kept unless force=True, as with --force.
    with pytest.raises(ValueError, match="earlier run"):
        mbmf.run(controller="ec", runs=2, out=out, **SMALL)
    mbmf.run(controller="ec", runs=1, out=out, force=True, **SMALL)
    assert mbmf.read(out, output="polars").height == 1
    with pytest.raises(ValueError):
        mbmf.read(tmp_path / "missing")


def test_progress_bar_counts_every_agent_step(monkeypatch) -> None:
    counted: list[int] = []

    class Bar:
        def __init__(self, total: int, **_: object) -> None:
            counted.append(total)

        def update(self, n: int) -> None:
            counted.append(n)

        def close(self) -> None:
            pass

    import tqdm.auto

    monkeypatch.setattr(tqdm.auto, "tqdm", Bar)
    mbmf.run(controller="ec", runs=3, progress=True, **SMALL)
    total, *steps = counted
    assert total == 3 * 350
    assert sum(steps) == total
