"""Tests of the ``fsw-scheduler`` command line through real subprocesses."""

from __future__ import annotations

import json
import subprocess
from pathlib import Path

import pytest

from ..factories import CLI, ROOT, TABLE1, TABLE2


def cli(*args: str, stdin: str | None = None) -> subprocess.CompletedProcess:
    """Run ``fsw-scheduler`` with ``args`` in a fresh interpreter."""
    return subprocess.run(
        [*CLI, *args],
        capture_output=True,
        text=True,
        input=stdin,
        timeout=120,
    )


def _write(path: Path, doc: dict) -> str:
    path.write_text(json.dumps(doc))
    return str(path)


def test_help_teaches() -> None:
    """Tests that --help lists the commands and shows examples."""
    result = cli("--help")
    assert result.returncode == 0
    for word in (
        "solve",
        "check",
        "replan",
        "run",
        "demo",
        "record",
        "replay",
        "recover",
        "info",
        "exit codes",
    ):
        assert word in result.stdout
    sub = cli("run", "--help")
    assert "--clock" in sub.stdout and "--connect" in sub.stdout
    assert "example" in sub.stdout


@pytest.mark.parametrize("solver", ["cbc", "highs"])
def test_solve_prints_plan(tmp_path: Path, solver: str) -> None:
    """Tests that solve prints clean plan JSON on stdout and exits 0."""
    picture = tmp_path / "plan.png"
    result = cli("solve", TABLE1, "--solver", solver, "--gantt", str(picture))
    assert result.returncode == 0, result.stderr
    plan = json.loads(result.stdout)
    assert plan["status"] == "optimal"
    assert plan["objective"]["delay_cost"] == 359
    assert plan["unscheduled"] == []
    assert picture.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


def test_solve_gantt_of_many_tasks_names_its_pages(tmp_path: Path) -> None:
    """Tests that solve --gantt of 41 tasks writes two pages and says so."""
    doc = {
        "horizon": 60,
        "tasks": [
            {
                "id": f"t{idx:02d}",
                "length": 1,
                "delay_cost": 1,
                "schedule_cost": 1,
            }
            for idx in range(41)
        ],
    }
    picture = tmp_path / "many.png"
    result = cli(
        "solve", _write(tmp_path / "many.json", doc), "--gantt", str(picture)
    )
    assert result.returncode == 0, result.stderr
    pages = [tmp_path / "many-1.png", tmp_path / "many-2.png"]
    assert sorted(tmp_path.glob("*.png")) == pages
    for page in pages:
        assert f"wrote {page}" in result.stderr


def test_solve_then_check(tmp_path: Path) -> None:
    """Tests that a solved plan passes check, and a broken one fails."""
    plan_path = tmp_path / "plan.json"
    assert cli("solve", TABLE1, "--out", str(plan_path)).returncode == 0
    ok = cli("check", TABLE1, str(plan_path))
    assert ok.returncode == 0, ok.stdout
    assert "valid" in ok.stdout
    plan = json.loads(plan_path.read_text())
    for activity in plan["activities"]:
        if activity["task"] == "BatteryCharge":
            activity["start"], activity["end"] = 5, 15
    broken = cli("check", TABLE1, _write(tmp_path / "bad.json", plan))
    assert broken.returncode == 1
    assert "binary" in broken.stdout and "precedence" in broken.stdout


def test_infeasible_exits_one_and_says_why(tmp_path: Path) -> None:
    """Tests that an infeasible problem exits 1 naming the blocked task."""
    doc = {
        "horizon": 4,
        "resources": {"binary": ["cam"]},
        "tasks": [
            {
                "id": "a",
                "length": 3,
                "delay_cost": 1,
                "schedule_cost": 0,
                "uses": {"cam": 1},
            },
            {
                "id": "b",
                "length": 3,
                "delay_cost": 1,
                "schedule_cost": 0,
                "uses": {"cam": 1},
            },
        ],
    }
    result = cli("solve", _write(tmp_path / "p.json", doc))
    assert result.returncode == 1
    plan = json.loads(result.stdout)
    assert plan["status"] == "infeasible"
    assert plan["why"] and plan["why"][0]["task"] in {"a", "b"}


@pytest.mark.parametrize(
    ("mutate", "path"),
    [
        (lambda d: d["tasks"][0].update(length=-1), "tasks[0].length"),
        (
            lambda d: d["tasks"][1].update(uses={"laser": 1}),
            "tasks[1].uses.laser",
        ),
        (lambda d: d.update(horizon="fifty"), "horizon"),
        (
            lambda d: d["precedences"][0].update(after="Nope"),
            "precedences[0].after",
        ),
    ],
)
def test_bad_input_exits_two_naming_field(
    tmp_path: Path, table1_doc: dict, mutate, path: str
) -> None:
    """Tests that bad input exits 2 with the field path on stderr."""
    doc = json.loads(json.dumps(table1_doc))
    mutate(doc)
    result = cli("solve", _write(tmp_path / "p.json", doc))
    assert result.returncode == 2
    assert path in result.stderr
    assert "Traceback" not in result.stderr
    assert result.stdout == ""


def test_unreadable_and_malformed_files_exit_two(tmp_path: Path) -> None:
    """Tests that missing files and broken JSON exit 2 without traceback."""
    missing = cli("solve", str(tmp_path / "absent.json"))
    assert missing.returncode == 2 and "cannot read" in missing.stderr
    (tmp_path / "bad.json").write_text("{not json")
    broken = cli("solve", str(tmp_path / "bad.json"))
    assert broken.returncode == 2 and "Traceback" not in broken.stderr


def test_solve_from_stdin(table1_doc: dict) -> None:
    """Tests that '-' reads the problem from stdin."""
    result = cli("solve", "-", "--no-explain", stdin=json.dumps(table1_doc))
    assert result.returncode == 0
    assert json.loads(result.stdout)["status"] == "optimal"


def test_replan_paper_table2(tmp_path: Path) -> None:
    """Tests that replan applies the Table 2 goal at t=15 and checks."""
    plan1 = tmp_path / "plan1.json"
    assert cli("solve", TABLE1, "--out", str(plan1)).returncode == 0
    problem2, plan2 = tmp_path / "problem2.json", tmp_path / "plan2.json"
    result = cli(
        "replan",
        TABLE1,
        str(plan1),
        TABLE2,
        "--now",
        "15",
        "--out",
        str(plan2),
        "--problem-out",
        str(problem2),
    )
    assert result.returncode == 0, result.stderr
    assert "obsolete" in result.stderr and "tight_cascade" in result.stderr
    starts = {
        a["task"]: a["start"]
        for a in json.loads(plan2.read_text())["activities"]
    }
    assert starts["BatteryCharge"] == 15
    assert starts["SetLFOption"] == 15
    assert "AcquisitionHF" not in starts and "SetHFOption" not in starts
    assert {"AcquisitionLF", "SetPositionZ", "DownlinkSat2Ground"} <= set(
        starts
    )
    assert cli("check", str(problem2), str(plan2)).returncode == 0


def test_replan_takes_run_stability_flags(tmp_path: Path) -> None:
    """Tests that replan takes run's --stability, --commit-window and
    --move-cost: the Table 2 replan moves SetPositionY and
    DownlinkSat2Ground by default (each move said with why on stderr)
    and nothing planned with --stability lexicographic; a flag out of
    range is bad input (exit 2)."""
    plan1 = tmp_path / "plan1.json"
    assert cli("solve", TABLE1, "--out", str(plan1)).returncode == 0
    base = ["replan", TABLE1, str(plan1), TABLE2, "--now", "15"]
    free = cli(*base)
    assert free.returncode == 0, free.stderr
    assert "moved      SetPositionY [38, 39) -> [33, 34): " in free.stderr
    for flags in (
        ["--stability", "lexicographic"],
        ["--commit-window", "30", "--move-cost", "7"],
    ):
        plan2 = tmp_path / "plan2.json"
        kept = cli(*base, *flags, "--out", str(plan2))
        assert kept.returncode == 0, kept.stderr
        assert "\nmoved " not in kept.stderr
        starts = {
            a["task"]: a["start"]
            for a in json.loads(plan2.read_text())["activities"]
        }
        assert starts["SetPositionY"] == 38
    bad = cli(*base, "--move-cost", "0")
    assert bad.returncode == 2
    assert "--move-cost" in bad.stderr


def test_replan_rejects_colliding_goal(tmp_path: Path) -> None:
    """Tests that a goal reusing a live id is rejected with exit 2."""
    plan1 = tmp_path / "plan1.json"
    assert cli("solve", TABLE1, "--out", str(plan1)).returncode == 0
    goal = json.loads(Path(TABLE2).read_text())
    goal["tasks"][2]["id"] = "DownlinkSat2Ground"
    result = cli(
        "replan",
        TABLE1,
        str(plan1),
        _write(tmp_path / "g.json", goal),
        "--now",
        "15",
    )
    assert result.returncode == 2
    assert "tasks[2].id" in result.stderr


def test_replay_wait_matching_times_out_cleanly() -> None:
    """Tests that replay --wait-matching with no subscriber exits 1."""
    golden = ROOT / "replay" / "paper.mcap"
    result = cli(
        "replay",
        str(golden),
        "--burst",
        "--wait-matching",
        "0.3",
        "--wait-key",
        "fsw/nobody/**",
        "--no-multicast-scouting",
        "--listen",
        "tcp/127.0.0.1:0",
    )
    assert result.returncode == 1, result.stderr
    assert "timed out" in result.stderr
    assert "Traceback" not in result.stderr
