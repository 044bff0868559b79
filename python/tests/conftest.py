"""Shared helpers: the CLI binary the equality tests compare with."""

from __future__ import annotations

import os
import pathlib

import pytest

REPO = pathlib.Path(__file__).resolve().parents[2]


@pytest.fixture(scope="session")
def mbmf_bin() -> pathlib.Path:
    path = pathlib.Path(os.environ.get("MBMF_BIN", REPO / "target" / "release" / "mbmf"))
    if not path.is_file():
        pytest.fail(f"the mbmf binary is missing at {path}: cargo build --release (or set MBMF_BIN)")
    return path
