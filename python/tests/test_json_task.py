"""A json: task takes its keyStates.txt and spaces.txt from elsewhere, as --key-states and
--spaces do."""

from __future__ import annotations

import subprocess

import numpy as np
import polars as pl
import pytest

import mbmf


def test_json_task_files_not_beside_the_model(tmp_path, mbmf_bin) -> None:
    world = tmp_path / "world"
    subprocess.run([str(mbmf_bin), "env", "export", "tidy1", "--json", str(world)],
                   check=True, capture_output=True)
    models = list(world.glob("*.json"))
    assert len(models) == 1
    elsewhere = tmp_path / "elsewhere"
    elsewhere.mkdir()
    (world / "keyStates.txt").rename(elsewhere / "keyStates.txt")
    (world / "spaces.txt").rename(elsewhere / "spaces.txt")
    task = f"json:{models[0]}"
    with pytest.raises(ValueError, match="cannot read .*(keyStates|spaces).txt"):
        mbmf.run(task, controller="mf", runs=1, steps=100)
    files = dict(key_states=elsewhere / "keyStates.txt", spaces=elsewhere / "spaces.txt")
    runs, _ = mbmf.run(task, controller="mf", runs=2, steps=300, babbling=50, output="polars",
                       **files)
    assert runs.height == 2
    cli = tmp_path / "cli"
    subprocess.run([str(mbmf_bin), "run", "--task", task, "--controller", "mf", "--runs", "2",
                    "--steps", "300", "--babbling", "50", "--key-states", str(files["key_states"]),
                    "--spaces", str(files["spaces"]), "--out", str(cli), "-q"],
                   check=True, capture_output=True)
    theirs = pl.read_parquet(cli / "runs.parquet")
    assert runs["total_reward"].to_list() == theirs["total_reward"].to_list()
    parts = list(mbmf.stream(task, controller="mf", runs=2, steps=300, babbling=50, **files))
    assert sum(pl.DataFrame(p.runs).height for p in parts) == 2
    env = mbmf.VecEnv(task, 2, **files)
    assert env.reset().shape == (2,)
    assert env.step(np.zeros(2, dtype=np.int64))[0].shape == (2,)


def test_task_files_only_for_json_tasks() -> None:
    with pytest.raises(ValueError, match="key_states only applies to json:PATH tasks, not 'tidy1'"):
        mbmf.run("tidy1", controller="mf", runs=1, key_states="keyStates.txt")
