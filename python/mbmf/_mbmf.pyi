# The native module (python/src/lib.rs); use the wrappers in mbmf/__init__.py.
from typing import Any, Callable

__all__ = ["run", "read", "sweep", "min_budget", "parameters", "CONTROLLERS"]

CONTROLLERS: list[str]

def run(
    task: str,
    controller: Any,
    runs: Any,
    seed: Any,
    out: str | None,
    force: bool,
    batch_size: Any,
    threads: Any,
    change: list[str],
    progress: Callable[[int, int], object] | None,
    params: dict[str, Any] | None,
) -> tuple[Any, Any, list[str]]: ...
def read(
    path: str, table: str, filters: list[str], allow_incomplete: bool
) -> tuple[Any, list[str]]: ...
def min_budget(
    path: str, metric: str, alpha: float | None, filters: list[str], allow_incomplete: bool
) -> tuple[Any, list[str]]: ...
def parameters() -> list[tuple[str, str, list[str], str, str, str]]: ...
def sweep(
    sweep: Any,
    out: str,
    resume: bool,
    shard: tuple[int, int],
    batch_size: Any,
    threads: Any,
    progress: Callable[[int, int], object] | None,
) -> tuple[tuple[str, int, int, int, int, int, float, str], list[str]]: ...
