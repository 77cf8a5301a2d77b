"""Tests that no module of the package reaches into another one's private
names: what one module needs of another is public and documented there."""

from __future__ import annotations

import ast
from typing import TYPE_CHECKING

from ..factories import ROOT

if TYPE_CHECKING:
    from pathlib import Path

PACKAGE = ROOT / "fsw_scheduler"


def _private(name: str) -> bool:
    """``_name`` (not a dunder such as ``__version__``)."""
    return name.startswith("_") and not (
        name.startswith("__") and name.endswith("__")
    )


def _inside(node: ast.ImportFrom) -> bool:
    """Whether an import names a module of the package."""
    module = node.module or ""
    return node.level > 0 or module.split(".")[0] == "fsw_scheduler"


def _modules() -> list[tuple[str, ast.Module]]:
    """Every module of the package: its path (for messages) and its AST."""
    paths: list[Path] = sorted(PACKAGE.rglob("*.py"))
    assert paths, PACKAGE
    return [
        (str(path.relative_to(ROOT)), ast.parse(path.read_text()))
        for path in paths
    ]


def _source(node: ast.ImportFrom) -> str:
    """The module an import names, as written (``..model.levels``)."""
    return "." * node.level + (node.module or "")


def _root(node: ast.expr) -> str | None:
    """The name a dotted expression starts from (``a`` of ``a.b.c``)."""
    while isinstance(node, ast.Attribute):
        node = node.value
    return node.id if isinstance(node, ast.Name) else None


def test_no_private_name_is_imported_from_another_module() -> None:
    """Tests that no ``from ... import _name`` inside the package takes a
    private name of one of its modules (dunders are fine)."""
    found = [
        f"{where}:{node.lineno}: from {_source(node)} import {alias.name}"
        for where, tree in _modules()
        for node in ast.walk(tree)
        if isinstance(node, ast.ImportFrom) and _inside(node)
        for alias in node.names
        if _private(alias.name)
    ]
    assert found == [], "\n".join(found)


def test_no_private_attribute_of_an_imported_name_is_read() -> None:
    """Tests that no ``name._private`` (or ``name.part._private``) is read
    where ``name`` was imported from the package (``from . import problem
    as model``, then ``model._check_task``)."""
    found = []
    for where, tree in _modules():
        imported = {
            alias.asname or alias.name
            for node in ast.walk(tree)
            if isinstance(node, ast.ImportFrom) and _inside(node)
            for alias in node.names
        } | {
            alias.asname or alias.name.split(".")[0]
            for node in ast.walk(tree)
            if isinstance(node, ast.Import)
            for alias in node.names
            if alias.name.split(".")[0] == "fsw_scheduler"
        }
        found += [
            f"{where}:{node.lineno}: {ast.unparse(node)}"
            for node in ast.walk(tree)
            if isinstance(node, ast.Attribute)
            and _private(node.attr)
            and _root(node.value) in imported
        ]
    assert found == [], "\n".join(found)
