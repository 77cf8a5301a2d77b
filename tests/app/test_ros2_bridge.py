"""Tests of ``fsw-scheduler ros2-bridge`` as a user runs it: its help,
its answer when the ``ros2`` extra is missing, and a clean stop on
SIGTERM from its own process."""

from __future__ import annotations

import signal
import subprocess
import sys
import threading
from typing import TYPE_CHECKING

import pytest

from fsw_scheduler.app.cli.main import main
from fsw_scheduler.testing import SchedulerHarness

from ..factories import cli_command

if TYPE_CHECKING:
    from collections.abc import Callable


def test_help_teaches_the_command_and_the_ros2_side(
    capsys: pytest.CaptureFixture[str],
) -> None:
    """Tests that --help gives an example, the topic names and what a
    ROS 2 user types, with the Zenoh flags of run."""
    with pytest.raises(SystemExit) as stopped:
        main(["ros2-bridge", "--help"])
    assert stopped.value.code == 0
    text = capsys.readouterr().out
    for words in (
        "fsw-scheduler ros2-bridge -m client -e tcp/127.0.0.1:7447",
        "ros2 topic list",
        "ros2 topic echo /fsw/sat1/scheduler/plan",
        "/fsw/<sc>/scheduler/dispatches",
        "std_msgs/msg/String",
        "--domain-id",
        "--no-multicast-scouting",
        "--cfg",
    ):
        assert words in text


@pytest.mark.parametrize("missing", ["zenoh_ros2_sdk", "rosbags"])
def test_without_the_extra_it_exits_2_with_the_install_command(
    missing: str,
    monkeypatch: pytest.MonkeyPatch,
    capsys: pytest.CaptureFixture[str],
) -> None:
    """Tests that a missing ros2 extra is exit 2 naming the pip command,
    before any bus is opened."""
    monkeypatch.setitem(sys.modules, missing, None)
    for name in list(sys.modules):
        if name.startswith((f"{missing}.", "fsw_scheduler.bus.ros2")):
            monkeypatch.delitem(sys.modules, name)
    assert main(["ros2-bridge", "--no-multicast-scouting"]) == 2
    assert "pip install 'fsw-scheduler[ros2]'" in capsys.readouterr().err


def test_a_bad_spacecraft_id_is_exit_2(
    capsys: pytest.CaptureFixture[str],
) -> None:
    """Tests that a spacecraft id that is not key-safe is refused."""
    assert main(["ros2-bridge", "--spacecraft", "sat/*"]) == 2
    assert "--spacecraft" in capsys.readouterr().err


def _wait_line(lines: list[str], cond: threading.Condition, word: str) -> bool:
    with cond:
        return cond.wait_for(lambda: any(word in x for x in lines), 60)


def _reader(
    process: subprocess.Popen[str], lines: list[str], cond: threading.Condition
) -> Callable[[], None]:
    def read() -> None:
        assert process.stderr is not None
        for line in process.stderr:
            with cond:
                lines.append(line)
                cond.notify_all()

    return read


def test_sigterm_stops_the_bridge_cleanly() -> None:
    """Tests that the bridge, in its own process on a scheduler's bus,
    comes up naming its topics and exits 0 on SIGTERM with its counts."""
    pytest.importorskip("zenoh_ros2_sdk")
    with SchedulerHarness() as harness:
        (endpoint,) = harness.endpoints()
        process = subprocess.Popen(
            cli_command(
                "ros2-bridge",
                "-e",
                endpoint,
                "--no-multicast-scouting",
                "--cfg",
                'listen/endpoints:["tcp/127.0.0.1:0"]',
            ),
            stdout=subprocess.DEVNULL,
            stderr=subprocess.PIPE,
            text=True,
        )
        lines: list[str] = []
        cond = threading.Condition()
        thread = threading.Thread(target=_reader(process, lines, cond))
        thread.start()
        try:
            assert _wait_line(lines, cond, "ros2-bridge up"), lines
            assert "/fsw/sat1/scheduler/plan" in "".join(lines)
            process.send_signal(signal.SIGTERM)
            assert process.wait(30) == 0, lines
        finally:
            if process.poll() is None:
                process.kill()
                process.wait(10)
            thread.join(10)
            if process.stderr is not None:
                process.stderr.close()
        assert _wait_line(lines, cond, "ros2-bridge stopped"), lines
