# The native module (python/src/lib.rs); use the wrappers in mbmf/__init__.py.
from typing import Any, Callable, final

__all__ = [
    "run",
    "read",
    "sweep",
    "min_budget",
    "parameters",
    "pareto",
    "stats",
    "stream",
    "Stream",
    "VecEnv",
    "CONTROLLERS",
]

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
    key_states: str | None = None,
    spaces: str | None = None,
) -> tuple[Any, Any, list[str]]: ...
def stream(
    task: str,
    controller: Any,
    runs: Any,
    seed: Any,
    batch_size: Any,
    threads: Any,
    change: list[str],
    params: dict[str, Any] | None,
    key_states: str | None = None,
    spaces: str | None = None,
) -> tuple[Stream, list[str]]: ...

@final
class Stream:
    def __iter__(self) -> Stream: ...
    def __next__(self) -> tuple[Any, Any]: ...
    def close(self) -> None: ...
    @property
    def runs(self) -> int: ...

def pareto(
    data: Any,
    objectives: list[str] | None,
    by: list[str],
    filters: list[str],
    allow_incomplete: bool,
) -> tuple[Any, list[str]]: ...
def stats(
    data: Any, by: str, metric: str, filters: list[str], allow_incomplete: bool
) -> tuple[Any, Any, list[str], list[str], list[str]]: ...

@final
class VecEnv:
    def __new__(
        cls,
        task: str,
        num_envs: Any,
        seed: Any,
        max_episode_steps: Any,
        params: dict[str, Any] | None,
        key_states: str | None = None,
        spaces: str | None = None,
    ) -> VecEnv: ...
    def reset(self, seed: Any = None) -> Any: ...
    def step(self, actions: Any) -> tuple[Any, Any, Any, Any, dict[str, Any]]: ...
    @property
    def num_envs(self) -> int: ...
    @property
    def n_states(self) -> int: ...
    @property
    def n_actions(self) -> int: ...
    @property
    def state_names(self) -> list[str]: ...
    @property
    def task_state(self) -> Any: ...

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
