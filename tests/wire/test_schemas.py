"""Tests that schemas/ matches the message types (wire.messages)."""

from __future__ import annotations

import json

import msgspec
import pytest

from fsw_scheduler.model.goal import decode_goal
from fsw_scheduler.model.plan import Activity, Objective, SolveStatus
from fsw_scheduler.runtime import schemas
from fsw_scheduler.wire import messages

from ..factories import DATA, ROOT

SCHEMAS = ROOT / "schemas"


def test_schema_files_match_code() -> None:
    """Tests that every schema file equals json_schemas() output."""
    # Through JSON text, as on disk (tuples become lists).
    generated = json.loads(json.dumps(schemas.json_schemas()))
    on_disk = {
        p.name.removesuffix(".schema.json"): json.loads(p.read_text())
        for p in SCHEMAS.glob("*.schema.json")
    }
    assert on_disk.keys() == generated.keys(), (
        "run: .venv/bin/python tools/gen_schemas"
    )
    for name, schema in generated.items():
        assert on_disk[name] == schema, f"schemas/{name} is out of date"


def _sample_messages() -> dict[str, object]:
    plan = messages.PlanMessage(
        plan_id=1,
        issued_at=0,
        horizon_start=0,
        horizon_end=50,
        status=SolveStatus.OPTIMAL,
        objective=Objective(0, 3, 3),
        activities=(Activity("a", 0, 1),),
    )
    return {
        "clock": messages.Clock(15),
        "activity_report": messages.ActivityReport("a", "running", 3),
        "resource_level": messages.ResourceLevel("battery", 8.5, 3),
        "plan": plan,
        "dispatch": messages.Dispatch("a", 1, 0, 1, {"power": 20.0}),
        "status": messages.Status("ok", 1, now=3, event="plan"),
        "goal": decode_goal((DATA / "paper_table2_goal.json").read_bytes()),
    }


@pytest.mark.parametrize("kind", sorted(_sample_messages()))
def test_round_trip(kind: str) -> None:
    """Tests that each message type survives encode and decode."""
    message = _sample_messages()[kind]
    payload = messages.encode(message)
    again = msgspec.json.decode(payload, type=type(message))
    assert again == message


def test_contract_examples_decode() -> None:
    """Tests that the bus keys minimal payloads decode."""
    examples = {
        "clock": b'{"now": 15}',
        "activity_report": (
            b'{"task": "BatteryCharge", "state": "running", "at": 15}'
        ),
        "resource_level": (
            b'{"resource": "battery", "level": 82.0, "at": 15}'
        ),
    }
    for kind, payload in examples.items():
        messages.decode_input(kind, payload)
    dispatch = msgspec.json.decode(
        b'{"task": "BatteryCharge", "plan_id": 1, "start": 7, "end": 17, '
        b'"uses": {"position": 1, "battery": -10}}',
        type=messages.Dispatch,
    )
    assert dispatch.uses["battery"] == -10


def test_unknown_fields_of_inputs_are_rejected() -> None:
    """Tests that a field the scheduler does not understand is refused,
    named, with the closest known field."""
    with pytest.raises(messages.InputError) as info:
        messages.decode_input("clock", b'{"nwo": 3}')
    paths = {issue.path: issue.reason for issue in info.value.issues}
    assert "did you mean 'now'?" in paths["nwo"]
    assert paths["now"] == "missing required field"


def test_oversized_payload_is_rejected() -> None:
    """Tests that a payload over the size limit is refused before parsing."""
    huge = b'{"now": 1, "pad": "' + b"x" * messages.MAX_PAYLOAD_BYTES + b'"}'
    with pytest.raises(messages.InputError) as info:
        messages.decode_input("clock", huge)
    assert "exceeds" in info.value.issues[0].reason


def test_normalise_makes_schemas_independent_of_msgspec_formatting() -> None:
    """Tests that descriptions are dedented and unordered lists sorted."""
    indented = {
        "description": "Title.\n\n    Attributes\n    ----------\n    x : int",
        "anyOf": [{"type": "null"}, {"type": "integer"}],
        "required": ["b", "a"],
        "enum": ["z", "a"],
    }
    dedented = {
        "enum": ["z", "a"],
        "required": ["a", "b"],
        "anyOf": [{"type": "integer"}, {"type": "null"}],
        "description": "Title.\n\nAttributes\n----------\nx : int",
    }
    assert schemas._normalise(indented) == schemas._normalise(dedented)
    out = schemas._normalise(indented)
    assert out["description"] == dedented["description"]
    # enum order is meaningful to readers and kept as written
    assert out["enum"] == ["z", "a"]
    assert list(out) == sorted(out)
