"""Tests of fenced terms: a commander cut off longer than the Zenoh lease
must not win back when it returns, and a flood through a killed commander
leaves no goal unanswered.

Separate processes through a router (``tools/soak_partition`` runs the
long version): A (rank 0) commands, B (rank 1) stands by. A is cut off
for longer than the lease, in two ways: its process is stopped (SIGSTOP,
then SIGCONT), or its link falls silent while it keeps running (a relay
that drops every byte). B takes over in a new term and accepts a goal;
then A comes back. A receiver that follows the README
(:class:`fsw_scheduler.testing.Fence`) must never act twice, the goal must
stay in the plan, exactly one node commands and A says why it stood down.
"""

from __future__ import annotations

import time
from typing import TYPE_CHECKING

import pytest

from ..factories import tool_script

if TYPE_CHECKING:
    from pathlib import Path
    from types import ModuleType


def soak_partition() -> ModuleType:
    """``tools/soak_partition``: cuts, heals and floods with kills."""
    return tool_script("soak_partition")


@pytest.mark.slow
@pytest.mark.parametrize(
    ("cut", "reason"),
    [("stopped", "did not run"), ("silent", "every link")],
)
def test_cut_off_commander_does_not_win_back(
    tmp_path: Path, cut: str, reason: str
) -> None:
    """Tests A cut off beyond the lease, then back: B took over in a
    higher term; A stands down, says why and follows B; nothing runs
    twice at a fencing receiver; B's goal is in the final plan; one
    commander; every journal replays identical."""
    result = soak_partition().run_round(tmp_path, cut)
    assert result.ok, result
    assert reason in result.stood_down, result.stood_down
    assert result.journals >= 2


@pytest.mark.slow
def test_flood_with_a_killed_commander_answers_every_goal(
    tmp_path: Path,
) -> None:
    """Tests a goal flood during which the commander gets SIGKILL: the
    standby takes over, the sender re-sends what got no verdict (the
    README's rule), every goal ends with exactly one kind of verdict,
    every accepted one is in a plan, nothing is executed twice."""
    result = soak_partition().run_round(tmp_path, "killed", flood=48)
    assert result.ok, result
    assert result.goals == 48


@pytest.mark.slow
def test_forged_tokens_cannot_stall_the_election(tmp_path: Path) -> None:
    """Tests an open bus with forged liveliness tokens: an ``active``
    token of term 999 with no member behind it makes no one stand down;
    a forged best member that never commands (rank 0, the earliest start)
    is passed over when the commander dies, within the pass-over bound."""
    import zenoh

    from fsw_scheduler.bus.redundancy import PASS_OVER_S
    from fsw_scheduler.bus.session import loopback_config
    from fsw_scheduler.testing import SchedulerClient

    soak = soak_partition()
    router, port = soak.start_router()
    nodes = {
        name: soak.node(tmp_path / name, port, name, rank)
        for name, rank in (("A", 0), ("B", 1))
    }
    try:
        config = loopback_config(
            listen=None, connect=[f"tcp/127.0.0.1:{port}"]
        )
        config.insert_json5("mode", '"client"')
        with zenoh.open(config) as session:
            client = SchedulerClient(session, timeout=30.0)
            assert nodes["A"].start() == "scheduler up on"
            assert nodes["B"].start() == "standing by"
            client.wait_scheduler(30)
            forged = [
                session.liveliness().declare_token(
                    "fsw/sat1/scheduler/active/999/0/1/evil"
                ),
                session.liveliness().declare_token(
                    "fsw/sat1/scheduler/nodes/-1/1/minus"
                ),
            ]
            seen = len(client.statuses)
            client.tick(0)
            client.tick(1)
            assert client.query_status().node_id == "A"
            assert not [
                s for s in client.statuses[seen:] if s.event == "stood_down"
            ]
            forged.append(
                session.liveliness().declare_token(
                    "fsw/sat1/scheduler/nodes/0/1/ghost"
                )
            )
            began = time.monotonic()
            nodes["A"].kill()
            client.wait_status(
                lambda s: s.event == "took_over" and s.node_id == "B",
                PASS_OVER_S + 20,
            )
            assert time.monotonic() - began < PASS_OVER_S + 10
            for token in forged:
                token.undeclare()
            client.close()
    finally:
        for process in nodes.values():
            process.kill()
        router.close()


@pytest.mark.slow
def test_forged_terms_and_state_on_an_open_bus_change_nothing(
    tmp_path: Path,
) -> None:
    """Tests forged active tokens of term 2^63-1, 10^30 and 10^50 (with a
    member token), a forged ``scheduler/term`` of 10^40 and a forged
    snapshot of a high term holding a goal no one sent: the commander
    never stands down, every goal is answered, the fencing receiver stays
    at term 1; when A dies, B takes over in term 2 from the genuine
    state (the forged goal is not in it)."""
    result = soak_partition().run_round(tmp_path, "forged")
    assert result.ok, result
    assert not result.stood_down
    assert result.goals == 3
