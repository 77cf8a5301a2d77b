"""The input codec: JSON documents to Structs, strictly, and back.

:func:`read_strict` parses a document, refuses keys written twice
(:mod:`.duplicates`) and checks its shape (:mod:`.strict`), giving every
issue with its field path; :func:`decode_strict` raises them
as one :class:`~fsw_scheduler.errors.InputError`. Both serve every format
that commands (problems, goals, changes, plans, bus inputs); the semantic
rules of each format run on what they return (:mod:`.validation` for the
problem). :func:`encode` is the other direction. Pure: no bus, no clock.
"""

from __future__ import annotations

import re
from typing import TYPE_CHECKING, Any, TypeVar

import msgspec

from ..errors import FieldIssue, InputError
from . import strict
from .duplicates import duplicate_issues
from .limits import key_path

if TYPE_CHECKING:
    from collections.abc import Callable

T = TypeVar("T")

_PATH_RE = re.compile(r"- at `\$(?P<path>[^`]*)`")
_GOT_RE = re.compile(r"got `(?P<got>\w+)`")
_MISSING_RE = re.compile(r"missing required field `(?P<field>\w+)`")
_SEGMENT_RE = re.compile(r"\.(?P<name>\w+)|\[(?P<idx>\d+)\]")
_JSON_TYPES = {
    str: "str",
    bool: "bool",
    int: "int",
    float: "float",
    list: "array",
    dict: "object",
    type(None): "null",
}

#: The reason given for a document nested beyond the decoder's limit.
MAX_DEPTH_NOTE = "nested too deeply to decode"


def _msgspec_issue(error: Exception, data: bytes | str) -> FieldIssue:
    """Turn a msgspec decode error into a FieldIssue with a clean path."""
    text = str(error)
    match = _PATH_RE.search(text)
    path = match.group("path").lstrip(".") if match else ""
    reason = _PATH_RE.sub("", text).strip()
    if "[...]" in path:
        path = _name_the_key(path, text, data)
    return FieldIssue(path, reason)


def _name_the_key(path: str, text: str, data: bytes | str) -> str:
    """``path.<key>...`` for msgspec's ``path[...]...`` (a dictionary value).

    msgspec does not say which key of a dictionary holds the wrong value;
    the key is found again in the document: the first whose value (or the
    part of it the rest of the path names) has the JSON type the error
    says it got, or is an object without the field it says is missing.
    """
    prefix, _, suffix = path.partition("[...]")
    got = _GOT_RE.search(text)
    missing = _MISSING_RE.search(text)
    try:
        node = _walk_path(msgspec.json.decode(data), prefix)
    except (msgspec.DecodeError, RecursionError):
        return path
    if not isinstance(node, dict) or (got is None and missing is None):
        return path
    for key, value in node.items():
        target = _walk_path(value, suffix)
        if got is not None:
            found = _JSON_TYPES.get(type(target)) == got["got"]
        else:
            found = (
                isinstance(target, dict)
                and missing is not None
                and (missing["field"] not in target)
            )
        if found:
            return key_path(prefix, key) + suffix
    return path


def _walk_path(node: object, path: str) -> object:
    """The part of a decoded document at ``path`` (``a.b[2]``), or None."""
    for segment in _SEGMENT_RE.finditer(
        path if path.startswith((".", "[")) or not path else "." + path
    ):
        if segment.group("name") is not None and isinstance(node, dict):
            node = node.get(segment.group("name"))
        elif segment.group("idx") is not None and isinstance(node, list):
            idx = int(segment.group("idx"))
            node = node[idx] if idx < len(node) else None
        else:
            node = None
    return node


def read_strict(
    data: bytes | str,
    kind: type[T],
    what: str,
    *,
    prepare: Callable[[Any], None] | None = None,
) -> tuple[T | None, list[FieldIssue], set[str]]:
    """Parse ``data`` and check it against ``kind`` (:mod:`.strict`).

    ``prepare``, if given, completes the parsed document in place before
    its shape is checked (a default that depends on other fields: a group
    member's schedule cost is its group's).

    Returns
    -------
    value, issues, bad
        ``value`` is the decoded document when ``issues`` is empty;
        otherwise a stand-in with every bad part set aside (for the
        semantic rules to run on the rest; never to be used), or None.
        ``bad`` holds the paths of the issues: semantic findings at or
        under them are about stand-ins.
    """
    try:
        raw = msgspec.json.decode(data)
    except msgspec.DecodeError as error:
        issue = strict.syntax_issue(error, data)
        return None, [issue], {""}
    except RecursionError:
        issue = FieldIssue("", f"{MAX_DEPTH_NOTE} (recursion limit reached)")
        return None, [issue], {""}
    if prepare is not None:
        prepare(raw)
    # Duplicate keys first: msgspec kept the last one without a word.
    issues = duplicate_issues(data, raw) + strict.shape_issues(raw, kind)
    if issues:
        return (
            strict.repaired(raw, kind, issues),
            issues,
            {issue.path for issue in issues},
        )
    try:
        return strict.convert(raw, kind), [], set()
    except msgspec.ValidationError as error:  # a rule in __post_init__
        issue = _msgspec_issue(error, data)
        return None, [issue], {issue.path}


def decode_strict(data: bytes | str, kind: type[T], what: str) -> T:
    """Decode JSON into ``kind``, raising InputError naming every mistake.

    Unknown fields are mistakes (with the closest known name), as are
    keys written twice in one object (:mod:`.duplicates`), wrong types,
    values outside their declared range or enumeration, and missing
    fields: all of them, in one pass (:mod:`.strict`). A document
    nested deeper than the decoder's recursion limit is bad input too.
    """
    value, issues, _ = read_strict(data, kind, what)
    if issues or value is None:
        raise InputError(issues, what)
    return value


def encode(value: object) -> bytes:
    """Encode a model or plan structure as compact JSON."""
    return msgspec.json.encode(value)
