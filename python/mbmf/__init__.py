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
from typing import Any, Iterator, NamedTuple, Sequence

from . import _mbmf

__all__ = [
    "Result",
    "Stats",
    "SweepReport",
    "VecEnv",
    "run",
    "stream",
    "sweep",
    "read",
    "pareto",
    "stats",
    "min_budget",
    "parameters",
    "CONTROLLERS",
    "OUTPUTS",
]

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
    key_states: str | os.PathLike[str] | None = None,
    spaces: str | os.PathLike[str] | None = None,
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
    PyCapsule table), "polars" or "pyarrow". ``key_states``, ``spaces``: a ``json:PATH`` task's
    keyStates.txt and spaces.txt when they are not beside the model file (``--key-states``,
    ``--spaces``).

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
            _path(key_states),
            _path(spaces),
        )
    finally:
        bar.close()
    for warning in warnings:
        _warnings.warn(warning, stacklevel=2)
    return Result(_convert(runs_t, output), _convert(series_t, output))


def _path(path: str | os.PathLike[str] | None) -> str | None:
    return None if path is None else os.fspath(path)


def stream(
    task: str = "tidy1",
    controller: str | Sequence[str] = ("mf", "mb", "rnd", "ec"),
    runs: int = 20,
    seed: int = 1,
    *,
    batch_size: int = 4096,
    threads: int | None = None,
    change: Sequence[str] = (),
    output: str = "arrow",
    key_states: str | os.PathLike[str] | None = None,
    spaces: str | os.PathLike[str] | None = None,
    **params: Any,
) -> Iterator[Result]:
    """Simulate what ``run`` simulates, yielding the tables of each batch of runs as it finishes.

    The arguments are ``run``'s (there is no ``out``: nothing is written). Each item is a
    ``Result(runs, series)`` of one batch of at most ``batch_size`` runs, in run order; all the
    items together hold the rows ``run`` returns (but for ``wall_time_s``). Every input is
    checked when ``stream`` is called. The simulation runs in a thread of its own with the GIL
    released, at most two batches ahead of the reader; Ctrl-C while waiting raises
    KeyboardInterrupt and stops it, as does leaving the loop (or ``close()``).

    >>> for runs, series in mbmf.stream(controller="ec", runs=8, batch_size=2, steps=500):
    ...     print(pl.DataFrame(runs)["total_reward"].mean())
    """
    _check_output(output)
    native, warnings = _mbmf.stream(
        task,
        controller,
        runs,
        seed,
        batch_size,
        threads,
        list(change),
        params,
        _path(key_states),
        _path(spaces),
    )
    for warning in warnings:
        _warnings.warn(warning, stacklevel=2)
    return _Stream(native, output)


class _Stream:
    """The iterator ``stream`` returns: each finished batch's ``Result``."""

    def __init__(self, native: Any, output: str) -> None:
        self.native = native
        self.output = output

    def __iter__(self) -> _Stream:
        return self

    def __next__(self) -> Result:
        item = self.native.__next__()
        runs_t, series_t = item
        return Result(_convert(runs_t, self.output), _convert(series_t, self.output))

    def close(self) -> None:
        """Stop the simulation; the iterator ends."""
        self.native.close()

    def __enter__(self) -> _Stream:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()


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


def _filters(where: str | Sequence[str]) -> list[str]:
    """``where`` as a list of filters: one string is one filter, not its characters."""
    return [where] if isinstance(where, str) else list(where)


def _shard(shard: tuple[int, int] | str) -> tuple[int, int]:
    """``shard`` as (INDEX, COUNT): a pair, or ``"INDEX/COUNT"`` as ``--shard`` writes it."""
    if isinstance(shard, str):
        index, sep, count = shard.partition("/")
        try:
            if not sep:
                raise ValueError
            return (int(index), int(count))
        except ValueError:
            raise ValueError(
                f"shard={shard!r}: expected INDEX/COUNT such as \"0/4\", or (INDEX, COUNT)"
            ) from None
    return tuple(shard)  # type: ignore[return-value]


def sweep(
    sweep: str | os.PathLike[str] | dict[str, Any],
    *,
    out: str | os.PathLike[str],
    resume: bool = False,
    shard: tuple[int, int] | str = (0, 1),
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
            _shard(shard),
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
    where: str | Sequence[str] = (),
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
    t, warnings = _mbmf.read(os.fspath(path), table, _filters(where), allow_incomplete)
    for warning in warnings:
        _warnings.warn(warning, stacklevel=2)
    return _convert(t, output)


def min_budget(
    path: str | os.PathLike[str],
    metric: str = "total_reward",
    alpha: float | None = None,
    *,
    where: str | Sequence[str] = (),
    allow_incomplete: bool = False,
    output: str = "arrow",
) -> Any:
    """The smallest budget of each group whose ``metric`` no larger budget beats (one-sided
    tests at level ``alpha``, default 0.05, SPEC 9): the table ``mbmf min-budget`` writes as
    min_budget.parquet, read from the runs of the dataset at ``path``.

    >>> mbmf.min_budget("out/budgets", metric="reward_last10", output="polars")
    """
    _check_output(output)
    t, warnings = _mbmf.min_budget(os.fspath(path), metric, alpha, _filters(where), allow_incomplete)
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


def _data(data: Any) -> Any:
    """A dataset's path as text; anything else (an Arrow table) as given."""
    if isinstance(data, (str, os.PathLike)):
        return os.fspath(data)
    return data


def pareto(
    data: Any,
    objectives: Sequence[str] | str | None = None,
    *,
    by: Sequence[str] | str = (),
    where: str | Sequence[str] = (),
    allow_incomplete: bool = False,
    output: str = "arrow",
) -> Any:
    """The Pareto analysis of ``mbmf pareto``: the table it writes as pareto.parquet.

    ``data`` is a dataset's path (as ``read`` takes) or any runs table with the Arrow PyCapsule
    interface (``mbmf.run(...).runs``, a polars or pyarrow table). ``objectives``: NAME:max or
    NAME:min, a list or comma-separated (``--objectives``; default: the paper's reward, cost
    and learning quality, plus ``interactions:min`` when it varies). ``by``: one front per
    value of these columns (``--by``); a dataset of several tasks or step counts gets a front
    per task and length anyway. One row per configuration and group: its parameters, ``n``,
    ``METRIC_mean`` and ``METRIC_ci95`` of every result, ``rank``, ``front``, ``knee``.

    >>> front = mbmf.pareto("out/kappa", "total_reward:max,cost_total:min", output="polars")
    >>> front.filter(pl.col("front"))
    """
    _check_output(output)
    if isinstance(objectives, str):
        objectives = objectives.split(",")
    if isinstance(by, str):
        by = by.split(",")
    t, warnings = _mbmf.pareto(
        _data(data),
        None if objectives is None else [o.strip() for o in objectives],
        [b.strip() for b in by],
        _filters(where),
        allow_incomplete,
    )
    for warning in warnings:
        _warnings.warn(warning, stacklevel=2)
    return _convert(t, output)


class Stats(NamedTuple):
    """What ``stats`` computes: a row per group, a row per pair of groups, the configuration
    columns that also vary within groups (compare like with like with ``where``), and the
    ``by`` values left out because none of their runs has a value of the metric."""

    groups: Any
    pairs: Any
    also_varying: list[str]
    left_out: list[str]


def stats(
    data: Any,
    by: str,
    metric: str = "total_reward",
    *,
    where: str | Sequence[str] = (),
    allow_incomplete: bool = False,
    output: str = "arrow",
) -> Stats:
    """The comparison of ``mbmf stats --by BY --metric METRIC``: two-sided
    Wilcoxon-Mann-Whitney tests between the groups of runs with each value of ``by``,
    Holm-corrected. ``groups`` has ``BY``, ``n``, ``missing``, ``mean``, ``sd``, ``median``;
    ``pairs`` has ``a``, ``b``, ``u`` (Mann-Whitney U of a), ``p``, ``p_holm``, ``effect``
    (rank-biserial correlation) and ``method`` ("exact" or "normal"). ``data`` as in ``pareto``.

    >>> mbmf.stats("out/run", by="controller", output="polars").pairs
    """
    _check_output(output)
    groups, pairs, mixed, empty, warnings = _mbmf.stats(
        _data(data), by, metric, _filters(where), allow_incomplete
    )
    for warning in warnings:
        _warnings.warn(warning, stacklevel=2)
    return Stats(_convert(groups, output), _convert(pairs, output), list(mixed), list(empty))


class VecEnv:
    """``num_envs`` copies of a task's world for an agent of your own (the EnvPool / gymnax
    shape), with the simulated human of ``run``.

    ``task`` is any task ``run`` takes; the keywords are ``run``'s parameters that shape the
    world and the human (``interaction``, ``budget``, ``forget_prob``, ``profile``, task
    parameters such as ``boxes`` or ``drift_sd``, ``reward_source``), with ``run``'s checks and
    messages. Copy ``i`` draws from the random stream of run ``i`` of master seed ``seed``.

    ``reset(seed=None)`` returns the states (a numpy int64 array of ``num_envs``), restoring
    each human's whole budget. ``step(actions)`` takes one action per copy (integers in
    ``0 .. n_actions - 1``; a bad one raises ValueError naming its index, and nothing moves)
    and returns ``(obs, reward, terminated, truncated, info)``. An episode that ends is reset
    at once: ``obs`` is then the next episode's start and ``info["final_obs"]`` the state
    arrived in. ``truncated`` is set after ``max_episode_steps`` steps (None: never). ``info``
    holds arrays over the copies: ``action`` (the action executed), ``takeover`` (the human
    acted instead of the agent), ``congratulation``, ``punishment``, ``nuisance`` (the human
    undid the action), ``human_reward``, ``forgotten`` (an opportunity missed),
    ``budget_left``, and for a task with drifting rewards (twostep) ``task_state``, one row of
    reward probabilities per copy. There is no babbling and no schedule of changes: the human
    acts from the first step, with one budget over every episode since ``reset``.

    >>> env = mbmf.VecEnv("tidy1", 8, seed=1, interaction="takeover", budget=10)
    >>> obs = env.reset()
    >>> obs, reward, terminated, truncated, info = env.step(np.zeros(8, dtype=np.int64))
    """

    def __init__(
        self,
        task: str = "tidy1",
        num_envs: int = 1,
        seed: int = 1,
        *,
        max_episode_steps: int | None = None,
        key_states: str | os.PathLike[str] | None = None,
        spaces: str | os.PathLike[str] | None = None,
        **params: Any,
    ) -> None:
        self._env = _mbmf.VecEnv(
            task, num_envs, seed, max_episode_steps, params, _path(key_states), _path(spaces)
        )
        self.task = task

    @property
    def num_envs(self) -> int:
        """Copies stepped together."""
        return int(self._env.num_envs)

    @property
    def n_states(self) -> int:
        """States of the task: observations are 0 .. n_states - 1."""
        return int(self._env.n_states)

    @property
    def n_actions(self) -> int:
        """Actions of the task: actions are 0 .. n_actions - 1."""
        return int(self._env.n_actions)

    @property
    def state_names(self) -> list[str]:
        """The name of each state."""
        return list(self._env.state_names)

    def reset(self, seed: int | None = None) -> Any:
        """Start every copy afresh; with ``seed``, restart the random streams from it."""
        return self._env.reset(seed)

    def step(self, actions: Any) -> tuple[Any, Any, Any, Any, dict[str, Any]]:
        """One step of every copy; see the class documentation."""
        import numpy

        a = numpy.asarray(actions)
        if a.shape != (self.num_envs,):
            raise ValueError(
                f"actions: expected shape ({self.num_envs},), one action per environment, "
                f"got {a.shape}"
            )
        if a.dtype.kind not in "iu":
            raise ValueError(f"actions: expected integers, got dtype {a.dtype}")
        if a.dtype.kind == "u" and a.size and int(a.max()) > numpy.iinfo(numpy.int64).max:
            i = int(a.argmax())
            raise ValueError(
                f"action {int(a[i])} at index {i} is out of range: expected 0 to {self.n_actions - 1}"
            )
        return self._env.step(numpy.ascontiguousarray(a, dtype=numpy.int64))
