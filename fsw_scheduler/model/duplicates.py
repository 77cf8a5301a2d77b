"""Duplicate keys in JSON text: found cheaply, named with both places.

JSON parsers (msgspec and the standard library alike) keep the last of
two equal keys of an object without a word: ``"length": 3, "length": 30``
plans a task of 30 units. A document that commands must never be read
differently from how it was written, so every strict decoder refuses it.

The check costs little on the common document, which has no duplicate:
one regular-expression pass counts the keys of the text (a string followed
by a colon), and a walk of the decoded value counts the entries its
objects kept; the counts are equal exactly when no key was dropped. Only
when they differ does :func:`duplicate_issues` tokenize the text again to
name each duplicate by path, line and column. Pure: the standard library
and msgspec's decoder only.
"""

from __future__ import annotations

import re

import msgspec

from ..errors import FieldIssue
from .limits import id_issue, shown

# Every string of the text, in order, and whether a colon follows it (a
# key). In valid JSON no quote stands outside a string, so scanning from
# the start never begins inside one.
_STRING = re.compile(rb'"[^"\\]*(?:\\.[^"\\]*)*"(\s*:)?')
_TOKEN = re.compile(
    rb'\s*(?:(?P<str>"(?:[^"\\]|\\.)*")|(?P<punct>[{}\[\],:])'
    rb'|(?P<atom>[^\s{}\[\],:"]+))'
)


def count_text_keys(data: bytes) -> int:
    """How many object keys the (valid) JSON text ``data`` writes."""
    return sum(map(bool, _STRING.findall(data)))


def count_kept_keys(value: object) -> int:
    """How many object entries the decoded ``value`` holds, at any depth."""
    count = 0
    stack = [value]
    pop, extend = stack.pop, stack.extend
    while stack:
        node = pop()
        # Exact types: decoded JSON holds no subclasses, and this loop is
        # on the path of every input.
        if type(node) is dict:
            count += len(node)
            extend(node.values())
        elif type(node) is list:
            extend(node)
    return count


def duplicate_issues(data: bytes | str, value: object) -> list[FieldIssue]:
    """One issue per key written twice (or more) in an object of ``data``.

    Parameters
    ----------
    data
        The JSON text, already known to be valid.
    value
        ``data`` as decoded (dicts, lists, scalars).

    Returns
    -------
    list of FieldIssue
        In document order, at the path of the repeated key, saying where
        each occurrence is; empty when no object repeats a key.
    """
    text = data.encode() if isinstance(data, str) else data
    if count_text_keys(text) == count_kept_keys(value):
        return []
    return _name_duplicates(text)


def _join(path: str, key: str) -> str:
    if id_issue(key) is not None:
        return f"{path}[{shown(key, 20)}]"
    return f"{path}.{key}" if path else key


def _place(text: bytes, offset: int) -> str:
    head = text[:offset]
    line = head.count(b"\n") + 1
    column = offset - (head.rfind(b"\n") + 1) + 1
    return f"line {line}, column {column}"


class _Object:
    """An object being read: its path, the keys seen, the pending key."""

    __slots__ = ("key", "path", "seen")

    def __init__(self, path: str) -> None:
        self.path = path
        self.seen: dict[str, list[int]] = {}
        self.key: str | None = None


class _Array:
    """An array being read: its path and the index of the next item."""

    __slots__ = ("index", "path")

    def __init__(self, path: str) -> None:
        self.path = path
        self.index = 0


def _name_duplicates(text: bytes) -> list[FieldIssue]:
    """Tokenize ``text`` and name every repeated key (the slow path)."""
    found: list[tuple[int, FieldIssue]] = []
    stack: list[_Object | _Array] = []

    def here() -> str:
        """The path of the value that comes next."""
        if not stack:
            return ""
        top = stack[-1]
        if isinstance(top, _Array):
            return f"{top.path}[{top.index}]"
        return _join(top.path, top.key or "")

    def close(frame: _Object | _Array) -> None:
        if not isinstance(frame, _Object):
            return
        for key, offsets in frame.seen.items():
            if len(offsets) > 1:
                places = [_place(text, offset) for offset in offsets]
                found.append(
                    (
                        offsets[0],
                        FieldIssue(
                            _join(frame.path, key),
                            f"key {key!r} is written {len(offsets)} times "
                            f"in one object (at {', '.join(places[:-1])} "
                            f"and {places[-1]}); JSON would keep only the "
                            "last: write it once",
                        ),
                    )
                )

    for match in _TOKEN.finditer(text):
        punct = match.group("punct")
        top = stack[-1] if stack else None
        if punct in (b"{", b"["):
            path = here()
            stack.append(_Object(path) if punct == b"{" else _Array(path))
        elif punct in (b"}", b"]"):
            if stack:
                close(stack.pop())
        elif punct == b",":
            if isinstance(top, _Array):
                top.index += 1
            elif isinstance(top, _Object):
                top.key = None
        elif (
            match.group("str") is not None
            and isinstance(top, _Object)
            and top.key is None
        ):
            key = msgspec.json.decode(match.group("str"), type=str)
            top.seen.setdefault(key, []).append(match.start("str"))
            top.key = key
    found.sort(key=lambda item: item[0])
    return [issue for _, issue in found]
