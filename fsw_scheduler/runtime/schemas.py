"""The JSON Schema of every message kind, as ``schemas/`` holds them.

Generated from the msgspec types (the bus messages of
:mod:`fsw_scheduler.wire.messages` and the engine's snapshot), so the
files cannot drift from the code: ``fsw-scheduler schemas`` and
``tools/gen_schemas`` write them, a test compares them. Kept apart from the
types, as msgspec keeps its ``_json_schema`` apart, so that the message
module needs nothing above it.
"""

from __future__ import annotations

import inspect
import json
from typing import Any

import msgspec

from ..engine.snapshot import EngineSnapshot
from ..wire.messages import SCHEMA_TYPES


def json_schemas() -> dict[str, dict]:
    """One JSON Schema per message kind, self-contained (``$defs``).

    Returns
    -------
    dict[str, dict]
        Kind name to schema; each has ``title`` and ``$id``.
    """
    schemas = {}
    for name, kind in _all_schema_types().items():
        (ref,), defs = msgspec.json.schema_components([kind])
        if name in STRICT_KINDS:
            for definition in defs.values():
                if "properties" in definition:
                    definition["additionalProperties"] = False
        schema: dict[str, Any] = {
            "$schema": "https://json-schema.org/draft/2020-12/schema",
            "$id": f"fsw_scheduler/{name}.schema.json",
            "title": f"fsw_scheduler.{name}",
            **ref,
            "$defs": defs,
        }
        schemas[name] = _normalise(schema)
    return schemas


#: Documents that command: the scheduler rejects a field it does not know
#: (:mod:`fsw_scheduler.model.strict`), and so do their schemas. Messages it
#: publishes stay open: readers accept fields newer than themselves.
STRICT_KINDS = frozenset(
    {
        "problem",
        "goal",
        "clock",
        "activity_report",
        "resource_level",
        "resource_forecast",
    }
)


def _all_schema_types() -> dict[str, Any]:
    """Bus message kinds plus the journal's engine snapshot."""
    return {**SCHEMA_TYPES, "snapshot": EngineSnapshot}


def schema_files() -> dict[str, str]:
    """File name -> text of every schema, as ``schemas/`` holds them.

    Returns
    -------
    dict[str, str]
        ``<kind>.schema.json`` -> indented JSON with sorted keys and a
        final newline.
    """
    return {
        f"{name}.schema.json": json.dumps(schema, indent=2, sort_keys=True)
        + "\n"
        for name, schema in json_schemas().items()
    }


def _normalise(node: Any, key: str | None = None) -> Any:
    """Make a generated schema independent of the msgspec version.

    msgspec's output changes between releases (0.23 dedents docstrings,
    releases before 0.22 order ``anyOf`` differently). The same code must
    write the same files under every version ``pyproject.toml`` allows, so
    descriptions are cleaned with ``inspect.cleandoc``, keys are sorted, and
    the members of unordered lists (``anyOf``, ``required``) are sorted by
    their canonical JSON text.
    """
    if isinstance(node, dict):
        return {k: _normalise(node[k], k) for k in sorted(node)}
    if isinstance(node, list):
        items = [_normalise(v) for v in node]
        if key in _UNORDERED_KEYWORDS:
            items.sort(key=lambda v: json.dumps(v, sort_keys=True))
        return items
    if isinstance(node, str) and key == "description":
        return inspect.cleandoc(node)
    return node


# JSON Schema keywords whose list order carries no meaning.
_UNORDERED_KEYWORDS = frozenset({"anyOf", "oneOf", "required"})
