"""Tests that classes stay objects that read alone: bounded in size, and
never split across files by inheritance with stubs for the other half."""

from __future__ import annotations

import ast
from dataclasses import dataclass, field
from pathlib import Path

PACKAGE = Path(__file__).resolve().parents[2] / "fsw_scheduler"

#: A class (its in-package bases counted) longer than this does more than
#: one job.
MAX_LINES = 700
#: Methods of a class, its in-package bases counted.
MAX_METHODS = 35
#: Classes allowed over the limits (none): a class that grows past them
#: is split into objects it owns.
KNOWN_SPLIT: dict[str, str] = {}
KNOWN_STUBBED: dict[str, str] = {}


@dataclass
class _Class:
    name: str
    where: str
    lines: int
    methods: set[str]
    bases: list[str]
    stubs: list[str] = field(default_factory=list)


def _raises_not_implemented(node: ast.FunctionDef) -> bool:
    for child in ast.walk(node):
        if isinstance(child, ast.Raise) and child.exc is not None:
            exc = child.exc
            if isinstance(exc, ast.Call):
                exc = exc.func
            if isinstance(exc, ast.Name) and exc.id == "NotImplementedError":
                return True
    return False


def _classes() -> dict[str, _Class]:
    found: dict[str, _Class] = {}
    for path in sorted(PACKAGE.rglob("*.py")):
        tree = ast.parse(path.read_text())
        for node in ast.walk(tree):
            if not isinstance(node, ast.ClassDef):
                continue
            functions = [
                n
                for n in node.body
                if isinstance(n, ast.FunctionDef | ast.AsyncFunctionDef)
            ]
            end = node.end_lineno or node.lineno
            found[node.name] = _Class(
                name=node.name,
                where=f"{path.relative_to(PACKAGE.parent)}:{node.lineno}",
                lines=end - node.lineno + 1,
                methods={f.name for f in functions},
                bases=[
                    b.id if isinstance(b, ast.Name) else ast.unparse(b)
                    for b in node.bases
                ],
                stubs=[
                    f.name
                    for f in functions
                    if isinstance(f, ast.FunctionDef)
                    and _raises_not_implemented(f)
                ],
            )
    return found


def _lineage(name: str, classes: dict[str, _Class]) -> list[_Class]:
    """``name`` and every in-package base it inherits from."""
    seen: list[_Class] = []
    todo = [name]
    while todo:
        current = classes.get(todo.pop())
        if current is None or current in seen:
            continue
        seen.append(current)
        todo.extend(current.bases)
    return seen


def test_no_class_is_too_big_counting_its_in_package_bases() -> None:
    """Tests that no class, with its in-package bases, passes 700 lines or
    35 methods."""
    classes = _classes()
    too_big = []
    for name in classes:
        lineage = _lineage(name, classes)
        lines = sum(c.lines for c in lineage)
        methods = set().union(*(c.methods for c in lineage))
        if lines > MAX_LINES or len(methods) > MAX_METHODS:
            too_big.append((name, classes[name].where, lines, len(methods)))
    assert {n: w.split(":")[0] for n, w, *_ in too_big} == KNOWN_SPLIT, too_big


def test_no_in_package_base_holds_not_implemented_stubs() -> None:
    """Tests that no class inherited from inside the package holds
    ``NotImplementedError`` stubs for a subclass to fill (a mixin that
    needs its host is a split class, not an object)."""
    classes = _classes()
    bases = {b for c in classes.values() for b in c.bases if b in classes}
    stubbed = {
        b: classes[b].where.split(":")[0] for b in bases if classes[b].stubs
    }
    assert stubbed == KNOWN_STUBBED, stubbed
