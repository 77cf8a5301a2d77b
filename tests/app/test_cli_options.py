"""Tests of first-touch behaviour of the command line: optional
dependencies, argument checks, help texts, exit codes and ``schemas``."""

from __future__ import annotations

import argparse
import json
import shutil
import subprocess
import sys
from typing import TYPE_CHECKING

import pytest

from fsw_scheduler.cli import build_parser
from fsw_scheduler.runtime import schemas

from ..factories import CLI, ROOT, TABLE1

if TYPE_CHECKING:
    from pathlib import Path


# Runs the CLI in a fresh interpreter where `import matplotlib` fails, as
# after a plain `pip install fsw-scheduler` without the plot extra.
WITHOUT_MATPLOTLIB = (
    "import sys; sys.modules['matplotlib'] = None; "
    "from fsw_scheduler.cli import main; sys.exit(main(sys.argv[1:]))"
)


def run(
    *args: str, code: str | None = None, cwd: Path | None = None
) -> subprocess.CompletedProcess:
    """``fsw-scheduler args`` in a subprocess (or ``code`` with args)."""
    head = ["-c", code] if code else ["-m", "fsw_scheduler.cli"]
    return subprocess.run(
        [sys.executable, *head, *args],
        capture_output=True,
        text=True,
        timeout=300,
        cwd=cwd,
    )


def test_solve_gantt_without_matplotlib_stops_before_solving(
    tmp_path: Path,
) -> None:
    """Tests that solve --gantt without matplotlib exits 2 with the hint."""
    result = run(
        "solve",
        TABLE1,
        "--gantt",
        str(tmp_path / "p.png"),
        code=WITHOUT_MATPLOTLIB,
    )
    assert result.returncode == 2, result.stderr
    assert "Traceback" not in result.stderr
    assert "pip install 'fsw-scheduler[plot]'" in result.stderr
    assert result.stdout == ""  # nothing was solved
    assert not (tmp_path / "p.png").exists()


def test_solve_without_matplotlib_still_solves() -> None:
    """Tests that a solve asking for no picture needs no matplotlib."""
    result = run("solve", TABLE1, code=WITHOUT_MATPLOTLIB)
    assert result.returncode == 0, result.stderr
    assert json.loads(result.stdout)["status"] == "optimal"


def test_demo_without_matplotlib_runs_without_pictures(
    tmp_path: Path,
) -> None:
    """Tests that demo without matplotlib says so and still completes."""
    out = tmp_path / "demo"
    result = run(
        "demo",
        "--out",
        str(out),
        "--quiet",
        "--time-unit",
        "0.01",
        code=WITHOUT_MATPLOTLIB,
    )
    assert result.returncode == 0, result.stderr
    assert "Traceback" not in result.stderr
    assert "without pictures" in result.stderr
    assert "IDENTICAL" in result.stdout
    assert not list(out.glob("*.png"))
    assert (out / "plan-1.txt").read_text().startswith("Plan:")
    assert (out / "session.mcap").stat().st_size > 0


@pytest.mark.parametrize(
    ("args", "message"),
    [
        (["solve", TABLE1, "--time-limit", "-1"], "must be > 0"),
        (["solve", TABLE1, "--time-limit", "0"], "must be > 0"),
        (["solve", TABLE1, "--time-limit", "nan"], "not finite"),
        (["solve", TABLE1, "--time-limit", "ten"], "not a number"),
        (["run", "--horizon", "0"], "must be > 0"),
        (["run", "--time-unit", "-0.5"], "must be > 0"),
        (["replay", "x.mcap", "--rate", "0"], "must be > 0"),
        (["record", "--out", "x.mcap", "--split-size", "1.5"], "integer"),
    ],
)
def test_bad_numbers_are_refused_with_exit_2(
    args: list[str], message: str
) -> None:
    """Tests that negative, zero or non-finite limits exit 2 at parsing."""
    result = run(*args)
    assert result.returncode == 2
    assert message in result.stderr
    assert "Traceback" not in result.stderr


def test_log_level_after_the_command() -> None:
    """Tests that --log-level works after the command name as well."""
    quiet = run("solve", TABLE1, "--log-level", "warning")
    assert quiet.returncode == 0, quiet.stderr
    assert "INFO" not in quiet.stderr
    before = run("--log-level", "warning", "solve", TABLE1)
    assert before.returncode == 0 and "INFO" not in before.stderr
    loud = run("solve", TABLE1)
    assert "INFO" in loud.stderr


def test_settings_file_with_unknown_key_exits_2(tmp_path: Path) -> None:
    """Tests that a TOML settings typo is bad input (exit 2), named."""
    settings = tmp_path / "scheduler.toml"
    settings.write_text('spacecraft = "sat1"\ntime-limt = 3\n')
    result = run("run", "--config", str(settings), "--horizon", "10")
    assert result.returncode == 2, result.stderr
    assert "time-limt" in result.stderr
    assert "Traceback" not in result.stderr


def _every_action() -> list[tuple[str, argparse.Action]]:
    parser = build_parser()
    found = [("fsw-scheduler", a) for a in parser._actions]
    for action in parser._actions:
        if isinstance(action, argparse._SubParsersAction):
            for name, sub in action.choices.items():
                found += [(name, a) for a in sub._actions]
    return found


def test_every_flag_has_help() -> None:
    """Tests that each argument of each command carries a help text."""
    missing = [
        f"{command} {action.option_strings or action.dest}"
        for command, action in _every_action()
        if not isinstance(action, argparse._SubParsersAction)
        and not (action.help and action.help.strip())
    ]
    assert missing == []


def test_every_command_has_an_example() -> None:
    """Tests that every command's --help ends with examples (the epilog)."""
    parser = build_parser()
    (sub,) = (
        a for a in parser._actions if isinstance(a, argparse._SubParsersAction)
    )
    without = [
        name
        for name, command in sub.choices.items()
        if "fsw-scheduler " + name not in (command.epilog or "")
        or not (command.epilog or "").startswith("example")
    ]
    assert without == []


def test_settings_flag_and_deprecated_toml_config(tmp_path: Path) -> None:
    """Tests --settings, and --config FILE.toml with its deprecation."""
    settings = tmp_path / "scheduler.toml"
    settings.write_text('spacecraft = "sat1"\ntime-limt = 3\n')
    new = run("run", "--settings", str(settings), "--horizon", "10")
    assert new.returncode == 2 and "time-limt" in new.stderr
    assert "deprecated" not in new.stderr
    old = run("run", "--config", str(settings), "--horizon", "10")
    assert old.returncode == 2 and "time-limt" in old.stderr
    assert "deprecated: --config" in old.stderr
    assert f"--settings {settings}" in old.stderr


def test_zenoh_short_flags_parse() -> None:
    """Tests the zenoh examples' short flags on a bus command."""
    args = build_parser().parse_args(
        [
            "record",
            "--out",
            "x.mcap",
            "-m",
            "client",
            "-e",
            "tcp/1.2.3.4:7447",
            "-l",
            "tcp/0.0.0.0:0",
            "-c",
            "z.json5",
            "--no-multicast-scouting",
            "--exclude",
            "fsw/sat1/clock",
        ]
    )
    assert args.mode == "client" and args.connect == ["tcp/1.2.3.4:7447"]
    assert args.listen == ["tcp/0.0.0.0:0"] and args.config == ["z.json5"]
    assert args.no_multicast_scouting and args.exclude == ["fsw/sat1/clock"]
    rep = build_parser().parse_args(
        ["replay", "f.mcap", "-r", "2", "--clock", "--remap", "a/b=a/c"]
    )
    assert rep.rate == 2 and rep.clock == 1.0
    assert rep.remap == [("a/b", "a/c")]


def test_bad_remap_exits_2() -> None:
    """Tests that a malformed --remap is refused at parsing."""
    result = run("replay", "f.mcap", "--remap", "fsw/sat1")
    assert result.returncode == 2 and "OLD=NEW" in result.stderr


def test_schemas_command_writes_the_shipped_schemas(tmp_path: Path) -> None:
    """Tests that `schemas --out` writes the same files as schemas/."""
    result = run("schemas", "--out", str(tmp_path / "s"))
    assert result.returncode == 0, result.stderr
    written = {p.name: p.read_text() for p in (tmp_path / "s").iterdir()}
    shipped = {
        p.name: p.read_text() for p in (ROOT / "schemas").glob("*.json")
    }
    assert written == shipped == schemas.schema_files()


def test_output_to_a_closed_pipe_is_quiet() -> None:
    """Tests that a reader going away (`solve ... | head`) ends quietly."""
    process = subprocess.Popen(
        [*CLI, "solve", TABLE1],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
    )
    # The reader is gone before the plan (printed after the solve) is.
    assert process.stdout is not None
    process.stdout.close()
    _, stderr = process.communicate(timeout=120)
    assert process.returncode == 141
    assert b"Traceback" not in stderr
    assert b"Broken pipe" not in stderr


def test_info_json_is_machine_readable() -> None:
    """Tests `info --json` on a golden journal: channels, counts, span."""
    # The 0.1.0 recording: no metadata, a fixed message count.
    legacy = ROOT / "replay" / "paper-2026-11-26.mcap"
    result = run("info", str(legacy), "--json")
    assert result.returncode == 0, result.stderr
    data = json.loads(result.stdout)
    assert data["messages"] == 152
    assert data["finished"] is True
    topics = {c["topic"]: c["messages"] for c in data["channels"]}
    assert topics["fsw/sat1/scheduler/plan"] == 2
    assert data["duration_s"] >= 0 and data["metadata"] == {}


def test_demo_says_what_it_does_after_the_timeline(tmp_path: Path) -> None:
    """Tests that the demo says it is drawing, then verifying, before each
    of those silent phases, and then the verdict."""
    result = run(
        "demo", "--out", str(tmp_path / "demo"), "--time-unit", "0.01"
    )
    assert result.returncode == 0, result.stderr
    text = result.stdout
    drawing = text.index("plan pictures and the levels")
    checking = text.index("through a fresh scheduler")
    verdict = text.index("replay --verify: IDENTICAL")
    assert drawing < checking < verdict


def test_every_command_takes_verbose_and_quiet() -> None:
    """Tests that ``-v`` and ``-q`` exist on every command, before or
    after its name, and set the log level (debug; warning)."""
    import argparse

    from fsw_scheduler.app.cli.parser import build_parser, log_level

    parser = build_parser()
    (commands,) = [
        action
        for action in parser._actions
        if isinstance(action, argparse._SubParsersAction)
    ]
    assert len(commands.choices) > 15
    for name, sub in commands.choices.items():
        flags = {
            flag for action in sub._actions for flag in action.option_strings
        }
        assert {"-v", "--verbose", "-q", "--quiet"} <= flags, name
    args = parser.parse_args(["schemas", "--out", "x", "-v"])
    assert log_level(args) == "debug"
    args = parser.parse_args(["-q", "schemas", "--out", "x"])
    assert (log_level(args), args.quiet) == ("warning", True)
    assert log_level(parser.parse_args(["schemas", "--out", "x"])) == "info"


@pytest.mark.parametrize(
    ("args", "flag"),
    [
        (["status"], "-e/--connect"),
        (["send", "clock", '{"now": 1}'], "-e/--connect"),
        (["record", "--out", "{tmp}/bus.mcap"], "-e/--connect"),
        (["replay", str(ROOT / "replay" / "paper.mcap")], "-e/--connect"),
        (["view", "--port", "0"], "-e/--connect"),
    ],
)
def test_an_unreachable_endpoint_is_one_line_naming_the_flag(
    args: list[str], flag: str, tmp_path: Path
) -> None:
    """Tests each command on the bus given a router that is not there:
    one line naming the endpoint and the flag, no traceback, no Rust
    internals, no file left behind by ``record``."""
    from ..factories import free_port

    args = [a.replace("{tmp}", str(tmp_path)) for a in args]
    endpoint = f"tcp/127.0.0.1:{free_port()}"
    done = run(*args, "-m", "client", "-e", endpoint)
    assert done.returncode == 1, done.stderr
    lines = done.stderr.strip().splitlines()
    assert len(lines) == 1, done.stderr
    assert f"cannot reach {endpoint}" in lines[0]
    assert flag in lines[0]
    for internal in ("Traceback", ".rs:", "Single(", "Json5Err"):
        assert internal not in done.stderr
    assert not list(tmp_path.iterdir())


@pytest.mark.parametrize(
    ("args", "words"),
    [
        (["-l", "tcp/127.0.0.1:99999"], "-l/--listen"),
        (["--cfg", "mode:bogus"], "--cfg 'mode:bogus': not a JSON5 value"),
        (["-e", "tcp127.0.0.1:7447"], "-e/--connect"),
        (["-c", "/nonexistent/zenoh.json5"], "-c/--config"),
    ],
)
def test_a_bad_zenoh_setting_is_one_line_naming_the_flag(
    args: list[str], words: str
) -> None:
    """Tests a bad port, a --cfg value that is not JSON5, an endpoint
    without its protocol and a missing Zenoh file: one line, the flag."""
    done = run("status", "--timeout", "1", *args)
    assert done.returncode in (1, 2), done.stderr
    lines = done.stderr.strip().splitlines()
    assert len(lines) == 1, done.stderr
    assert words in lines[0]
    for internal in ("Traceback", ".rs:", "Single(", "Json5Err", "cargo"):
        assert internal not in done.stderr


#: Modules a command that talks to a node has no use for: the solver, the
#: journal, the pictures, the Foxglove server and what they pull in.
HEAVY = (
    "pulp",
    "highspy",
    "mcap",
    "matplotlib",
    "numpy",
    "foxglove",
    "fsw_scheduler.solving",
    "fsw_scheduler.engine",
    "fsw_scheduler.journal",
    "fsw_scheduler.analysis",
    "fsw_scheduler.replan",
    "fsw_scheduler.api",
)


def test_the_command_line_imports_only_what_a_command_needs() -> None:
    """Tests the import cost of the command line: parsing ``status``
    loads none of the solver, the journal, MCAP, the pictures or the
    Foxglove server (they come with the commands that use them)."""
    code = (
        "import sys\n"
        "from fsw_scheduler.app.cli.main import main\n"
        "try:\n"
        "    main(['status', '--help'])\n"
        "except SystemExit:\n"
        "    pass\n"
        "print('\\n'.join(sorted(sys.modules)))\n"
    )
    done = run(code=code)
    assert done.returncode == 0, done.stderr
    loaded = set(done.stdout.split())
    heavy = sorted(
        name
        for name in loaded
        if any(name == h or name.startswith(h + ".") for h in HEAVY)
    )
    assert heavy == [], heavy


def test_the_layout_and_the_examples_are_shipped(tmp_path: Path) -> None:
    """Tests that the package holds the layout and the examples the clone
    has (byte for byte), that ``layout`` and ``examples`` write them, and
    that a wheel built from the project carries them."""
    data = ROOT / "fsw_scheduler" / "data"
    docs_layout = ROOT / "docs" / "foxglove-layout.json"
    assert (data / "foxglove-layout.json").read_bytes() == (
        docs_layout.read_bytes()
    )
    clone = sorted(p.name for p in (ROOT / "examples").iterdir())
    assert sorted(p.name for p in (data / "examples").iterdir()) == clone
    for name in clone:
        assert (data / "examples" / name).read_bytes() == (
            ROOT / "examples" / name
        ).read_bytes()
    done = run("layout", "--out", str(tmp_path / "layout.json"))
    assert done.returncode == 0, done.stderr
    assert (tmp_path / "layout.json").read_bytes() == docs_layout.read_bytes()
    done = run("examples", "--out", str(tmp_path / "examples"))
    assert done.returncode == 0, done.stderr
    assert sorted(p.name for p in (tmp_path / "examples").iterdir()) == clone
    # Built from a copy: an in-tree build would leave build/ behind.
    source = tmp_path / "source"
    shutil.copytree(
        ROOT,
        source,
        ignore=shutil.ignore_patterns(
            ".*", "build", "*.egg-info", "__pycache__", "replay", "tests"
        ),
    )
    wheel = subprocess.run(
        [
            sys.executable,
            "-m",
            "pip",
            "wheel",
            "--no-deps",
            "--no-build-isolation",
            "--wheel-dir",
            str(tmp_path / "dist"),
            str(source),
        ],
        capture_output=True,
        text=True,
        timeout=300,
        check=False,
    )
    assert wheel.returncode == 0, wheel.stderr
    import zipfile

    (built,) = (tmp_path / "dist").glob("*.whl")
    names = set(zipfile.ZipFile(built).namelist())
    assert "fsw_scheduler/data/foxglove-layout.json" in names
    for name in clone:
        assert f"fsw_scheduler/data/examples/{name}" in names


def test_the_sdist_is_the_whole_project(tmp_path: Path) -> None:
    """Tests a source distribution built from the project: it holds the
    docs, examples, schemas, golden journals, every test, the tools and
    the lock, besides the package."""
    source = tmp_path / "source"
    shutil.copytree(
        ROOT,
        source,
        ignore=shutil.ignore_patterns(
            ".*", "build", "dist", "*.egg-info", "__pycache__", "out"
        ),
    )
    done = subprocess.run(
        [
            sys.executable,
            "-c",
            "import sys; from setuptools import build_meta; "
            "print(build_meta.build_sdist(sys.argv[1]))",
            str(tmp_path / "dist"),
        ],
        cwd=source,
        capture_output=True,
        text=True,
        timeout=300,
        check=False,
    )
    assert done.returncode == 0, done.stderr
    import tarfile

    (built,) = (tmp_path / "dist").glob("*.tar.gz")
    with tarfile.open(built) as archive:
        names = {
            name.split("/", 1)[1] for name in archive.getnames() if "/" in name
        }
    wanted = {
        str(path.relative_to(source))
        for top in ("docs", "examples", "schemas", "replay", "tests", "tools")
        for path in (source / top).rglob("*")
        if path.is_file()
    }
    wanted |= {
        "requirements-lock.txt",
        "fsw_scheduler/data/foxglove-layout.json",
    }
    assert not wanted - names, sorted(wanted - names)[:10]


def test_predictable_replan_flags_override_the_settings_file(
    tmp_path: Path,
) -> None:
    """Tests that run's --commit-window, --stability, --move-cost and
    --early-completion-gain override the TOML file, and that a flag left
    out keeps the file's value."""
    from fsw_scheduler.app.cli.run import node_settings

    settings = tmp_path / "scheduler.toml"
    settings.write_text("commit-window = 3\nmove-cost = 8\n")
    args = build_parser().parse_args(
        [
            "run",
            "--settings",
            str(settings),
            "--stability",
            "moves",
            "--early-completion-gain",
            "2",
            "--commit-window",
            "6",
            "--late-completion",
            "push",
        ]
    )
    config = node_settings(args)
    assert config.commit_window == 6
    assert config.stability == "moves"
    assert config.move_cost == 8
    assert config.early_completion_gain == 2
    assert config.late_completion == "push"


@pytest.mark.parametrize(
    "flags",
    [
        ("--commit-window", "-1"),
        ("--move-cost", "0"),
        ("--move-cost", "1001"),
        ("--stability", "on"),
        ("--early-completion-gain", "x"),
        ("--late-completion", "wait"),
    ],
)
def test_predictable_replan_flags_out_of_range_exit_2(
    flags: tuple[str, str],
) -> None:
    """Tests that a predictable-replan flag out of its range is bad input
    (exit 2), named, before anything starts."""
    result = run("run", "--horizon", "10", *flags)
    assert result.returncode == 2, result.stderr
    assert flags[0] in result.stderr
    assert "Traceback" not in result.stderr
