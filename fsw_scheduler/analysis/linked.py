"""Sets of names that pairs link: independent parts, bundles (pure).

One union-find for every caller that asks which tasks hang together:
:func:`~fsw_scheduler.solving.solve.components` (independent parts) and
:func:`~fsw_scheduler.analysis.greedy.bundles` (tasks kept together).
"""

from __future__ import annotations

from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from collections.abc import Iterable


def linked(
    names: Iterable[str], pairs: Iterable[tuple[str, str]]
) -> list[list[str]]:
    """The sets of ``names`` that ``pairs`` link, directly or through
    others, each in the order of ``names`` and listed by its first name
    (the same sets and order for the same input: no hashing order)."""
    order = list(names)
    parent = {name: name for name in order}

    def find(name: str) -> str:
        while parent[name] != name:
            parent[name] = parent[parent[name]]
            name = parent[name]
        return name

    for a, b in pairs:
        root_a, root_b = find(a), find(b)
        if root_a != root_b:
            parent[max(root_a, root_b)] = min(root_a, root_b)
    sets: dict[str, list[str]] = {}
    for name in order:
        sets.setdefault(find(name), []).append(name)
    return list(sets.values())
