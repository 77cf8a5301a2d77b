"""Shared fixtures: the paper's scenarios and small helpers."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from fsw_scheduler.model.problem import Problem, decode_problem

DATA = Path(__file__).resolve().parents[1] / "fsw_scheduler" / "data"

#: The optimal Table 1 plan (task, start, end): delay cost 359.
TABLE1_PLAN = (
    ("SetHFOption", 0, 1),
    ("SetPositionX", 0, 1),
    ("DownlinkSat2Sat", 1, 6),
    ("SetPositionK", 6, 7),
    ("BatteryCharge", 7, 17),
    ("SetPositionZ", 17, 18),
    ("AcquisitionHF", 18, 38),
    ("SetPositionY", 38, 39),
    ("DownlinkSat2Ground", 39, 49),
)


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
