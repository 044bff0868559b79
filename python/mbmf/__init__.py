"""mbmf from Python: simulate, and read results, as Arrow tables.

The simulator of Dromnelle et al. (RO-MAN 2020): a model-free Q-learning expert, a model-based
value-iteration expert and a meta-controller arbitrating between them, on the "tidy the cubes"
task with a simulated human. The same engine and the same numbers as the ``mbmf`` command line:
``mbmf.run(...)`` writes the rows ``mbmf run`` writes, on every column but ``wall_time_s``.

Tables are returned as Arrow tables that polars, pyarrow and DuckDB read through the Arrow
PyCapsule interface, without pyarrow being required (``output="polars"`` or ``"pyarrow"``
converts for you).

>>> import mbmf, polars as pl
>>> runs, series = mbmf.run(controller=["mf", "ec"], runs=4, steps=1000, babbling=100)
>>> pl.DataFrame(runs).group_by("controller").agg(pl.col("total_reward").mean()).height
2
"""

from __future__ import annotations

import os
import warnings as _warnings
from typing import Any, NamedTuple, Sequence

from . import _mbmf

__all__ = ["Result", "SweepReport", "run", "sweep", "read", "min_budget", "parameters", "CONTROLLERS", "OUTPUTS"]

#: The meta-controllers, as ``controller=`` accepts them.
CONTROLLERS: tuple[str, ...] = tuple(_mbmf.CONTROLLERS)

#: The table types ``output=`` accepts.
OUTPUTS: tuple[str, ...] = ("arrow", "polars", "pyarrow")


class Result(NamedTuple):
    """The two tables of a run: one row per run, and one row per checkpoint of each run."""

    runs: Any
    series: Any


def _convert(table: Any, output: str) -> Any:
    """``table`` (an Arrow PyCapsule table) as the type ``output`` names."""
    if output == "arrow":
        return table
    if output == "polars":
        import polars

        return polars.DataFrame(table)
    import pyarrow

    return pyarrow.table(table)


def _check_output(output: str) -> None:
    if output not in OUTPUTS:
        raise ValueError(
            f"invalid value '{output}' for 'output': expected one of {', '.join(OUTPUTS)}"
        )


def _progress_bar(total: int, progress: bool | None) -> Any:
    """A tqdm bar counting agent-steps, or None: ``progress=None`` shows one when tqdm is
    installed, True requires tqdm, False never shows one."""
    if progress is False:
        return None
    try:
        from tqdm.auto import tqdm
    except ImportError:
        if progress:
            raise ImportError("progress=True needs tqdm: pip install tqdm") from None
        return None
    return tqdm(total=total, unit=" steps", unit_scale=True, desc="mbmf", leave=False)


def run(
    task: str = "tidy1",
    controller: str | Sequence[str] = ("mf", "mb", "rnd", "ec"),
    runs: int = 20,
    seed: int = 1,
    *,
    out: str | os.PathLike[str] | None = None,
    force: bool = False,
    batch_size: int = 4096,
    threads: int | None = None,
    change: Sequence[str] = (),
    progress: bool | None = None,
    output: str = "arrow",
    **params: Any,
) -> Result:
    """Simulate ``runs`` runs of each controller on ``task``: what ``mbmf run`` does.

    Arguments and defaults are ``mbmf run``'s: ``task`` is tidy1, tidy2 or json:PATH;
    ``controller`` a name or a list of names (``CONTROLLERS``); ``seed`` the master seed;
    ``change`` the ``--change STEP:KEY=VALUE`` events; every other keyword is a parameter of the
    registry under its flag's name with ``_`` (``alpha_mf=0.5``, ``interaction="takeover"``,
    ``profile="paper-takeover"``; ``parameters()`` lists them with defaults and ranges).

    ``out``: also keep runs.parquet and series.parquet in this folder (``force=True`` replaces
    earlier results); by default they are written to a temporary folder and removed.
    ``threads``: worker threads (default: one per core), a pool of the call's own.
    ``progress``: a tqdm bar (None: when tqdm is installed). ``output``: "arrow" (an Arrow
    PyCapsule table), "polars" or "pyarrow".

    The simulation runs with the GIL released; Ctrl-C stops it within a second with
    KeyboardInterrupt and nothing is written to ``out``. A bad value raises ValueError naming
    the parameter and what it accepts, an unknown keyword TypeError with the closest name.

    >>> runs, series = mbmf.run(controller="ec", runs=2, steps=500, babbling=50, output="pyarrow")
    >>> runs.num_rows, series.num_rows
    (2, 10)
    """
    _check_output(output)
    bar = _Bar(progress)
    try:
        runs_t, series_t, warnings = _mbmf.run(
            task,
            controller,
            runs,
            seed,
            None if out is None else os.fspath(out),
            force,
            batch_size,
            threads,
            list(change),
            None if progress is False else bar,
            params,
        )
    finally:
        bar.close()
    for warning in warnings:
        _warnings.warn(warning, stacklevel=2)
    return Result(_convert(runs_t, output), _convert(series_t, output))


class SweepReport(NamedTuple):
    """What one ``sweep`` call did."""

    out: str
    total: int
    shard_runs: int
    done_before: int
    ran: int
    parts_written: int
    seconds: float
    line: str


class _Bar:
    """The progress callback of the native calls: a tqdm bar made at the first report, when
    the total is known."""

    def __init__(self, progress: bool | None) -> None:
        self.progress = progress
        self.bar: Any = None

    def __call__(self, n: int, total: int) -> None:
        if self.bar is None:
            made = _progress_bar(total, self.progress)
            self.bar = False if made is None else made
        if self.bar is not False:
            self.bar.update(n)

    def close(self) -> None:
        if self.bar is not None and self.bar is not False:
            self.bar.close()


def sweep(
    sweep: str | os.PathLike[str] | dict[str, Any],
    *,
    out: str | os.PathLike[str],
    resume: bool = False,
    shard: tuple[int, int] = (0, 1),
    batch_size: int = 4096,
    threads: int | None = None,
    progress: bool | None = None,
) -> SweepReport:
    """Run a sweep into the dataset folder ``out``: what ``mbmf sweep FILE --out OUT`` does.

    ``sweep`` is a sweep file's path or the same content as a dict (the TOML's tables as nested
    dicts). ``resume=True`` runs what is missing from ``out``; ``shard=(INDEX, COUNT)`` runs one
    slice of the configurations, as ``--shard``. Read the result with ``mbmf.read(out)``.
    Ctrl-C raises KeyboardInterrupt; the parts already written are kept (resume later).

    >>> mbmf.sweep({"seeds": 2, "fixed": {"steps": 500}, "grid": {"controller": ["mf", "ec"]}},
    ...            out="out/small")
    """
    bar = _Bar(progress)
    try:
        report, warnings = _mbmf.sweep(
            sweep if isinstance(sweep, dict) else os.fspath(sweep),
            os.fspath(out),
            resume,
            tuple(shard),
            batch_size,
            threads,
            None if progress is False else bar,
        )
    finally:
        bar.close()
    for warning in warnings:
        _warnings.warn(warning, stacklevel=2)
    return SweepReport(*report)


def read(
    path: str | os.PathLike[str],
    table: str = "runs",
    *,
    where: Sequence[str] = (),
    allow_incomplete: bool = False,
    output: str = "arrow",
) -> Any:
    """Read table ``table`` ("runs" or "series") of a dataset, as the analysis verbs do.

    ``path`` is a run's folder (runs.parquet, series.parquet), a sweep's folder (only its
    committed parts are read), or one Parquet file. ``where`` keeps the rows passing every
    filter, as ``--where`` (``["interaction=takeover", "budget=10"]``). An unfinished sweep is
    refused unless ``allow_incomplete=True`` (then read with a warning).

    >>> runs = mbmf.read("out/run", output="polars")
    """
    _check_output(output)
    t, warnings = _mbmf.read(os.fspath(path), table, list(where), allow_incomplete)
    for warning in warnings:
        _warnings.warn(warning, stacklevel=2)
    return _convert(t, output)


def min_budget(
    path: str | os.PathLike[str],
    metric: str = "total_reward",
    alpha: float | None = None,
    *,
    where: Sequence[str] = (),
    allow_incomplete: bool = False,
    output: str = "arrow",
) -> Any:
    """The smallest budget of each group whose ``metric`` no larger budget beats (one-sided
    tests at level ``alpha``, default 0.05, SPEC 9): the table ``mbmf min-budget`` writes as
    min_budget.parquet, read from the runs of the dataset at ``path``.

    >>> mbmf.min_budget("out/budgets", metric="reward_last10", output="polars")
    """
    _check_output(output)
    t, warnings = _mbmf.min_budget(os.fspath(path), metric, alpha, list(where), allow_incomplete)
    for warning in warnings:
        _warnings.warn(warning, stacklevel=2)
    return _convert(t, output)


def parameters() -> list[tuple[str, str, list[str], str, str, str]]:
    """The parameter keywords of ``run``, in the output columns' order: (keyword, type,
    accepted names, default, accepted range, description).

    >>> [p[0] for p in mbmf.parameters()][:3]
    ['selection', 'cost_model', 'interaction']
    """
    return list(_mbmf.parameters())
