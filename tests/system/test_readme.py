"""Tests that the documentation runs as shown.

Every fenced block of README.md, replay/README.md and docs/*.md is either
checked here or listed in :data:`NOT_RUN` with the reason:

* ``json`` blocks decode as the document they show (a problem must also
  solve to a plan that schedules something), and a block that shows an
  ``examples/`` file equals that file;
* ``toml`` blocks are valid node settings;
* ``bash`` / ``sh`` blocks: every ``fsw-scheduler`` command that works
  offline runs, in order, in a scratch folder holding the files the README
  names, and must exit 0;
* the blocks of the README's session on the bus (those naming
  :data:`SESSION_ENDPOINT`) run against a live node: see
  :func:`test_the_session_on_the_bus_runs`;
* ``python`` blocks run in the same kind of scratch folder.

Every relative link of these documents must name a file that exists (and,
with ``#anchor``, one of its headings), the README's command table must
name every command of ``fsw-scheduler``, and the limits table of
docs/robustness.md must name real settings and flags with their defaults.
"""

from __future__ import annotations

import json
import re
import shlex
import shutil
import subprocess
import sys
import time
import tomllib
from pathlib import Path
from typing import TYPE_CHECKING

import msgspec
import pytest

from fsw_scheduler.app.cli.parser import build_parser
from fsw_scheduler.model.goal import decode_goal
from fsw_scheduler.model.problem import decode_problem
from fsw_scheduler.runtime.config import NodeConfig
from fsw_scheduler.solving.solve import solve
from fsw_scheduler.testing import SchedulerProcess

from ..factories import ROOT, free_port, tool_script

if TYPE_CHECKING:
    from collections.abc import Callable

DOCS = [
    ROOT / "README.md",
    ROOT / "replay" / "README.md",
    *sorted((ROOT / "docs").glob("*.md")),
]
FENCE = re.compile(
    r"^(?P<indent> *)```(?P<lang>[a-z]*)\n(?P<body>.*?)^(?P=indent)```",
    re.M | re.S,
)

#: Commands shown but not run here, each with the reason.
NOT_RUN = {
    "tools/demo": "the main job; CI and the newcomer check run it",
    "tools/test": "runs this suite",
    "tools/lock": "needs PyPI and rewrites the lock",
    "tools/bench": "minutes of solving; tests/system/test_bench.py runs its "
    "quick modes",
    "fsw-scheduler run": "a long-running bus component; the README's "
    "session runs in test_the_session_on_the_bus_runs, tests/bus/test_node.py "
    "runs it on loopback (the other endpoints shown are a deployment's)",
    "fsw-scheduler record": "needs a live bus; "
    "tests/app/test_cli_recording.py",
    "fsw-scheduler probe": "needs a live secure bus; "
    "tests/bus/test_security.py runs it against one",
    "fsw-scheduler replay --burst": "publishes on a live bus; "
    "tests/app/test_cli_recording.py",
    ".venv/bin/python tools/make_golden": "regenerates the golden files; "
    "`--check` runs in test_golden_tables_are_current",
    "mcap": "the Go `mcap` CLI is not a dependency",
    "pip install": "needs PyPI; the lock installs the extras here",
    "fsw-scheduler view": "a long-running bus component; "
    "tests/app/test_live_view.py runs it, in process and as a process",
    "fsw-scheduler ros2-bridge": "a long-running bus component; "
    "tests/app/test_ros2_bridge.py and tests/bus/test_ros2.py run it",
    "export RMW_IMPLEMENTATION": "the ROS 2 side (rmw_zenoh), not installed "
    "here; tests/bus/test_ros2.py stands in with zenoh-ros2-sdk",
    "ros2 ": "the ROS 2 command line, not installed here",
}


def blocks(lang: str) -> list[tuple[str, str]]:
    """``(where, body)`` of every fenced block in ``lang`` in the docs."""
    found = []
    for doc in DOCS:
        text = doc.read_text()
        for match in FENCE.finditer(text):
            if match["lang"] != lang:
                continue
            line = text[: match.start()].count("\n") + 1
            body = "\n".join(
                row.removeprefix(match["indent"])
                for row in match["body"].splitlines()
            )
            found.append((f"{doc.relative_to(ROOT)}:{line}", body))
    return found


def _ids(found: list[tuple[str, str]]) -> list[str]:
    return [where for where, _ in found]


def scratch(tmp_path: Path) -> Path:
    """A folder holding what the documented commands name."""
    for name in ("examples", "replay"):
        shutil.copytree(ROOT / name, tmp_path / name)
    shutil.copytree(
        ROOT / "fsw_scheduler" / "data", tmp_path / "fsw_scheduler" / "data"
    )
    return tmp_path


@pytest.mark.parametrize(
    ("where", "body"), blocks("json"), ids=_ids(blocks("json"))
)
def test_json_blocks_are_valid_documents(where: str, body: str) -> None:
    """Tests that each JSON block is a document the product accepts."""
    doc = json.loads(body)
    if "horizon" in doc:
        problem = decode_problem(body.encode())
        plan = solve(problem, "cbc", explain=False)
        assert plan.status.has_plan and plan.activities, where
    elif "goal_id" in doc:
        decode_goal(body.encode())
    else:
        pytest.fail(f"{where}: a JSON block of an unknown kind")
    shipped = [
        json.loads(p.read_text()) for p in (ROOT / "examples").glob("*.json")
    ]
    if doc.get("tasks"):
        assert doc in shipped, f"{where}: not the same as an examples/ file"


@pytest.mark.parametrize(
    ("where", "body"), blocks("toml"), ids=_ids(blocks("toml"))
)
def test_toml_blocks_are_valid_settings(where: str, body: str) -> None:
    """Tests that each TOML block is strict node settings, as shipped."""
    msgspec.convert(tomllib.loads(body), NodeConfig)
    shipped = (ROOT / "examples" / "scheduler.toml").read_text()
    assert body.strip() == shipped.strip(), (
        f"{where} and examples/scheduler.toml differ"
    )


def commands(body: str) -> list[str]:
    """Shell command lines of a block, continuations joined."""
    joined = re.sub(r"\\\n\s*", " ", body)
    lines = []
    for line in joined.splitlines():
        line = re.sub(r"\s+#.*$", "", line).strip()
        if line and not line.startswith("#"):
            lines.append(line)
    return lines


#: The endpoint of the README's session: ``fsw-scheduler run --listen`` on
#: it in one block, the commands that ``--connect`` (``-e``) to it in the
#: next. Every shell block naming it is part of the session, and the test
#: runs the session on a free port instead: it replaces the port of this
#: endpoint in each command line and changes nothing else.
SESSION_ENDPOINT = "tcp/127.0.0.1:7447"


def _in_session(where: str, body: str) -> bool:
    """A block of the README's session (other pages may show commands
    that join it, such as the ROS 2 bridge: those run as shell blocks)."""
    return where.startswith("README.md:") and SESSION_ENDPOINT in body


SHELL = [
    (where, body)
    for where, body in blocks("bash") + blocks("sh")
    if not _in_session(where, body)
]
SESSION = [
    (where, body)
    for where, body in blocks("bash") + blocks("sh")
    if _in_session(where, body)
]


@pytest.mark.parametrize(("where", "body"), SHELL, ids=_ids(SHELL))
def test_shell_blocks_run(where: str, body: str, tmp_path: Path) -> None:
    """Tests that each documented command runs as shown (or is excused)."""
    cwd = scratch(tmp_path)
    for line in commands(body):
        excuse = [k for k in NOT_RUN if line.startswith(k)]
        if excuse:
            continue
        argv = shlex.split(line)
        assert argv[0] == "fsw-scheduler", (
            f"{where}: `{line}` is neither run here nor in NOT_RUN"
        )
        # The installed script, as a user runs it: `python -m` would put
        # the scratch folder (with its fsw_scheduler/data) first on the path.
        script = Path(sys.executable).with_name("fsw-scheduler")
        result = subprocess.run(
            [str(script), *argv[1:]],
            cwd=cwd,
            capture_output=True,
            text=True,
            timeout=300,
        )
        assert result.returncode == 0, f"{where}: {line}\n{result.stderr}"


def test_the_session_on_the_bus_runs(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """Tests the README's session as a newcomer types it: the ``run`` line
    starts a node in the background, on a free port, and once it logs that
    it is up, every other command runs as written, in order, and exits 0;
    the goal is accepted and is in the plan; then the node stops."""
    assert SESSION, f"no shell block names {SESSION_ENDPOINT}"
    assert {where.split(":")[0] for where, _ in SESSION} == {"README.md"}
    endpoint = f"tcp/127.0.0.1:{free_port()}"
    lines = [
        line.replace(SESSION_ENDPOINT, endpoint)
        for _, body in SESSION
        for line in commands(body)
    ]
    runs = [line for line in lines if line.startswith("fsw-scheduler run ")]
    assert len(runs) == 1, runs
    # SchedulerProcess starts the node in the current folder: the scratch
    # one, where the README's relative paths hold.
    monkeypatch.chdir(scratch(tmp_path))
    node = SchedulerProcess(shlex.split(runs[0])[2:])
    assert node.start() == "scheduler up on", "".join(node.log)
    script = Path(sys.executable).with_name("fsw-scheduler")
    answers: dict[str, list[dict]] = {}
    try:
        for line in lines:
            if line in runs:
                continue
            argv = shlex.split(line)
            assert argv[0] == "fsw-scheduler", line
            result = subprocess.run(
                [str(script), *argv[1:]],
                capture_output=True,
                text=True,
                timeout=120,
            )
            assert result.returncode == 0, f"{line}\n{result.stderr}"
            answers.setdefault(" ".join(argv[1:3]), []).append(
                json.loads(result.stdout)
            )
        # "A moment later": the early completion's replan, asked for as
        # the README does until it is in (a solve, then the plan).
        last = _plan_when(
            [str(script), "plan", "-m", "client", "-e", endpoint],
            lambda p: p["trigger"] == "early_completion",
        )
    finally:
        assert node.stop() == 0, "".join(node.log)
    goal = json.loads((ROOT / "examples" / "goal.json").read_text())
    verdict = answers[next(k for k in answers if k == "send goal")][0]
    assert (verdict["event"], verdict["goal_id"]) == (
        "goal_accepted",
        goal["goal_id"],
    )
    plan = next(v for k, v in answers.items() if k.startswith("plan"))[0]
    assert goal["goal_id"] in plan["goals"]
    # What the README says of plan 2.
    starts = {a["task"]: a["start"] for a in plan["activities"]}
    assert starts == {"Point": 0, "Acquire": 1, "Downlink": 10}
    # The what-if, the goal it foretold, and the early completion.
    [answer] = answers["what-if examples/calibrate.json"]
    assert answer["verdict"] == "goal_accepted"
    assert answer["plan"]["plan_id"] is None
    foretold = {a["task"]: a["start"] for a in answer["plan"]["activities"]}
    assert foretold["Calibrate"] == 6
    assert [v["event"] for v in answers["send goal"]] == ["goal_accepted"] * 2
    assert (last["plan_id"], last["trigger"]) == (5, "early_completion")
    pulled = {a["task"]: a["start"] for a in last["activities"]}
    assert (pulled["Calibrate"], pulled["Downlink"]) == (3, 10)


def _plan_when(
    argv: list[str], done: Callable[[dict], bool], timeout: float = 60.0
) -> dict:
    """The node's plan, asked for again until ``done`` says it is in."""
    deadline = time.monotonic() + timeout
    while True:
        result = subprocess.run(
            argv, capture_output=True, text=True, timeout=120
        )
        assert result.returncode == 0, result.stderr
        plan = json.loads(result.stdout)
        if done(plan) or time.monotonic() > deadline:
            return plan


@pytest.mark.parametrize(
    ("where", "body"), blocks("python"), ids=_ids(blocks("python"))
)
def test_python_blocks_run(where: str, body: str, tmp_path: Path) -> None:
    """Tests that each Python block runs in a fresh interpreter."""
    # -P: the scratch folder's fsw_scheduler/data must not shadow the
    # installed package, as it would from the current directory.
    result = subprocess.run(
        [sys.executable, "-P", "-c", body],
        cwd=scratch(tmp_path),
        capture_output=True,
        text=True,
        timeout=300,
    )
    assert result.returncode == 0, f"{where}\n{result.stderr}"


def test_every_block_language_is_handled() -> None:
    """Tests that no fenced block escapes the checks above unnoticed."""
    handled = {"json", "toml", "bash", "sh", "python", ""}
    for doc in DOCS:
        for match in FENCE.finditer(doc.read_text()):
            assert match["lang"] in handled, (doc, match["lang"])


def test_golden_tables_are_current() -> None:
    """Tests that replay/README.md's tables match the recordings."""
    make_golden = tool_script("make_golden")
    assert make_golden.readme_is_current(), (
        "run: .venv/bin/python tools/make_golden (rewrites the tables)"
    )


def test_no_pointer_to_unshipped_documents() -> None:
    """Tests that no shipped text sends users to a document they lack."""
    texts = [
        *(ROOT / "fsw_scheduler").rglob("*.py"),
        *(ROOT / "schemas").glob("*.json"),
        *DOCS,
    ]
    offenders = [
        str(p.relative_to(ROOT))
        for p in texts
        if re.search(r"CONTRACT|STYLE\.md|shared/", p.read_text())
    ]
    assert offenders == []


def test_license_file_matches_pyproject() -> None:
    """Tests that the licence pyproject names is shipped in full."""
    pyproject = tomllib.loads((ROOT / "pyproject.toml").read_text())
    assert pyproject["project"]["license"] == "Apache-2.0"
    assert "LICENSE" in pyproject["project"]["license-files"]
    text = (ROOT / "LICENSE").read_text()
    assert "Apache License" in text and "Version 2.0" in text


LINK = re.compile(r"!?\[[^\]]*\]\((?P<target>[^)\s]+)\)")


def anchors(doc: Path) -> set[str]:
    """The anchors GitHub makes of a Markdown file's headings."""
    text = FENCE.sub("", doc.read_text())
    found = set()
    for heading in re.findall(r"^#+ (.+)$", text, re.M):
        slug = re.sub(r"[^\w\- ]", "", heading.lower()).replace(" ", "-")
        found.add(slug)
    return found


@pytest.mark.parametrize(
    "doc", DOCS, ids=[str(d.relative_to(ROOT)) for d in DOCS]
)
def test_relative_links_name_files_that_exist(doc: Path) -> None:
    """Tests that every relative link of a document names a shipped file,
    and that an ``#anchor`` names one of that file's headings."""
    broken = []
    for match in LINK.finditer(FENCE.sub("", doc.read_text())):
        target = match["target"]
        if re.match(r"[a-z]+:", target):
            continue
        path, _, anchor = target.partition("#")
        file = (doc.parent / path).resolve() if path else doc
        unknown = bool(anchor) and file.suffix == ".md"
        if not file.exists() or (unknown and anchor not in anchors(file)):
            broken.append(target)
    assert broken == [], f"{doc.relative_to(ROOT)}: {broken}"


def test_the_command_table_names_every_command() -> None:
    """Tests that each command of ``fsw-scheduler`` has a row in the
    README's command table, and that the table names no other."""
    parser = build_parser()
    [sub] = [
        a
        for a in parser._actions
        if a.__class__.__name__ == "_SubParsersAction"
    ]
    assert sub.choices is not None  # the commands
    text = (ROOT / "README.md").read_text()
    rows = re.findall(r"^\| `([a-z0-9-]+)[ `|\\]", text, re.M)
    table = set(rows) - {"command"}
    # A row may name several: `status\|plan ...`.
    for alias in re.findall(r"^\| `[a-z0-9-]+\\\|([a-z0-9-]+)", text, re.M):
        table.add(alias)
    assert set(sub.choices) <= table, set(sub.choices) - table


def test_the_limits_table_matches_the_settings() -> None:
    """Tests that each row of docs/robustness.md's limits table names
    settings and ``run`` flags that exist, with the defaults they have."""
    import argparse

    text = (ROOT / "docs" / "robustness.md").read_text()
    table = text.split("| limit | default | setting / flag | beyond it |")[1]
    defaults = {
        f.encode_name: getattr(NodeConfig(), f.name)
        for f in msgspec.structs.fields(NodeConfig)
    }
    [sub] = [
        a
        for a in build_parser()._actions
        if isinstance(a, argparse._SubParsersAction)
    ]
    flags = set(sub.choices["run"]._option_string_actions)
    checked = 0
    for row in table.strip().splitlines()[1:]:
        if not row.startswith("|"):
            break
        _, default, names, _ = row.strip("|").split("|")
        settings = re.findall(r"`([a-z-]+)`", names)
        for flag in re.findall(r"`(--[a-z-]+)`", names):
            assert flag in flags, row
        numbers = re.findall(r"(\d+) ?(MiB)?", default)
        for name, (number, unit) in zip(settings, numbers, strict=False):
            assert name in defaults, row
            scale = 2**20 if unit else 1
            assert defaults[name] == int(number) * scale, (name, row)
            checked += 1
    assert checked >= 10
