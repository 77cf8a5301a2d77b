"""Shared fixtures: the paper's scenarios (factories are in factories.py)."""

from __future__ import annotations

import json
from typing import TYPE_CHECKING

import pytest

from .factories import DATA, problem_from

if TYPE_CHECKING:
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
