"""Strict reading of input documents: every mistake, named, in one pass.

msgspec decodes fast but stops at the first error and, without
``forbid_unknown_fields``, ignores a misspelt field: a task with
``"feasable_interval"`` would be scheduled anywhere. Input structs keep
unknown fields allowed (readers of recordings accept fields newer than
themselves); the documents that command are read here instead:

1. the JSON text is parsed (a syntax error says line and column);
2. :func:`shape_issues` walks the parsed value against the target type,
   as :func:`msgspec.inspect.type_info` describes it, and collects every
   unknown field (with the closest known name), missing field, wrong type,
   value outside its declared range, length or pattern (the ``Meta`` of
   the type, the same constraint the JSON Schema carries), and value
   outside an enumeration (listing the allowed ones);
3. :func:`repaired` gives a copy with every bad part set aside, so that
   the semantic rules can still run on the rest and their findings are
   reported with the shape's.

Pure: no bus, no clock.
"""

from __future__ import annotations

import difflib
import math
import re
from typing import Any

import msgspec
from msgspec import inspect as mi

from ..errors import FieldIssue
from .limits import HORIZON_WHY, MAX_HORIZON

#: JSON names of Python values, as users write them.
_JSON_NAMES = {
    bool: "a boolean",
    int: "an integer",
    float: "a number",
    str: "a string",
    list: "an array",
    dict: "an object",
    type(None): "null",
}
_SHOWN = 40  # characters of a value quoted in a reason
_WIDE = 2**30  # a range this wide is told as an interval, not a list

_INFOS: dict[object, mi.Type] = {}


def type_info(kind: object) -> mi.Type:
    """The msgspec description of ``kind``, built once per type."""
    info = _INFOS.get(kind)
    if info is None:
        info = _INFOS[kind] = mi.type_info(kind)
    return info


def line_column(text: bytes | str, offset: int) -> tuple[int, int]:
    """1-based line and column of byte ``offset`` in ``text``."""
    data = text.encode() if isinstance(text, str) else text
    head = data[: max(offset, 0)]
    line = head.count(b"\n") + 1
    column = len(head) - (head.rfind(b"\n") + 1) + 1
    return line, column


_BYTE_RE = re.compile(r"\(byte (\d+)\)")


#: A JSON number with an exponent: the only kind that can exceed a float.
_EXPONENT_RE = re.compile(rb"-?\d+(?:\.\d+)?[eE][+-]?\d+")


def syntax_issue(error: msgspec.DecodeError, text: bytes | str) -> FieldIssue:
    """A JSON syntax error, placed by line and column."""
    message = str(error)
    match = _BYTE_RE.search(message)
    if match is None and message.startswith("Number out of range"):
        # The decoder names no place for a number past a float's range
        # (1e999): find it, so the sender knows which one.
        return _out_of_range(text) or FieldIssue("", message)
    if match is None:
        return FieldIssue("", message)
    line, column = line_column(text, int(match.group(1)))
    reason = _BYTE_RE.sub("", message).strip().rstrip(".")
    return FieldIssue("", f"{reason} at line {line}, column {column}")


def _out_of_range(text: bytes | str) -> FieldIssue | None:
    """The first number of ``text`` beyond a 64-bit float, placed by line
    and column; None if there is none."""
    data = text.encode() if isinstance(text, str) else text
    for found in _EXPONENT_RE.finditer(data):
        if math.isinf(float(found.group())):
            line, column = line_column(data, found.start())
            literal = found.group().decode()
            return FieldIssue(
                "",
                f"number {literal[:_SHOWN]} is beyond the range of a "
                f"64-bit float at line {line}, column {column}",
            )
    return None


def _shown(value: object) -> str:
    text = repr(value)
    return text if len(text) <= _SHOWN else text[: _SHOWN - 3] + "..."


def _name(value: object) -> str:
    return _JSON_NAMES.get(type(value), type(value).__name__)


def _join(path: str, key: str) -> str:
    return f"{path}.{key}" if path else key


def suggestion(word: str, known: list[str]) -> str:
    """`` (did you mean 'x'?)`` for the closest of ``known``, or ``""``."""
    close = difflib.get_close_matches(word, known, n=1, cutoff=0.6)
    return f" (did you mean {close[0]!r}?)" if close else ""


def shape_issues(value: object, kind: object) -> list[FieldIssue]:
    """Every way ``value`` (parsed JSON) does not fit ``kind``.

    Parameters
    ----------
    value
        The parsed document (dicts, lists, strings, numbers).
    kind
        The type it must have (a Struct, a tagged union of Structs, ...).

    Returns
    -------
    list of FieldIssue
        In document order; empty when ``msgspec.convert`` will accept it.
    """
    issues: list[FieldIssue] = []
    _check(value, type_info(kind), "", issues)
    return issues


def _check(
    value: object, info: mi.Type, path: str, out: list[FieldIssue]
) -> None:
    if isinstance(info, mi.Metadata):
        before = len(out)
        _check(value, info.type, path, out)
        about = (info.extra_json_schema or {}).get("description")
        if about and len(out) > before and out[-1].path == path:
            out[-1] = FieldIssue(path, f"{out[-1].reason}: {about}")
    elif isinstance(info, mi.AnyType):
        return
    elif isinstance(info, mi.UnionType):
        _check_union(value, info, path, out)
    elif isinstance(info, mi.StructType):
        _check_struct(value, info, path, out)
    elif isinstance(info, mi.LiteralType):
        if value not in info.values or isinstance(value, bool):
            allowed = ", ".join(repr(v) for v in info.values)
            hint = (
                suggestion(value, [str(v) for v in info.values])
                if isinstance(value, str)
                else ""
            )
            out.append(
                FieldIssue(
                    path,
                    f"must be one of {allowed}, got {_shown(value)}{hint}",
                )
            )
    elif isinstance(info, (mi.NoneType, mi.BoolType)):
        if not _kind_fits(value, info):
            _kind_issue(value, info, path, out)
    elif isinstance(info, (mi.IntType, mi.FloatType)):
        _check_number(value, info, path, out)
    elif isinstance(info, mi.StrType):
        _check_str(value, info, path, out)
    elif isinstance(
        info, (mi.ListType, mi.VarTupleType, mi.SetType, mi.FrozenSetType)
    ):
        _check_array(value, info, path, out)
    elif isinstance(info, mi.TupleType):
        _check_tuple(value, info, path, out)
    elif isinstance(info, mi.DictType):
        _check_dict(value, info, path, out)
    else:  # a type without a walker here: msgspec decides
        _check_by_convert(value, info, path, out)


def _check_by_convert(
    value: object, info: mi.Type, path: str, out: list[FieldIssue]
) -> None:
    cls = getattr(info, "cls", None)
    if cls is None:
        return
    try:
        msgspec.convert(value, cls)
    except msgspec.ValidationError as error:
        out.append(FieldIssue(path, str(error).split(" - at ")[0]))


def _check_number(
    value: object,
    info: mi.IntType | mi.FloatType,
    path: str,
    out: list[FieldIssue],
) -> None:
    integer = isinstance(info, mi.IntType)
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        want = "an integer" if integer else "a number"
        out.append(FieldIssue(path, f"must be {want}, got {_name(value)}"))
        return
    # 5.0 and 1e1 are integers to JSON Schema (a number whose fraction is
    # zero), so they are to the scheduler too; read_strict converts them.
    if (
        integer
        and isinstance(value, float)
        and not (math.isfinite(value) and value.is_integer())
    ):
        out.append(
            FieldIssue(path, f"must be an integer, got {_shown(value)}")
        )
        return
    if isinstance(value, float) and not math.isfinite(value):
        out.append(FieldIssue(path, f"must be finite, got {value}"))
        return
    low, high = info.ge, info.le
    if low is not None and high is not None:
        if not low <= value <= high:
            # A number of hundreds of digits is shown cut, not whole.
            shown = _shown(value)
            reason = (
                f"must be in {low}..{high}, got {shown}"
                if high - low < _WIDE
                else f"{shown} is outside [{low}, {high}]"
            )
            if (
                value > high == MAX_HORIZON
                and path.rsplit(".", 1)[-1] == "horizon"
            ):
                reason += f": the longest horizon; {HORIZON_WHY}"
            out.append(FieldIssue(path, reason))
        return
    for bound, test, words in (
        (info.ge, lambda b: value >= b, ">="),
        (info.gt, lambda b: value > b, ">"),
        (info.le, lambda b: value <= b, "<="),
        (info.lt, lambda b: value < b, "<"),
    ):
        if bound is not None and not test(bound):
            out.append(
                FieldIssue(path, f"must be {words} {bound}, got {value}")
            )
            return
    multiple = info.multiple_of
    if multiple is not None and value % multiple:
        out.append(
            FieldIssue(path, f"must be a multiple of {multiple}, got {value}")
        )


def _check_str(
    value: object, info: mi.StrType, path: str, out: list[FieldIssue]
) -> None:
    if not isinstance(value, str):
        _kind_issue(value, info, path, out)
        return
    before = len(out)
    _check_length(len(value), info, "characters", path, out)
    if len(out) > before:
        return  # one issue per value
    if info.pattern is not None and re.search(info.pattern, value) is None:
        out.append(
            FieldIssue(
                path,
                f"{_shown(value)} does not match the pattern {info.pattern!r}",
            )
        )


_ONE = {"items": "item", "characters": "character", "entries": "entry"}


def _check_length(
    size: int, info: Any, unit: str, path: str, out: list[FieldIssue]
) -> None:
    low, high = info.min_length, info.max_length
    if low is not None and size < low:
        named = _ONE.get(unit, unit) if low == 1 else unit
        out.append(
            FieldIssue(path, f"needs at least {low} {named}, got {size}")
        )
    if high is not None and size > high:
        out.append(
            FieldIssue(path, f"holds at most {high} {unit}, got {size}")
        )


def _check_array(
    value: object, info: Any, path: str, out: list[FieldIssue]
) -> None:
    if not isinstance(value, list):
        _kind_issue(value, info, path, out)
        return
    _check_length(len(value), info, "items", path, out)
    for index, item in enumerate(value):
        _check(item, info.item_type, f"{path}[{index}]", out)


def _check_tuple(
    value: object, info: mi.TupleType, path: str, out: list[FieldIssue]
) -> None:
    if not isinstance(value, list):
        _kind_issue(value, info, path, out)
        return
    if len(value) != len(info.item_types):
        out.append(
            FieldIssue(
                path,
                f"must hold exactly {len(info.item_types)} items, "
                f"got {len(value)}",
            )
        )
        return
    for index, (item, item_type) in enumerate(zip(value, info.item_types)):
        _check(item, item_type, f"{path}[{index}]", out)


def _check_dict(
    value: object, info: mi.DictType, path: str, out: list[FieldIssue]
) -> None:
    if not isinstance(value, dict):
        _kind_issue(value, info, path, out)
        return
    _check_length(len(value), info, "entries", path, out)
    for key, item in value.items():
        here = _join(path, key) if isinstance(key, str) else f"{path}[{key!r}]"
        key_issues: list[FieldIssue] = []
        _check(key, info.key_type, here, key_issues)
        out.extend(FieldIssue(i.path, f"key {i.reason}") for i in key_issues)
        _check(item, info.value_type, here, out)


def _check_struct(
    value: object, info: mi.StructType, path: str, out: list[FieldIssue]
) -> None:
    if not isinstance(value, dict):
        _kind_issue(value, info, path, out)
        return
    fields = {f.encode_name: f for f in info.fields}
    tag_field = info.tag_field
    for key in value:
        if key in fields or key == tag_field:
            continue
        known = sorted(fields)
        out.append(
            FieldIssue(
                _join(path, str(key)),
                f"unknown field{suggestion(str(key), known)}; the fields "
                f"are {', '.join(known)}",
            )
        )
    for name, field in fields.items():
        if name in value:
            _check(value[name], field.type, _join(path, name), out)
        elif field.required:
            out.append(FieldIssue(_join(path, name), "missing required field"))


def _check_union(
    value: object, info: mi.UnionType, path: str, out: list[FieldIssue]
) -> None:
    members = list(info.types)
    if value is None and any(isinstance(t, mi.NoneType) for t in members):
        return
    structs = [t for t in members if isinstance(t, mi.StructType)]
    tagged = [t for t in structs if t.tag_field is not None]
    if tagged and isinstance(value, dict):
        field = tagged[0].tag_field
        tags = {str(t.tag): t for t in tagged}
        tag = value.get(field)
        if tag in tags:
            _check_struct(value, tags[str(tag)], path, out)
        else:
            hint = (
                suggestion(tag, sorted(tags)) if isinstance(tag, str) else ""
            )
            out.append(
                FieldIssue(
                    _join(path, str(field)),
                    f"must be one of {', '.join(map(repr, sorted(tags)))}, "
                    f"got {_shown(tag)}{hint}",
                )
            )
        return
    # The members whose JSON kind the value has; the fewest issues wins.
    fitting = [m for m in members if _kind_fits(value, m)]
    if not fitting:
        names = sorted({_TYPE_NAMES.get(type(m), "a value") for m in members})
        out.append(
            FieldIssue(
                path, f"must be {' or '.join(names)}, got {_name(value)}"
            )
        )
        return
    best: list[FieldIssue] | None = None
    for member in fitting:
        trial: list[FieldIssue] = []
        _check(value, member, path, trial)
        if not trial:
            return
        if best is None or len(trial) < len(best):
            best = trial
    if best is not None:
        out.extend(best)


_TYPE_NAMES: dict[type, str] = {
    mi.BoolType: "a boolean",
    mi.IntType: "an integer",
    mi.FloatType: "a number",
    mi.StrType: "a string",
    mi.LiteralType: "a string",
    mi.ListType: "an array",
    mi.TupleType: "an array",
    mi.VarTupleType: "an array",
    mi.SetType: "an array",
    mi.FrozenSetType: "an array",
    mi.DictType: "an object",
    mi.StructType: "an object",
    mi.NoneType: "null",
}


_ARRAYS = (
    mi.ListType,
    mi.TupleType,
    mi.VarTupleType,
    mi.SetType,
    mi.FrozenSetType,
)


def _kind_fits(value: object, info: mi.Type) -> bool:
    """Whether ``value`` has the JSON kind of ``info`` (not its details)."""
    while isinstance(info, mi.Metadata):
        info = info.type
    if isinstance(value, bool):
        return isinstance(info, (mi.BoolType, mi.LiteralType))
    if isinstance(value, int):
        return isinstance(info, (mi.IntType, mi.FloatType, mi.LiteralType))
    if isinstance(value, float):
        return isinstance(info, mi.FloatType)
    if isinstance(value, str):
        return isinstance(info, (mi.StrType, mi.LiteralType))
    if isinstance(value, list):
        return isinstance(info, _ARRAYS)
    if isinstance(value, dict):
        return isinstance(info, (mi.DictType, mi.StructType))
    return value is None and isinstance(info, mi.NoneType)


def _kind_issue(
    value: object, info: mi.Type, path: str, out: list[FieldIssue]
) -> None:
    """``value`` is not of ``info``'s JSON kind: say which it needs."""
    want = _TYPE_NAMES[type(info)]
    out.append(FieldIssue(path, f"must be {want}, got {_name(value)}"))


def convert(value: object, kind: Any) -> Any:
    """``value`` (checked by :func:`shape_issues`) as ``kind``.

    Not strict about one thing only: a float with no fraction where an
    integer is declared becomes that integer, as JSON Schema reads it.
    Everything else lax conversion would allow (strings as numbers) the
    shape check has already refused.
    """
    return msgspec.convert(value, kind, strict=False)


# -- repair: set bad parts aside so that the semantic rules can run ---------


def repaired(value: object, kind: object, issues: list[FieldIssue]) -> Any:
    """A copy of ``value`` that converts to ``kind``, or None.

    Every field named by a shape issue is set aside: an optional field
    falls back to its default, a required one gets a stand-in of its type
    (the semantic findings at or under a bad path are not reported: they
    are about the stand-in). An unknown field is dropped.
    """
    bad = {issue.path for issue in issues}
    try:
        fixed = _repair(value, type_info(kind), "", bad)
        return convert(fixed, kind)
    except (msgspec.ValidationError, _Unrepairable, TypeError, ValueError):
        return None


class _Unrepairable(Exception):
    pass


def _repair(value: object, info: mi.Type, path: str, bad: set[str]) -> Any:
    if isinstance(info, mi.Metadata):
        return _repair(value, info.type, path, bad)
    if path in bad:
        return _stand_in(info, path)
    if isinstance(info, mi.StructType) and isinstance(value, dict):
        fields = {f.encode_name: f for f in info.fields}
        out = {}
        for key, item in value.items():
            if key == info.tag_field:
                out[key] = item
            elif key in fields:
                here = _join(path, key)
                if here in bad and not fields[key].required:
                    continue
                out[key] = _repair(item, fields[key].type, here, bad)
        for name, field in fields.items():
            if field.required and name not in out:
                out[name] = _stand_in(field.type, _join(path, name))
        return out
    if isinstance(info, mi.UnionType):
        for member in info.types:
            trial: list[FieldIssue] = []
            _check(value, member, path, trial)
            if not trial:
                return value
        for member in info.types:
            if isinstance(member, mi.StructType) and isinstance(value, dict):
                return _repair(value, member, path, bad)
        raise _Unrepairable(path)
    if isinstance(info, (mi.ListType, mi.VarTupleType)) and isinstance(
        value, list
    ):
        return [
            _repair(item, info.item_type, f"{path}[{i}]", bad)
            for i, item in enumerate(value)
        ]
    if isinstance(info, mi.DictType) and isinstance(value, dict):
        return {
            key: _repair(item, info.value_type, _join(path, str(key)), bad)
            for key, item in value.items()
            if _join(path, str(key)) not in bad
        }
    return value


def _stand_in(info: mi.Type, path: str) -> Any:
    """A value of type ``info`` within its declared bounds (a string is
    named after its path, so that two stand-in ids never look alike)."""
    if isinstance(info, mi.Metadata):
        return _stand_in(info.type, path)
    if isinstance(info, (mi.IntType, mi.FloatType)):
        # A small range (a cost): its top, the least binding (an optional
        # task); otherwise the bottom (the shortest length).
        if info.ge is not None and info.le is not None and info.le <= 100:
            return info.le
        if info.ge is not None:
            return info.ge
        if info.gt is not None:
            return info.gt + 1
        if info.le is not None:
            return info.le
        if info.lt is not None:
            return info.lt - 1
        return 1
    if isinstance(info, mi.StrType):
        name = "invalid-" + re.sub(r"[^A-Za-z0-9_.-]+", "-", path)
        return name[: info.max_length or None].ljust(info.min_length or 0, "_")
    if isinstance(info, mi.LiteralType):
        return info.values[0]
    if isinstance(info, (mi.ListType, mi.VarTupleType)):
        return []
    if isinstance(info, mi.DictType):
        return {}
    if isinstance(info, mi.TupleType):
        return [
            _stand_in(t, f"{path}[{i}]") for i, t in enumerate(info.item_types)
        ]
    if isinstance(info, mi.UnionType):
        if any(isinstance(t, mi.NoneType) for t in info.types):
            return None
        return _stand_in(info.types[0], path)
    if isinstance(info, mi.BoolType):
        return False
    if isinstance(info, mi.NoneType):
        return None
    if isinstance(info, mi.StructType):
        return {
            f.encode_name: _stand_in(f.type, _join(path, f.encode_name))
            for f in info.fields
            if f.required
        }
    raise _Unrepairable(repr(info))


def under(path: str, roots: set[str]) -> bool:
    """Whether ``path`` is one of ``roots`` or inside one."""
    for root in roots:
        if path == root or path.startswith((root + ".", root + "[")):
            return True
    return False
