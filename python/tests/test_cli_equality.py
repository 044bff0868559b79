"""mbmf.run writes the rows `mbmf run` writes, on every column but wall_time_s."""

from __future__ import annotations

import subprocess

import pyarrow.parquet as pq

import mbmf

ABOUT_THE_WRITING = {"wall_time_s"}


def test_run_equals_the_command_line(tmp_path, mbmf_bin) -> None:
    cli_out = tmp_path / "cli"
    subprocess.run(
        [str(mbmf_bin), "run", "--controller", "ec,mf,fixed", "--interaction", "takeover",
         "--budget", "20", "--steps", "1000", "--babbling", "100", "--runs", "4", "--seed", "7",
         "--w-mb", "0.25", "--change", "500:boxes=brg", "--out", str(cli_out), "-q"],
        check=True, capture_output=True,
    )
    py = mbmf.run(controller=["ec", "mf", "fixed"], interaction="takeover", budget=20, steps=1000,
                  babbling=100, runs=4, seed=7, w_mb=0.25, change=["500:boxes=brg"],
                  output="pyarrow")
    for name, table in zip(["runs", "series"], py):
        cli = pq.read_table(cli_out / f"{name}.parquet")
        keep = [c for c in cli.column_names if c not in ABOUT_THE_WRITING]
        assert table.column_names == cli.column_names
        assert table.schema.remove_metadata() == cli.schema.remove_metadata()
        assert table.num_rows == cli.num_rows == (12 if name == "runs" else 120)
        assert table.select(keep).equals(cli.select(keep)), name
