"""Tests of the table of ``run``'s flags and the settings they override."""

from __future__ import annotations

import argparse
from typing import TYPE_CHECKING

import msgspec
import pytest

from fsw_scheduler.app.cli.parser import build_parser
from fsw_scheduler.app.cli.run_flags import RUN_FLAGS, RunFlag, run_settings
from fsw_scheduler.runtime.config import NodeConfig, load_config

if TYPE_CHECKING:
    from pathlib import Path

#: Every field of the node settings.
FIELDS = {f.name for f in msgspec.structs.fields(NodeConfig)}

#: Flags of ``run`` that are not the table's: Zenoh's (bus.session) and
#: the one every command has (app.cli.parser).
OTHERS = {
    "-m",
    "-e",
    "-l",
    "-c",
    "--cfg",
    "--no-multicast-scouting",
    "--log-level",
    # Every command's own: the log level.
    "-v",
    "-q",
}


def run_parser() -> argparse.ArgumentParser:
    """The parser of ``fsw-scheduler run``, as the command builds it."""
    (sub,) = (
        a
        for a in build_parser()._actions
        if isinstance(a, argparse._SubParsersAction)
    )
    parser = sub.choices["run"]
    assert isinstance(parser, argparse.ArgumentParser)
    return parser


def run_flags() -> dict[str, argparse.Action]:
    """Each long flag of ``run`` with its action (``--help`` left out)."""
    flags = {}
    for action in run_parser()._actions:
        if isinstance(action, argparse._HelpAction):
            continue
        if not set(action.option_strings) & OTHERS:
            (name,) = [o for o in action.option_strings if o.startswith("--")]
            flags[name] = action
    return flags


def test_every_setting_with_a_flag_is_mapped_by_the_table() -> None:
    """Tests that each flag of ``run`` named after a setting (or switching
    one off, ``--no-<setting>``) is the table's, mapped to that setting,
    and that the table declares exactly the flags ``run`` has."""
    table = {flag.name: flag for flag in RUN_FLAGS}
    declared = run_flags()
    assert list(declared) == list(table)
    named = {}
    for name, action in declared.items():
        assert action.dest == table[name].dest
        for setting in (action.dest, action.dest.removeprefix("no_")):
            if setting in FIELDS:
                named[name] = setting
    mapped = {f.name: f.setting for f in RUN_FLAGS if f.setting is not None}
    assert mapped == named
    assert len(mapped) == 21


def sample(flag: RunFlag) -> list[str]:
    """Command-line words giving ``flag`` a value unlike the default."""
    if flag.options.get("action") == "store_true":
        return [flag.name]
    default = getattr(NodeConfig(), flag.setting or "")
    for choice in flag.options.get("choices", ()):
        if choice != default:
            return [flag.name, choice]
    if "type" in flag.options:
        return [flag.name, "7"]
    return [flag.name, "x7"]


@pytest.mark.parametrize(
    "flag", [f for f in RUN_FLAGS if f.setting], ids=lambda f: f.name
)
def test_each_flag_sets_its_setting_alone(flag: RunFlag) -> None:
    """Tests that a flag given changes its own setting, to the value
    given, and no other."""
    assert flag.setting is not None
    args = run_parser().parse_args(sample(flag))
    base = NodeConfig()
    config = base.replace(**run_settings(args))
    given = getattr(args, flag.dest)
    expected = given if flag.value is None else flag.value(given)
    assert getattr(config, flag.setting) == expected
    assert expected != getattr(base, flag.setting)
    changed = {
        name
        for name, value in msgspec.structs.asdict(config).items()
        if value != getattr(base, name)
    }
    assert changed == {flag.setting}


def test_flags_not_given_keep_the_settings_file(tmp_path: Path) -> None:
    """Tests that only the flags given override the settings file."""
    settings = tmp_path / "scheduler.toml"
    settings.write_text(
        'clock = "bus"\ntasks-per-goal = 5\nstandby = false\nrank = 3\n'
    )
    from_file = load_config(settings)
    args = run_parser().parse_args(["--rank", "1"])
    assert set(run_settings(args).values()) == {None, 1}
    config = from_file.replace(**run_settings(args))
    assert config == msgspec.structs.replace(from_file, rank=1)
    assert (config.clock, config.tasks_per_goal, config.standby) == (
        "bus",
        5,
        False,
    )


def test_a_bad_flag_value_is_refused_by_the_settings() -> None:
    """Tests that a value the settings refuse raises as the command maps
    it (run exits 2 naming it)."""
    args = run_parser().parse_args(["--tasks-per-goal", "0"])
    with pytest.raises(ValueError, match="tasks-per-goal: must be >= 1"):
        NodeConfig().replace(**run_settings(args))
