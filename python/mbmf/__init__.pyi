# Hand-written stubs of the mbmf package, checked against the module by
# `python -m mypy.stubtest mbmf` (scripts/python-package.sh).
import os
from typing import Any, NamedTuple, Sequence

__all__ = ["Result", "SweepReport", "run", "sweep", "read", "min_budget", "parameters", "CONTROLLERS", "OUTPUTS"]

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
    **params: Any,
) -> Result: ...
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
    shard: tuple[int, int] = (0, 1),
    batch_size: int = 4096,
    threads: int | None = None,
    progress: bool | None = None,
) -> SweepReport: ...
def read(
    path: str | os.PathLike[str],
    table: str = "runs",
    *,
    where: Sequence[str] = (),
    allow_incomplete: bool = False,
    output: str = "arrow",
) -> Any: ...
def min_budget(
    path: str | os.PathLike[str],
    metric: str = "total_reward",
    alpha: float | None = None,
    *,
    where: Sequence[str] = (),
    allow_incomplete: bool = False,
    output: str = "arrow",
) -> Any: ...
def parameters() -> list[tuple[str, str, list[str], str, str, str]]: ...
