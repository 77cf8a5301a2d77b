"""Tests that the package keeps its layers: import-linter's contracts hold
and no module takes part in an import cycle, function-level ones included."""

from __future__ import annotations

import subprocess
import sys

import pytest

from ..factories import ROOT, tool

PACKAGE = ROOT / "fsw_scheduler"


def test_import_contracts_hold() -> None:
    """Tests that every import-linter contract in pyproject.toml is kept."""
    result = subprocess.run(
        [tool("lint-imports"), "--no-cache"],
        cwd=ROOT,
        capture_output=True,
        text=True,
    )
    assert result.returncode == 0, result.stdout + result.stderr
    assert "0 broken" in result.stdout


def _graph() -> dict[str, set[str]]:
    """Module -> the package modules it imports (any level, not typing)."""
    grimp = pytest.importorskip("grimp")
    graph = grimp.build_graph(
        "fsw_scheduler", exclude_type_checking_imports=True
    )
    return {
        m: set(graph.find_modules_directly_imported_by(m))
        for m in graph.modules
    }


def test_no_import_cycle_between_modules() -> None:
    """Tests that no module reaches itself through imports (Tarjan's SCCs);
    a package's own __init__ re-exporting its modules is not a cycle."""
    edges = _graph()
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    on: set[str] = set()
    cycles: list[list[str]] = []
    counter = [0]

    def visit(v: str) -> None:
        index[v] = low[v] = counter[0]
        counter[0] += 1
        stack.append(v)
        on.add(v)
        for w in edges.get(v, ()):
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in on:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            scc = []
            while True:
                w = stack.pop()
                on.discard(w)
                scc.append(w)
                if w == v:
                    break
            if len(scc) > 1:
                cycles.append(sorted(scc))

    for v in sorted(edges):
        if v not in index:
            visit(v)
    assert cycles == []


def test_top_of_the_package_is_small() -> None:
    """Tests that at most 8 plain modules sit at the package top and that
    no module is over 800 lines."""
    top = sorted(p.name for p in PACKAGE.glob("*.py"))
    assert len(top) <= 8, top
    long = {
        str(p.relative_to(ROOT)): n
        for p in PACKAGE.rglob("*.py")
        if (n := len(p.read_text().splitlines())) > 800
    }
    assert long == {}


def test_module_map_matches_the_tree() -> None:
    """Tests that the module map of docs/architecture.md lists every
    module, and only modules that exist, each with its docstring's first
    line."""
    import ast
    import re

    text = (ROOT / "docs" / "architecture.md").read_text()
    block = text.split("<!-- module-map -->")[1].split("<!-- /module-map -->")[
        0
    ]
    listed: dict[str, str] = {}
    folder = ""
    for line in block.splitlines():
        top = re.match(r"^  (\S+\.py)\s+(.*)$", line)
        sub = re.match(r"^  (\S+/)$", line)
        mod = re.match(r"^    (\S+\.py)\s+(.*)$", line)
        if sub:
            folder = sub.group(1)
        elif top:
            listed[top.group(1)] = top.group(2)
        elif mod:
            listed[folder + mod.group(1)] = mod.group(2)
    files = {
        str(p.relative_to(PACKAGE)): p
        for p in PACKAGE.rglob("*.py")
        if p.name != "__init__.py" or p.parent == PACKAGE
    }
    assert set(listed) == set(files)
    for name, summary in listed.items():
        doc = ast.get_docstring(ast.parse(files[name].read_text())) or ""
        first = doc.splitlines()[0].rstrip(".") if doc else ""
        prefix = summary.rstrip(". ").removesuffix("...").rstrip(", ")
        assert first.startswith(prefix), (name, summary, first)


#: Test folders that mirror no subpackage: project-wide checks (lint,
#: layers, documentation, benchmarks, soak).
PROJECT_WIDE = {"system"}


def test_tests_mirror_the_package() -> None:
    """Tests that each test folder is named after a subpackage (or is a
    project-wide one) and that only the top modules' tests sit at the top."""
    tests = ROOT / "tests"
    subpackages = {p.parent.name for p in PACKAGE.glob("*/__init__.py")}
    folders = {p.parent.name for p in tests.glob("*/__init__.py")}
    assert folders - subpackages - PROJECT_WIDE == set()
    top = {p.stem.removeprefix("test_") for p in tests.glob("test_*.py")}
    modules = {p.stem for p in PACKAGE.glob("*.py")}
    assert top <= modules, top - modules
    for path in tests.glob("*/**/*.py"):
        assert (path.parent / "__init__.py").exists(), path


def test_engine_tests_run_without_zenoh() -> None:
    """Tests that the engine's tests import with Zenoh made unimportable:
    events in, commands out, no bus."""
    code = (
        "import sys, pathlib, importlib\n"
        "sys.modules['zenoh'] = None\n"
        "for path in sorted(pathlib.Path('tests/engine').glob('*.py')):\n"
        "    importlib.import_module('tests.engine.' + path.stem)\n"
        "assert sys.modules['zenoh'] is None\n"
    )
    result = subprocess.run(
        [sys.executable, "-c", code], cwd=ROOT, capture_output=True, text=True
    )
    assert result.returncode == 0, result.stderr
