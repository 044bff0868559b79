# Hand-written stubs of the mbmf package, checked against the module by
# `python -m mypy.stubtest mbmf` (scripts/python-package.sh).
import os
from typing import Any, Iterator, NamedTuple, Sequence

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

CONTROLLERS: tuple[str, ...]
OUTPUTS: tuple[str, ...]

class Result(NamedTuple):
    runs: Any
    series: Any

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
) -> Result: ...
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
) -> Iterator[Result]: ...

class _Stream:
    native: Any
    output: str
    def __init__(self, native: Any, output: str) -> None: ...
    def __iter__(self) -> _Stream: ...
    def __next__(self) -> Result: ...
    def close(self) -> None: ...
    def __enter__(self) -> _Stream: ...
    def __exit__(self, *exc: object) -> None: ...

class SweepReport(NamedTuple):
    out: str
    total: int
    shard_runs: int
    done_before: int
    ran: int
    parts_written: int
    seconds: float
    line: str

class _Bar:
    progress: bool | None
    bar: Any
    def __init__(self, progress: bool | None) -> None: ...
    def __call__(self, n: int, total: int) -> None: ...
    def close(self) -> None: ...

def sweep(
    sweep: str | os.PathLike[str] | dict[str, Any],
    *,
    out: str | os.PathLike[str],
    resume: bool = False,
    shard: tuple[int, int] | str = (0, 1),
    batch_size: int = 4096,
    threads: int | None = None,
    progress: bool | None = None,
) -> SweepReport: ...
def read(
    path: str | os.PathLike[str],
    table: str = "runs",
    *,
    where: str | Sequence[str] = (),
    allow_incomplete: bool = False,
    output: str = "arrow",
) -> Any: ...
def min_budget(
    path: str | os.PathLike[str],
    metric: str = "total_reward",
    alpha: float | None = None,
    *,
    where: str | Sequence[str] = (),
    allow_incomplete: bool = False,
    output: str = "arrow",
) -> Any: ...
def parameters() -> list[tuple[str, str, list[str], str, str, str]]: ...
def pareto(
    data: Any,
    objectives: Sequence[str] | str | None = None,
    *,
    by: Sequence[str] | str = (),
    where: str | Sequence[str] = (),
    allow_incomplete: bool = False,
    output: str = "arrow",
) -> Any: ...

class Stats(NamedTuple):
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
) -> Stats: ...

class VecEnv:
    task: str
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
    ) -> None: ...
    @property
    def num_envs(self) -> int: ...
    @property
    def n_states(self) -> int: ...
    @property
    def n_actions(self) -> int: ...
    @property
    def state_names(self) -> list[str]: ...
    def reset(self, seed: int | None = None) -> Any: ...
    def step(self, actions: Any) -> tuple[Any, Any, Any, Any, dict[str, Any]]: ...
