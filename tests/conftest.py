"""Shared fixtures: the paper's scenarios (factories are in factories.py)."""

from __future__ import annotations

import json
import random
from typing import TYPE_CHECKING, Any, NamedTuple

import pytest

from .factories import DATA, problem_from, tool_script

if TYPE_CHECKING:
    from pathlib import Path

    from fsw_scheduler.model.problem import Problem


@pytest.fixture(scope="session")
def table1_doc() -> dict:
    """The paper's Table 1 problem as a dict (start reading of windows)."""
    return json.loads((DATA / "paper_table1.json").read_text())


@pytest.fixture(scope="session")
def table1(table1_doc: dict) -> Problem:
    """The paper's Table 1 problem, decoded."""
    return problem_from(table1_doc)


@pytest.fixture(scope="session")
def table2_goal_doc() -> dict:
    """The paper's Table 2 goal as a dict."""
    return json.loads((DATA / "paper_table2_goal.json").read_text())


class Uninterrupted(NamedTuple):
    """The scripted session of ``tools/soak_resume`` with no fault."""

    #: Its ``Outcome``: the plan and dispatch counts a session with
    #: faults must end with.
    outcome: Any
    #: The node's state folder after it. Shared: copy it before changing
    #: anything in it.
    state: Path


@pytest.fixture(scope="session")
def uninterrupted(tmp_path_factory: pytest.TempPathFactory) -> Uninterrupted:
    """The fault-free session of a real node (a separate process with
    ``--state``), run once: the reference of the resume and failover
    tests, and the journal of the integrity tests. No kill point means
    the session never draws from its random generator, so it is the same
    session whatever seed a test gives its own run."""
    work = tmp_path_factory.mktemp("uninterrupted")
    outcome = tool_script("soak_resume").run_session(
        work, set(), random.Random(0)
    )
    return Uninterrupted(outcome, work / "state")
