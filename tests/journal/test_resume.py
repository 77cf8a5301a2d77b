"""Tests of resume from a state folder: a real node (separate process,
``--state``) killed with SIGKILL at random points, rotated journals, a
journal cut short."""

from __future__ import annotations

import contextlib
import random
import shutil
from typing import TYPE_CHECKING

import pytest

from fsw_scheduler.journal.state import journal_files, open_state

from ..factories import tool_script

if TYPE_CHECKING:
    from pathlib import Path
    from types import ModuleType

    from ..conftest import Uninterrupted


def soak_resume() -> ModuleType:
    """``tools/soak_resume``: a node session with SIGKILLs at given steps."""
    return tool_script("soak_resume")


def test_random_sigkills_resume_to_the_uninterrupted_plan(
    tmp_path: Path, uninterrupted: Uninterrupted
) -> None:
    """Tests the real node (separate process, --state) killed by SIGKILL
    at random points: after each restart it resumes, and the session ends
    with the plan of an uninterrupted run, every activity dispatched
    exactly as often, and every journal file replaying identically."""
    soak = soak_resume()
    rng = random.Random(7)
    reference = uninterrupted.outcome
    kills = soak.random_kills(rng, 4) | {(15, "goal"), (0, "tick")}
    outcome = soak.run_session(tmp_path, kills, rng)
    assert soak.compare(reference, outcome) == []
    assert outcome.kills == len(kills)
    assert outcome.resumed == len(kills)
    assert outcome.journals == len(kills) + 1
    assert max(outcome.dispatches.values()) == 1


def test_rotated_journal_resumes_from_the_newest_snapshot(
    tmp_path: Path, uninterrupted: Uninterrupted
) -> None:
    """Tests journals that rotate by size: each file opens with a snapshot,
    a node killed after rotations resumes, all files replay identically."""
    soak = soak_resume()
    rng = random.Random(3)
    reference = uninterrupted.outcome
    outcome = soak.run_session(
        tmp_path,
        {(20, "tick"), (30, "report")},
        rng,
        ("--journal-max-size", "4000"),
    )
    assert soak.compare(reference, outcome) == []
    parts = [n for n in outcome.journal_files if n.count("-") == 2]
    assert parts, outcome.journal_files


def test_state_folder_finishes_a_truncated_journal(
    tmp_path: Path, uninterrupted: Uninterrupted
) -> None:
    """Tests that a journal cut short (killed writer) is recovered and the
    state rebuilt from what it holds."""
    state = tmp_path / "state"
    shutil.copytree(uninterrupted.state, state)
    (path,) = journal_files(state)
    data = path.read_bytes()
    path.write_bytes(data[: len(data) * 2 // 3])
    start = open_state(state)
    assert start.recovered == [path]
    assert start.rebuilt is not None
    assert start.rebuilt.engine.plan_id in (1, 2)
    assert start.next_journal.name == "journal-0002.mcap"


def test_the_state_folder_keeps_its_byte_budget(
    tmp_path: Path, uninterrupted: Uninterrupted
) -> None:
    """Tests ``--state-max-bytes``: with small parts the oldest files go
    once a newer part opens with the state; the folder stays within its
    budget (plus the part being written) and still resumes to the plan
    of an uninterrupted run."""
    soak = soak_resume()
    rng = random.Random(3)
    reference = uninterrupted.outcome
    budget = 30_000
    outcome = soak.run_session(
        tmp_path,
        {(30, "report")},
        rng,
        ("--journal-max-size", "4000", "--state-max-bytes", str(budget)),
    )
    assert soak.compare(reference, outcome) == []
    files = journal_files(tmp_path / "state")
    sizes = [p.stat().st_size for p in files]
    assert sum(sizes) <= budget + max(sizes), sizes
    assert files[0].name != "journal-0001.mcap"  # the oldest went
    assert open_state(tmp_path / "state").rebuilt is not None


@pytest.mark.slow
def test_a_real_full_disk_degrades_and_recovers(tmp_path: Path) -> None:
    """Tests ``run --state`` on a 2 MB tmpfs that fills up: the node says
    ``journal_failed`` (durable false) at once, answers the next goal,
    and says ``journal_resumed`` once space is freed. Needs mount rights
    (root); skipped elsewhere (the injected ENOSPC test still runs)."""
    import subprocess

    import zenoh

    from fsw_scheduler.bus.session import loopback_config
    from fsw_scheduler.testing import SchedulerClient

    from ..factories import ping_goal

    disk = tmp_path / "disk"
    disk.mkdir()
    mounted = subprocess.run(
        ["mount", "-t", "tmpfs", "-o", "size=2m", "tmpfs", str(disk)],
        capture_output=True,
    )
    if mounted.returncode != 0:
        pytest.skip("cannot mount a small filesystem here")
    soak = soak_resume()
    router, port = soak.start_router()
    node = soak.node_process(disk / "state", port, ("--no-standby",))
    try:
        config = loopback_config(
            listen=None, connect=[f"tcp/127.0.0.1:{port}"]
        )
        config.insert_json5("mode", '"client"')
        with zenoh.open(config) as session:
            client = SchedulerClient(session, timeout=30.0)
            node.start()
            client.wait_scheduler(30)
            client.tick(0)
            client.wait_plan(lambda p: p.plan_id == 1)
            filler = disk / "filler"
            with open(filler, "wb") as f, contextlib.suppress(OSError):
                while True:
                    f.write(b"\0" * 65536)
                    f.flush()
            client.tick(1)
            client.publish_goal(ping_goal("on-a-full-disk", "Full"))
            failed = client.wait_status(lambda s: s.event == "journal_failed")
            assert failed.state == "degraded" and not failed.durable
            verdict = client.wait_status(
                lambda s: (
                    s.goal_id == "on-a-full-disk"
                    and s.event in ("goal_accepted", "goal_rejected")
                )
            )
            assert verdict.event == "goal_accepted"
            filler.unlink()
            back = client.wait_status(
                lambda s: s.event == "journal_resumed", 30
            )
            assert back.durable
            client.close()
    finally:
        node.kill()
        router.close()
        subprocess.run(["umount", "-l", str(disk)], capture_output=True)
