"""Tests that the package keeps its layers: import-linter's contracts hold
and no module takes part in an import cycle, function-level ones included."""

from __future__ import annotations

import ast
import json
import os
import shutil
import subprocess
import sys
import tomllib
from typing import TYPE_CHECKING

import pytest

from ..factories import ROOT, tool

if TYPE_CHECKING:
    from pathlib import Path

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


#: The import-linter contracts of pyproject.toml, by id.
CONTRACTS = {
    c["id"]: c
    for c in tomllib.loads((ROOT / "pyproject.toml").read_text())["tool"][
        "importlinter"
    ]["contracts"]
}


def test_library_contracts_cover_the_whole_package() -> None:
    """Tests that every forbidden contract but the pure core's has the
    whole package as its source, so a new module is covered at once."""
    named = {
        cid: c["source_modules"]
        for cid, c in CONTRACTS.items()
        if c["type"] == "forbidden" and cid != "pure-core"
    }
    assert named
    assert {cid: ["fsw_scheduler"] for cid in named} == named


def test_pure_core_is_every_layer_below_the_engine() -> None:
    """Tests that the pure-core contract names the engine and every layer
    below it (the layers contract is exhaustive, so a new module has one)."""
    layers = CONTRACTS["layers"]["layers"]
    below = layers[layers.index("engine | solving") :]
    names = {
        f"fsw_scheduler.{name.strip()}"
        for layer in below
        for name in layer.split("|")
    }
    pure = set(CONTRACTS["pure-core"]["source_modules"])
    assert pure == names - {"fsw_scheduler.solving"}


#: Names that import a module given as a string or a path, or run code
#: that may: import-linter sees none of these imports.
DYNAMIC = frozenset(
    {
        "__import__",
        "import_module",
        "module_from_spec",
        "exec_module",
        "load_module",
        "run_module",
        "run_path",
        "exec",
        "eval",
    }
)

#: The dynamic imports the package may make, (module, name) -> the reason.
#: None today: importlib.resources and importlib.metadata read data, they
#: import nothing.
DYNAMIC_ALLOWED: dict[tuple[str, str], str] = {}


def dynamic_imports(package: Path) -> set[tuple[str, str]]:
    """(module, name) for each use of a name of ``DYNAMIC`` in ``package``:
    a call, a reference (``f = __import__``) or an import of it."""
    found = set()
    for path in sorted(package.rglob("*.py")):
        for node in ast.walk(ast.parse(path.read_text(), str(path))):
            if isinstance(node, ast.Name):
                names = [node.id]
            elif isinstance(node, ast.Attribute):
                names = [node.attr]
            elif isinstance(node, ast.ImportFrom):
                names = [alias.name for alias in node.names]
            else:
                continue
            module = str(path.relative_to(package))
            found |= {(module, name) for name in names if name in DYNAMIC}
    return found


def test_no_dynamic_import_in_the_package() -> None:
    """Tests that the package imports nothing by name (``__import__``,
    ``importlib.import_module``...) but what DYNAMIC_ALLOWED lists."""
    assert dynamic_imports(PACKAGE) == set(DYNAMIC_ALLOWED)


def _copy_package(root: Path) -> Path:
    """A copy of the package and pyproject.toml under ``root``."""
    shutil.copytree(
        PACKAGE,
        root / "fsw_scheduler",
        ignore=shutil.ignore_patterns("__pycache__"),
    )
    shutil.copy(ROOT / "pyproject.toml", root)
    return root


def _broken_contracts(root: Path) -> tuple[set[str], str]:
    """The ids of the contracts lint-imports finds broken in the package
    under ``root`` (its own checkout), and its report."""
    result = subprocess.run(
        [tool("lint-imports"), "--no-cache"],
        cwd=root,
        capture_output=True,
        text=True,
    )
    by_name = {c["name"]: cid for cid, c in CONTRACTS.items()}
    broken = {
        by_name[line.partition(" BROKEN")[0]]
        for line in result.stdout.splitlines()
        if " BROKEN" in line
    }
    assert result.returncode == (1 if broken else 0), result.stderr
    return broken, result.stdout


#: Violations planted one at a time in a copy of the package: where (the
#: module, appended to if it exists), what, the contracts that must break
#: and a line of lint-imports' report that shows the import.
PLANTED = {
    "pulp-in-incumbent": (
        "solving/incumbent.py",
        "import pulp\n",
        {"one-pulp-user"},
        "fsw_scheduler.solving.incumbent -> pulp",
    ),
    "foxglove-in-engine": (
        "engine/planted.py",
        "import foxglove\n",
        {"foxglove-in-the-view", "pure-core"},
        "fsw_scheduler.engine.planted -> foxglove",
    ),
    "foxglove-in-wire": (
        "wire/planted.py",
        "import foxglove\n",
        {"foxglove-in-the-view", "pure-core"},
        "fsw_scheduler.wire.planted -> foxglove",
    ),
    "new-subpackage": (
        "newpkg/__init__.py",
        "import mcap\nimport pulp\nimport zenoh\n",
        {
            "layers",
            "one-pulp-user",
            "zenoh-in-the-shell",
            "mcap-in-the-journal",
        },
        "- fsw_scheduler.newpkg\n",
    ),
    "zenoh-in-a-function-of-runtime": (
        "runtime/planted.py",
        "def f() -> None:\n    import zenoh\n",
        {"zenoh-in-the-shell"},
        "fsw_scheduler.runtime.planted -> zenoh",
    ),
    "zenoh-in-testing": (
        "testing.py",
        "import zenoh\n",
        {"zenoh-in-the-shell"},
        "fsw_scheduler.testing -> zenoh",
    ),
    "mcap-in-bus": (
        "bus/planted.py",
        "import mcap\n",
        {"mcap-in-the-journal"},
        "fsw_scheduler.bus.planted -> mcap",
    ),
    "matplotlib-in-app": (
        "app/planted.py",
        "import matplotlib\n",
        {"matplotlib-in-the-view"},
        "fsw_scheduler.app.planted -> matplotlib",
    ),
    "rosbags-in-app": (
        "app/planted.py",
        "import rosbags\n",
        {"ros2-in-the-shell"},
        "fsw_scheduler.app.planted -> rosbags",
    ),
    "highspy-in-ilp": (
        "solving/ilp/planted.py",
        "import highspy\n",
        {"one-pulp-user"},
        "fsw_scheduler.solving.ilp.planted -> highspy",
    ),
    "engine-imports-solving": (
        "engine/planted.py",
        "import fsw_scheduler.solving.budget\n",
        {"layers"},
        "fsw_scheduler.engine.planted -> fsw_scheduler.solving.budget",
    ),
    "model-imports-wire": (
        "model/planted.py",
        "from fsw_scheduler.wire import topics\n",
        {"layers", "no-cycles"},  # wire imports model
        "fsw_scheduler.model.planted -> fsw_scheduler.wire.topics",
    ),
}


@pytest.mark.parametrize("case", sorted(PLANTED))
def test_contracts_catch_a_planted_import(case: str, tmp_path: Path) -> None:
    """Tests that an import the contracts forbid, planted in a copy of the
    package, breaks exactly the contracts that forbid it."""
    where, code, contracts, shown = PLANTED[case]
    path = _copy_package(tmp_path) / "fsw_scheduler" / where
    path.parent.mkdir(exist_ok=True)
    with path.open("a") as out:
        out.write(code)
    broken, report = _broken_contracts(tmp_path)
    assert broken == contracts, report
    assert shown in report, report


def test_an_import_by_name_is_caught(tmp_path: Path) -> None:
    """Tests that ``importlib.import_module`` and ``__import__`` in a copy
    of the package pass lint-imports, which cannot see them, and fail the
    AST check; ruff's banned-api sees ``importlib.import_module``."""
    root = _copy_package(tmp_path)
    (root / "fsw_scheduler" / "engine" / "planted.py").write_text(
        '"""Planted: imports by name."""\n\nimport importlib\n\n'
        'NODE = importlib.import_module("fsw_scheduler.bus.node")\n'
        'PULP = __import__("pulp")\n'
    )
    assert _broken_contracts(root)[0] == set()
    found = dynamic_imports(root / "fsw_scheduler") - set(DYNAMIC_ALLOWED)
    assert found == {
        ("engine/planted.py", "import_module"),
        ("engine/planted.py", "__import__"),
    }
    result = subprocess.run(
        [tool("ruff"), "check", "--no-cache", "--output-format=concise", "."],
        cwd=root,
        capture_output=True,
        text=True,
    )
    assert result.returncode == 1
    hits = [line for line in result.stdout.splitlines() if ": TID251 " in line]
    assert hits, result.stdout
    assert all(
        h.startswith("fsw_scheduler/engine/planted.py:5:") for h in hits
    ), result.stdout
    assert "importlib.import_module" in hits[0]


#: What the engine's tests must never import, even inside a test or behind
#: a caught ImportError: the bus, the journal, the pictures. PuLP is not
#: among them: the driver runs the node's real solve (CBC).
ENGINE_TESTS_REFUSE = (
    "zenoh",
    "zenoh_ros2_sdk",
    "rosbags",
    "mcap",
    "matplotlib",
    "foxglove",
)

#: Runs pytest with an import hook that records and refuses the libraries
#: named in argv[1], then prints what was tried and what got loaded.
_REFUSING_PYTEST = """
import json, sys
import pytest

refused = set(sys.argv[1].split(","))
tried = []

class Refuse:
    def find_spec(self, name, path=None, target=None):
        if name.partition(".")[0] in refused:
            tried.append(name)
            raise ModuleNotFoundError(f"{name} is refused here", name=name)
        return None

sys.meta_path.insert(0, Refuse())
code = pytest.main(["-q", "-p", "no:cacheprovider", *sys.argv[2:]])
loaded = sorted(refused & set(sys.modules))
print(json.dumps({"exit": int(code), "tried": sorted(set(tried)),
                  "loaded": loaded}))
"""


def _run_refusing(root: Path, folder: str) -> dict[str, object]:
    """pytest on ``folder`` under ``root`` with ENGINE_TESTS_REFUSE refused:
    its exit code, the refused imports it tried and those it loaded."""
    result = subprocess.run(
        [
            sys.executable,
            "-c",
            _REFUSING_PYTEST,
            ",".join(ENGINE_TESTS_REFUSE),
            folder,
        ],
        cwd=root,
        env={**os.environ, "PYTHONPATH": str(ROOT)},
        capture_output=True,
        text=True,
    )
    assert result.stdout, result.stderr
    verdict: dict[str, object] = json.loads(result.stdout.splitlines()[-1])
    return verdict


def test_engine_tests_run_without_the_bus() -> None:
    """Tests that the engine's tests pass and never try to import Zenoh,
    mcap or a picture library, at the top or inside a test: events in,
    commands out, no bus."""
    verdict = _run_refusing(ROOT, "tests/engine")
    assert verdict == {"exit": 0, "tried": [], "loaded": []}


def test_a_planted_bus_import_in_engine_tests_is_caught(
    tmp_path: Path,
) -> None:
    """Tests that an engine test importing zenoh inside its body, even one
    that skips when it cannot, is seen by the check above."""
    engine = tmp_path / "tests" / "engine"
    engine.mkdir(parents=True)
    (tmp_path / "tests" / "__init__.py").write_text("")
    (engine / "__init__.py").write_text("")
    (engine / "test_planted.py").write_text(
        '"""Planted."""\n\nimport pytest\n\n\n'
        "def test_skips() -> None:\n"
        '    """Tests nothing: skips without zenoh."""\n'
        '    pytest.importorskip("zenoh")\n'
    )
    shutil.copy(ROOT / "pyproject.toml", tmp_path)
    verdict = _run_refusing(tmp_path, "tests/engine")
    assert verdict == {"exit": 0, "tried": ["zenoh"], "loaded": []}
    (engine / "test_planted.py").write_text(
        '"""Planted."""\n\n\ndef test_imports() -> None:\n'
        '    """Tests nothing: imports zenoh."""\n'
        "    import zenoh  # noqa: F401\n"
    )
    verdict = _run_refusing(tmp_path, "tests/engine")
    assert verdict == {"exit": 1, "tried": ["zenoh"], "loaded": []}
