"""Tests of following a journal record by record (what a standby does
with the commander's ``scheduler/changes``)."""

from __future__ import annotations

from pathlib import Path

import msgspec
import pytest

from fsw_scheduler.journal.follow import Follower, needed
from fsw_scheduler.journal.reader import iter_messages
from fsw_scheduler.journal.replay import read_node_info, rebuild
from fsw_scheduler.runtime.policy import config_from_info
from fsw_scheduler.wire import topics

ROOT = Path(__file__).resolve().parents[2]


@pytest.mark.parametrize("name", ["paper.mcap", "failure.mcap"])
def test_only_the_records_a_standby_is_sent_give_the_same_state(
    name: str,
) -> None:
    """Tests a golden journal followed with only what a commander sends
    its standby (``needed``: inputs and solve results, no outputs, no
    settings, no states): the engine ends in the state a resume from
    every record gives, and far fewer bytes are sent than journaled."""
    path = ROOT / "replay" / name
    recorded = list(iter_messages(path))
    info, _ = read_node_info(recorded)
    config = config_from_info(info, None)
    keys = topics.Topics(config.spacecraft)
    follower = Follower(config, problem=info.problem)
    sent = [m for m in recorded if needed(keys, m.topic)]
    for message in sent:
        follower.apply(message.topic, message.payload)
    full = rebuild(path).engine.snapshot()
    assert msgspec.json.encode(follower.engine.snapshot()) == (
        msgspec.json.encode(full)
    )
    assert sum(len(m.payload) for m in sent) < sum(
        len(m.payload) for m in recorded
    )
    assert follower.engine.plan_id is not None
