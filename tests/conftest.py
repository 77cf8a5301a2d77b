"""Shared fixtures: the paper's scenarios and small helpers."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from fsw_scheduler.model import Problem, decode_problem

DATA = Path(__file__).resolve().parents[1] / "fsw_scheduler" / "data"


def problem_from(doc: dict) -> Problem:
    """Decode a problem from a Python dict (validating it)."""
    return decode_problem(json.dumps(doc))


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
