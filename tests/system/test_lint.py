"""Tests that the code base stays ruff-clean and type-checks with mypy."""

from __future__ import annotations

import subprocess
import tomllib

from ..factories import ROOT, TOOLS, tool


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
    """Tests that mypy finds no type error in the package, the tests and
    the tools (the ``files`` of ``[tool.mypy]``)."""
    result = subprocess.run(
        [tool("mypy")],
        cwd=ROOT,
        capture_output=True,
        text=True,
    )
    assert result.returncode == 0, result.stdout + result.stderr


def test_mypy_checks_all_the_python() -> None:
    """Tests that mypy's ``files`` hold the package, the tests and every
    Python file and script of tools/, so a new one is checked at once,
    and that unused ignores are errors everywhere; and that ruff reads
    every script of tools/ as well."""
    mypy = tomllib.loads((ROOT / "pyproject.toml").read_text())["tool"]["mypy"]
    files = set(mypy["files"])
    assert mypy["warn_unused_ignores"] is True
    assert "overrides" not in mypy  # no module is checked more loosely
    python = {
        f"tools/{path.name}"
        for path in TOOLS.iterdir()
        if path.is_file()
        and (
            path.suffix == ".py"
            or path.read_bytes().startswith(b"#!/usr/bin/env python")
        )
    }
    assert len(python) >= 10  # the scripts were found
    assert python | {"fsw_scheduler", "tests", "tools/bench_lib"} <= files
    # Ruff reads only *.py unless told: every script is named for it.
    ruff = tomllib.loads((ROOT / "pyproject.toml").read_text())["tool"]["ruff"]
    scripts = {name for name in python if not name.endswith(".py")}
    assert scripts <= set(ruff["extend-include"])
