"""Tests that the code base stays ruff-clean and type-checks with mypy."""

from __future__ import annotations

import subprocess

from ..factories import ROOT, tool


def test_ruff_is_clean() -> None:
    """Tests that ruff finds nothing (rules in pyproject.toml)."""
    result = subprocess.run(
        [tool("ruff"), "check", "."],
        cwd=ROOT,
        capture_output=True,
        text=True,
    )
    assert result.returncode == 0, result.stdout + result.stderr


def test_mypy_is_clean() -> None:
    """Tests that mypy finds no type error in the package."""
    result = subprocess.run(
        [tool("mypy"), "fsw_scheduler"],
        cwd=ROOT,
        capture_output=True,
        text=True,
    )
    assert result.returncode == 0, result.stdout + result.stderr
