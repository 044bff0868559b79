"""Search EC's kappa_coeff, the human's zeta and budget with Optuna's multi-objective sampler
(maximise reward, minimise inference cost and the human's effort), and compare the front it
finds, and the runs it took, with the grid front of sweeps/kappa.toml.

    pip install optuna            # only this example needs it
    mbmf sweep sweeps/kappa.toml --out out/kappa          # the grid (8,200 runs), optional
    python examples/optuna_kappa.py --trials 60 --grid out/kappa

Each trial is one configuration (kappa_coeff in [0, 20], zeta in [0, 1], budget in 0..100, the
congratulating human of the grid, task 1, 50 runs, master seed 7 as the grid), run with
``mbmf.run``; its objectives are the means of total_reward, cost_total and interactions over its
runs. The front is then computed from every trial's runs by ``mbmf.pareto``, as ``mbmf pareto``
computes the grid's, over the same three objectives.
"""

from __future__ import annotations

import argparse
import math

import optuna
import polars as pl

import mbmf

OBJECTIVES = ["total_reward:max", "cost_total:min", "interactions:min"]
MEANS = ["total_reward_mean", "cost_total_mean", "interactions_mean"]
SIGNS = [-1.0, 1.0, 1.0]  # minimise sign * mean
HUMAN = dict(interaction="congratulation", forget_prob=0.1)


def search(trials: int, runs: int, seed: int, sampler_seed: int) -> tuple[pl.DataFrame, int]:
    """Every trial's runs, and the number of runs simulated."""
    tables: list[pl.DataFrame] = []

    def objective(trial: optuna.Trial) -> tuple[float, float, float]:
        kappa = trial.suggest_float("kappa_coeff", 0.0, 20.0)
        zeta = trial.suggest_float("zeta", 0.0, 1.0)
        budget = trial.suggest_int("budget", 0, 100)
        result = mbmf.run("tidy1", controller="ec", runs=runs, seed=seed, checkpoint=0,
                          kappa_coeff=kappa, zeta=zeta, budget=budget, progress=False,
                          output="polars", **HUMAN)
        table = result.runs
        tables.append(table)
        return (float(table["total_reward"].mean()), float(table["cost_total"].mean()),
                float(table["interactions"].mean()))

    optuna.logging.set_verbosity(optuna.logging.WARNING)
    study = optuna.create_study(directions=["maximize", "minimize", "minimize"],
                                sampler=optuna.samplers.NSGAIISampler(seed=sampler_seed))
    study.optimize(objective, n_trials=trials)
    return pl.concat(tables), trials * runs


def front(table: pl.DataFrame | str, where: list[str]) -> pl.DataFrame:
    result = mbmf.pareto(table, OBJECTIVES, where=where, output="polars")
    return result.filter(pl.col("front")).sort("total_reward_mean", descending=True)


def dominates(a: tuple[float, ...], b: tuple[float, ...]) -> bool:
    """a is no worse than b on every objective and better on one (on the means)."""
    x = [s * v for s, v in zip(SIGNS, a)]
    y = [s * v for s, v in zip(SIGNS, b)]
    return all(p <= q for p, q in zip(x, y)) and any(p < q for p, q in zip(x, y))


def points(f: pl.DataFrame) -> list[tuple[float, ...]]:
    return [tuple(row) for row in f.select(MEANS).iter_rows()]


def show(name: str, f: pl.DataFrame, runs: int) -> None:
    keys = [k for k in ("kappa_coeff", "zeta", "budget") if k in f.columns]
    print(f"{name}: {f.height} front points from {runs} runs")
    print(f.select(keys + MEANS + ["knee"]))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--trials", type=int, default=60)
    parser.add_argument("--runs", type=int, default=50, help="runs per trial (the grid: 50)")
    parser.add_argument("--seed", type=int, default=7, help="master seed of every trial's runs")
    parser.add_argument("--sampler-seed", type=int, default=0)
    parser.add_argument("--grid", help="the dataset of sweeps/kappa.toml (mbmf sweep ... --out)")
    args = parser.parse_args()

    runs, simulated = search(args.trials, args.runs, args.seed, args.sampler_seed)
    found = front(runs, [])
    show("Optuna (NSGA-II)", found, simulated)
    if args.grid is None:
        return
    grid = front(args.grid, ["interaction=congratulation"])
    grid_runs = mbmf.read(args.grid, where=["interaction=congratulation"], output="polars").height
    show("grid (sweeps/kappa.toml, congratulation)", grid, grid_runs)
    mine, theirs = points(found), points(grid)
    beaten = sum(any(dominates(g, p) for g in theirs) for p in mine)
    beating = sum(any(dominates(p, g) for p in mine) for g in theirs)
    print(f"Optuna front points dominated by a grid front point: {beaten} of {len(mine)}")
    print(f"grid front points dominated by an Optuna front point: {beating} of {len(theirs)}")
    best = lambda ps, i: min(SIGNS[i] * p[i] for p in ps) * SIGNS[i]  # noqa: E731
    for i, name in enumerate(MEANS):
        print(f"best {name}: Optuna {best(mine, i):.6g}, grid {best(theirs, i):.6g}")
    if not math.isfinite(best(mine, 0)):
        raise SystemExit("no finite front")


if __name__ == "__main__":
    main()
