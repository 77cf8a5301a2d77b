"""Tests of the node settings file (fsw_scheduler.runtime.config)."""

from __future__ import annotations

from typing import TYPE_CHECKING

import pytest

from fsw_scheduler.errors import ConfigError
from fsw_scheduler.runtime.config import NodeConfig, load_config

if TYPE_CHECKING:
    from pathlib import Path


def test_defaults_without_a_file() -> None:
    """Tests that no file gives the documented defaults."""
    config = load_config(None)
    assert config == NodeConfig()
    assert config.solver == "cbc" and config.threads == 1
    assert config.lead == 1  # wall clock: one unit of lead
    assert NodeConfig(clock="bus").lead == 0


def test_kebab_case_keys_are_read(tmp_path: Path) -> None:
    """Tests that a TOML file with kebab-case keys is read."""
    path = tmp_path / "scheduler.toml"
    path.write_text(
        'spacecraft = "sat7"\nclock = "bus"\ntime-limit = 3.5\n'
        "report-timeout = 4\ndrift-absolute = 2.0\nreplan-lead = 2\n"
    )
    config = load_config(path)
    assert config.spacecraft == "sat7"
    assert config.time_limit == 3.5
    assert config.report_timeout == 4
    assert config.tolerance.absolute == 2.0
    assert config.lead == 2


@pytest.mark.parametrize(
    ("text", "words"),
    [
        ("time-limitt = 3\n", "time-limitt"),
        ('solver = "gurobi"\n', "solver"),
        ("time-unit = 0\n", "time-unit"),
        ("inbox-capacity = 0\n", "inbox-capacity"),
        ('spacecraft = "sat/1"\n', "spacecraft"),
        ("tasks-per-goal = 0\n", "tasks-per-goal"),
        ("max-clock-step = 0\n", "max-clock-step"),
        ("clock-stall = -1\n", "clock-stall"),
        ("response-deadline = 0\n", "response-deadline"),
        ("inbox-bytes = 10\n", "inbox-bytes"),
        ("commit-window = -1\n", "commit-window"),
        ('stability = "strict"\n', "stability"),
        ("move-cost = 0\n", "move-cost"),
        ("move-cost = 1001\n", "move-cost"),
        ("early-completion-gain = -2\n", "early-completion-gain"),
        ('late-completion = "wait"\n', "late-completion"),
        ("commit-window = 2.5\n", "commit-window"),
        ("this is not toml", "scheduler.toml"),
    ],
)
def test_bad_settings_name_the_key(
    tmp_path: Path, text: str, words: str
) -> None:
    """Tests that typos and bad values are errors naming the key."""
    path = tmp_path / "scheduler.toml"
    path.write_text(text)
    with pytest.raises(ConfigError) as info:
        load_config(path)
    assert words in str(info.value)


def test_missing_file_is_a_config_error(tmp_path: Path) -> None:
    """Tests that an unreadable settings file is reported, not raised."""
    with pytest.raises(ConfigError, match="cannot read"):
        load_config(tmp_path / "absent.toml")


def test_command_line_overrides_keep_unset_values() -> None:
    """Tests that replace() ignores options the user did not give."""
    config = NodeConfig(solver="highs").replace(solver=None, seed=3)
    assert config.solver == "highs" and config.seed == 3


def test_every_mistake_of_a_settings_file_at_once(tmp_path: Path) -> None:
    """Tests that a settings file with several mistakes names them all,
    with the closest key, and says that keys are kebab-case."""
    path = tmp_path / "scheduler.toml"
    path.write_text('report_timeout = 5\nheartbeat = "x"\nclock = "gps"\n')
    with pytest.raises(ConfigError) as info:
        load_config(path)
    text = str(info.value)
    assert (
        "report_timeout: unknown field (did you mean 'report-timeout'?)"
        in (text)
    )
    assert "heartbeat: must be an integer" in text
    assert "clock: must be one of 'bus', 'wall', got 'gps'" in text
    assert "kebab-case" in text


@pytest.mark.parametrize(
    ("text", "words"),
    [
        ("heartbeat = -1\n", "heartbeat: must be >= 0, got -1"),
        ("threads = 0\n", "threads: must be >= 1, got 0"),
        ("drift-relative = -0.1\n", "drift-relative: must be >= 0"),
        ("report-timeout = 0\n", "report-timeout: must be >= 1"),
        ("replan-lead = -2\n", "replan-lead: must be >= 0"),
        ("time-unit = nan\n", "time-unit: must be finite"),
    ],
)
def test_every_range_of_the_settings_is_declared_in_the_types(
    tmp_path: Path, text: str, words: str
) -> None:
    """Tests the ranges read from the field types (``heartbeat = -1`` was
    accepted): the file is refused naming the key and the range."""
    path = tmp_path / "scheduler.toml"
    path.write_text(text)
    with pytest.raises(ConfigError) as info:
        load_config(path)
    assert words in str(info.value)


def test_a_setting_changed_in_code_keeps_its_range() -> None:
    """Tests that a value set by a flag (``replace``) or in code is held to
    the same declared range, every mistake at once."""
    with pytest.raises(ValueError, match="heartbeat: must be >= 0") as info:
        NodeConfig().replace(heartbeat=-1, rank=-1)
    assert "rank: must be >= 0" in str(info.value)


def test_predictable_replan_settings_are_read(tmp_path: Path) -> None:
    """Tests the kebab-case keys of the predictable-replan settings and
    their defaults (the paper's behaviour: no window, no move term)."""
    assert (
        NodeConfig().commit_window,
        NodeConfig().stability,
        NodeConfig().move_cost,
        NodeConfig().early_completion_gain,
        NodeConfig().late_completion,
    ) == (0, "off", 5, 0, "off")
    path = tmp_path / "scheduler.toml"
    path.write_text(
        'commit-window = 4\nstability = "lexicographic"\n'
        "move-cost = 7\nearly-completion-gain = 2\n"
        'late-completion = "push"\n'
    )
    config = load_config(path)
    assert config.commit_window == 4
    assert config.stability == "lexicographic"
    assert config.move_cost == 7
    assert config.early_completion_gain == 2
    assert config.late_completion == "push"


def test_predictable_replan_ranges_hold_in_code() -> None:
    """Tests that the ranges declared in the types also hold for settings
    built in code or changed by replace()."""
    with pytest.raises(ValueError, match="commit-window"):
        NodeConfig(commit_window=-1)
    with pytest.raises(ValueError, match="move-cost"):
        NodeConfig().replace(move_cost=0)
