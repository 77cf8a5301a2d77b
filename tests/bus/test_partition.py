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
from typing import TYPE_CHECKING, Any

import pytest

from ..factories import tool_script

if TYPE_CHECKING:
    from pathlib import Path
    from types import ModuleType


def _client_of(port: int) -> Any:
    """A Zenoh client configuration of the router on ``port``."""
    from fsw_scheduler.bus.session import loopback_config

    config = loopback_config(listen=None, connect=[f"tcp/127.0.0.1:{port}"])
    config.insert_json5("mode", '"client"')
    return config


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
@pytest.mark.parametrize("spacecraft", ["one", "both"])
def test_a_router_split_executes_nothing_twice(
    tmp_path: Path, spacecraft: str
) -> None:
    """Tests a split between two routers, A on one and B on the other,
    with the spacecraft (clock and a README executor) on A's side or on
    both, and goals sent on both sides: both command; at the heal A hands
    over its facts and B merges them; nothing is executed twice, no
    accepted goal is lost, every goal ends with one final verdict, no goal
    of which something was commanded is told to be sent again, no report
    is rejected "after now", B commands, every journal replays
    identical."""
    result = soak_partition().run_split(
        tmp_path, spacecraft, before=4, split=14, after=25
    )
    assert result.ok, result
    assert result.facts_merged, result  # A did hand facts over
    assert result.journals >= 2


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


@pytest.mark.slow
@pytest.mark.parametrize("kind", ["reset", "restored", "aside", "empty"])
def test_a_reset_never_reuses_or_lowers_a_term(
    tmp_path: Path, kind: str
) -> None:
    """Tests both computers reset after a history of two terms: the
    standby back first resumes from the copy it saved (term 2); a node
    with a restored or moved-aside folder adopts the peer's newer state
    before anyone commands (term 3); a node alone on an empty folder
    learns term 2 from the receivers, commands in term 3 and raises an
    alarm saying what was lost. In each: no (term, plan_id) with two
    contents, every goal one verdict, no accepted goal forgotten (but by
    the lone empty folder, which says so), the fencing receiver executes
    the new commander's dispatches."""
    result = soak_partition().run_reset(tmp_path, kind)
    assert result.ok, result
    if kind == "empty":
        assert "term 2" in result.alarm
    else:
        assert result.forgotten == []


@pytest.mark.slow
def test_a_stall_under_the_lease_is_not_a_stand_down(tmp_path: Path) -> None:
    """Tests the commander stopped (SIGSTOP) for 0.8 x the lease while
    goals arrive: it re-verifies without leaving command, answers every
    goal in term 1, never says ``stood_down``; B never takes over."""
    result = soak_partition().run_round(tmp_path, "stall")
    assert result.ok, result
    assert result.goals == 3


@pytest.mark.slow
def test_a_peer_tool_leaving_a_standalone_node_costs_nothing(
    tmp_path: Path,
) -> None:
    """Tests the README's topology (one node listening, peer mode) when a
    peer-mode session connects to it and leaves, twice: the node never
    says its lease was lost and answers a goal afterwards in term 1."""
    import zenoh

    from fsw_scheduler.bus.session import loopback_config
    from fsw_scheduler.testing import SchedulerClient, SchedulerProcess

    from ..factories import DATA, free_port, ping_goal

    port = free_port()
    endpoint = f"tcp/127.0.0.1:{port}"
    lease = soak_partition().LEASE_MS
    node = SchedulerProcess(
        [
            "--problem",
            str(DATA / "paper_table1.json"),
            "--clock",
            "bus",
            "--state",
            str(tmp_path / "state"),
            "--listen",
            endpoint,
            "--no-multicast-scouting",
            "--insecure",
            "--discovery",
            "0.2",
            "--cfg",
            f"transport/link/tx/lease:{lease}",
        ]
    )
    try:
        assert node.start() == "scheduler up on"
        for _ in range(2):
            config = loopback_config(listen=None, connect=[endpoint])
            with zenoh.open(config) as tool:
                client = SchedulerClient(tool, timeout=30.0)
                client.wait_scheduler(30)
                assert client.query_status().term == 1
                client.close()
            # Past the lease: a lost link would have been noticed.
            with pytest.raises(RuntimeError, match=r"no .* in the sched"):
                node.wait_log(("lease lost",), 2 * lease / 1000)
        config = loopback_config(listen=None, connect=[endpoint])
        with zenoh.open(config) as session:
            client = SchedulerClient(session, timeout=30.0)
            client.wait_scheduler(30)
            client.tick(0)
            answers = client.send_goals([ping_goal("after", "After")])
            assert answers["after"] == {"goal_accepted"}
            assert client.query_status().term == 1
            client.close()
        assert not any("lease lost" in line for line in node.log)
    finally:
        node.kill()


@pytest.mark.slow
@pytest.mark.parametrize("kind", ["aside", "restored"])
def test_a_lone_node_on_an_old_folder_says_so_without_a_fence_to_ask(
    tmp_path: Path, kind: str
) -> None:
    """Tests one node after two terms, restarted on a folder whose newest
    run was moved aside, or on a copy of it taken in term 1, while the
    only receiver restarted (its fence answers term 0).

    Moved aside: the folder's term mark (``term.json``) still says term
    2, so the node begins term 3 and says ``alarm`` that what term 2
    decided is lost. Restored: the mark was restored too, nothing on the
    bus remembers term 2 and the node cannot tell; it begins term 2 again
    but says ``alarm`` that no one vouches for its state's term, instead
    of ``ok`` in silence."""
    import shutil

    import zenoh

    from fsw_scheduler.journal.state import journal_files
    from fsw_scheduler.testing import SchedulerClient

    from ..factories import ping_goal

    soak = soak_partition()
    router, port = soak.start_router()
    state = tmp_path / "state"
    node = soak.node(state, port, "A", 0)
    config = _client_of(port)
    try:
        with zenoh.open(config) as session:
            client = SchedulerClient(session, timeout=30.0)
            for run, name in enumerate(("one", "two")):
                node.start()
                client.wait_scheduler(30)
                client.tick(run)
                answers = client.send_goals([ping_goal(name, name.upper())])
                assert answers[name] == {"goal_accepted"}
                node.kill()
                if run == 0:
                    shutil.copytree(state, tmp_path / "backup")
            client.close()
        if kind == "aside":
            newest = journal_files(state)[-1].name.split("-")[1]
            (state / "aside").mkdir()
            for path in journal_files(state):
                if path.name.split("-")[1] == newest:
                    shutil.move(path, state / "aside" / path.name)
        else:
            shutil.rmtree(state)
            shutil.copytree(tmp_path / "backup", state)
        with zenoh.open(config) as session:
            # The receiver restarted: its fence knows no term.
            client = SchedulerClient(session, timeout=30.0)
            mark = len(node.log)
            node.start()
            said = "older than term 2" if kind == "aside" else "vouches for"
            node.wait_log((said,), 30, since=mark)
            (alarm,) = [line for line in node.log[mark:] if said in line]
            client.wait_scheduler(30)
            status = client.query_status()
            client.close()
    finally:
        node.kill()
        router.close()
    if kind == "aside":
        assert status.term == 3, status
    else:
        assert status.term == 2 and status.state == "ok", status
        assert "state of term 1" in alarm, alarm
    # The alarm is a decision like the others: the replay says it again.
    from fsw_scheduler.journal.replay import verify

    last = journal_files(state)[-1]
    assert verify(last).identical, last


@pytest.mark.slow
def test_a_commander_fenced_by_a_receiver_says_so(tmp_path: Path) -> None:
    """Tests a term written on an open bus above the commander's: the
    receiver's fence follows it and drops every command, and the node,
    which asks the fences every few seconds, says ``alarm`` (degraded)
    naming the term instead of ``ok``, and a status query says it while
    the fence stands."""
    import zenoh

    from fsw_scheduler.bus.fenced import FENCE_CHECK_S
    from fsw_scheduler.testing import SchedulerClient
    from fsw_scheduler.wire import messages, topics

    soak = soak_partition()
    router, port = soak.start_router()
    node = soak.node(tmp_path / "state", port, "A", 0)
    config = _client_of(port)
    try:
        node.start()
        with zenoh.open(config) as session:
            client = SchedulerClient(session, timeout=30.0)
            client.wait_scheduler(30)
            client.tick(0)
            assert client.query_status().term == 1
            seen = len(client.statuses)
            client.put(topics.TERM, messages.Term(7, "forger"))
            alarm = client.wait_status(
                lambda s: s.event == "alarm" and "fences term 7" in s.detail,
                3 * FENCE_CHECK_S,
                since=seen,
            )
            assert alarm.state == "degraded" and alarm.node_id == "A"
            assert client.fence.term == 7
            # A status asked for later says it too, while the fence stands.
            asked = client.query_status()
            assert asked.state == "degraded" and "fence: " in asked.detail
            assert "fences term 7" in asked.detail
            client.close()
    finally:
        node.kill()
        router.close()


def test_a_commander_whose_standby_left_says_so_until_one_is_back(
    tmp_path: Path,
) -> None:
    """Tests a standby killed outright, then started again, through a
    router: the commander says ``alarm`` (degraded) at its next step that
    no standby holds its state, a status query says so for as long as it
    lasts, and once a standby follows again a query says ``ok``."""
    import zenoh

    from fsw_scheduler.testing import SchedulerClient

    from ..factories import ping_goal

    soak = soak_partition()
    router, port = soak.start_router()
    a = soak.node(tmp_path / "a", port, "A", 0)
    b = soak.node(tmp_path / "b", port, "B", 1)
    config = _client_of(port)
    try:
        a.start()
        with zenoh.open(config) as session:
            client = SchedulerClient(session, timeout=30.0)
            client.wait_scheduler(30)
            client.tick(0)
            b.start()
            b.wait_log(("standing by for A",), 30)
            answers = client.send_goals([ping_goal("held", "Held")])
            assert answers["held"] == {"goal_accepted"}
            assert client.query_status().state == "ok"
            b.kill()
            seen = len(client.statuses)
            deadline = time.monotonic() + 30
            asked = client.query_status()
            now = 1
            # The commander sees the standby gone at a step: tick until.
            while "standby_left" not in asked.detail:
                assert time.monotonic() < deadline, asked
                client.tick(now)
                now += 1
                asked = client.query_status()
            alarm = client.wait_status(
                lambda s: s.event == "alarm" and "no standby" in s.detail,
                10,
                since=seen,
            )
            assert alarm.state == "degraded" and alarm.node_id == "A"
            assert asked.state == "degraded", asked
            b.start()
            b.wait_log(("standing by for A",), 30)
            deadline = time.monotonic() + 30
            while asked.state != "ok":
                assert time.monotonic() < deadline, asked
                client.tick(now)
                now += 1
                asked = client.query_status()
            assert not asked.detail, asked
            client.close()
    finally:
        a.kill()
        b.kill()
        router.close()


def test_a_term_mark_that_cannot_be_written_is_said_for_the_term(
    tmp_path: Path,
) -> None:
    """Tests a state folder whose ``term.json`` cannot be replaced (a
    directory stands in its place): the node commands, says ``alarm``
    naming the file, and a status query says ``degraded`` with it for as
    long as the term lasts; before, it was only in the log."""
    import zenoh

    from fsw_scheduler.journal.state import TERM_MARK
    from fsw_scheduler.testing import SchedulerClient

    from ..factories import ping_goal

    soak = soak_partition()
    router, port = soak.start_router()
    state = tmp_path / "state"
    (state / TERM_MARK / "blocked").mkdir(parents=True)
    node = soak.node(state, port, "A", 0)
    config = _client_of(port)
    try:
        node.start()
        node.wait_log(("cannot write",), 30)
        with zenoh.open(config) as session:
            client = SchedulerClient(session, timeout=30.0)
            client.wait_scheduler(30)
            client.tick(0)
            answers = client.send_goals([ping_goal("kept", "Kept")])
            assert answers["kept"] == {"goal_accepted"}
            asked = client.query_status()
            client.close()
    finally:
        node.kill()
        router.close()
    assert asked.state == "degraded" and asked.term == 1, asked
    assert "term_mark: cannot write" in asked.detail, asked
    assert "term.json" in asked.detail
