"""Tests of list schedules with a supply beside each consumer a capped
store cannot feed (:mod:`fsw_scheduler.analysis.paired`)."""

from __future__ import annotations

import json
from pathlib import Path

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from fsw_scheduler.analysis.check import check_plan
from fsw_scheduler.analysis.greedy import greedy_plan
from fsw_scheduler.analysis.paired import needy, paired_plan
from fsw_scheduler.analysis.sampling import sampled_plan
from fsw_scheduler.model.problem import Problem, decode_problem

from ..problems import COMMON, brute_force, decode_doc

#: The forced tasks and supplies of ``tools/fuzz --large`` seed 1519 (18
#: tasks over H = 700): t6, pinned at 344, draws 12 from a battery of at
#: most 10 and needs the 59-unit supply t36 running into it, which must
#: wait for t7 on their camera until 326. No rule and no perturbed order
#: places them; the solve answered ``unknown`` at 5 s.
CORE_1519 = Path(__file__).parent / "paired_core_l1519.json"
#: The forced tasks and supplies of ``tools/fuzz --large`` seed 1501 (19
#: tasks over [100, 400)): t34 draws 76 from a battery of at most 10 and
#: fits only late, beside the 41-unit supply t15 and an external charge
#: from 250; the solve answered ``unknown`` at 20 s.
CORE_1501 = Path(__file__).parent / "paired_core_l1501.json"


def _pinned_drain() -> Problem:
    """A consumer pinned at 10 that draws 12 from a store of at most 10,
    a long supply, and a task holding the supply's camera until 6: list
    scheduling puts the supply at 0, where it charges a full store."""
    return decode_problem(
        json.dumps(
            {
                "horizon": 30,
                "feasible_interval_applies_to": "start",
                "resources": {
                    "binary": ["camera"],
                    "consumable": {"battery": {"initial": 4, "max": 10}},
                },
                "tasks": [
                    {"id": "drain", "length": 6, "delay_cost": 1,
                     "schedule_cost": 0, "uses": {"battery": 2},
                     "feasible_interval": [10, 10]},
                    {"id": "sun", "length": 12, "delay_cost": 1,
                     "schedule_cost": 2, "uses": {"camera": 1,
                                                  "battery": -1}},
                    {"id": "shot", "length": 5, "delay_cost": 3,
                     "schedule_cost": 0, "uses": {"camera": 1},
                     "feasible_interval": [1, 1]},
                ],
            }
        )
    )  # fmt: skip


def test_a_consumer_a_capped_store_cannot_feed_gets_its_supply_beside() -> (
    None
):
    """Tests that a consumer drawing more than its store holds is placed
    with a supply overlapping it where list scheduling alone fails, and
    that the plan is the optimum exhaustive search finds."""
    problem = _pinned_drain()
    assert [(t.id, n) for t, n in needy(problem)] == [("drain", "battery")]
    assert greedy_plan(problem) is None
    plan = paired_plan(problem)
    assert plan is not None and plan.objective is not None
    assert check_plan(problem, plan).ok
    starts = plan.starts()
    assert starts["sun"] <= 10 < starts["sun"] + 12
    best = brute_force(problem)
    assert best is not None
    assert plan.objective.total == best[0].total


@pytest.mark.parametrize(
    ("path", "supply", "consumer"),
    [(CORE_1519, "t36", "t6"), (CORE_1501, "t15", "t34")],
)
def test_forced_cores_no_order_places_are_placed(
    path: Path, supply: str, consumer: str
) -> None:
    """Tests that the forced cores of ``tools/fuzz --large`` seeds 1519
    and 1501, which no rule and no perturbed order place, are placed with
    the supply running beside the consumer that needs it (their runs
    overlap; 1501's only in the latest part of its overlapping starts)."""
    core = decode_problem(path.read_text())
    assert greedy_plan(core) is None
    assert sampled_plan(core) is None
    plan = paired_plan(core)
    assert plan is not None
    assert check_plan(core, plan).ok
    assert all(not core.required(core.task(n)) for n in plan.unscheduled)
    starts = plan.starts()
    ends = {n: starts[n] + core.task(n).length for n in (supply, consumer)}
    assert max(starts[supply], starts[consumer]) < min(ends.values())


@settings(COMMON, max_examples=150)
@given(
    horizon=st.integers(8, 16),
    cap=st.integers(3, 8),
    draw=st.integers(1, 4),
    length=st.integers(2, 5),
    supplies=st.lists(
        st.tuples(st.integers(1, 8), st.integers(1, 3), st.integers(0, 4)),
        min_size=1,
        max_size=3,
    ),
    pin=st.integers(0, 10),
)
def test_a_paired_plan_is_valid_and_never_better_than_the_optimum(
    horizon: int,
    cap: int,
    draw: int,
    length: int,
    supplies: list[tuple[int, int, int]],
    pin: int,
) -> None:
    """Tests, against exhaustive search on small days with a capped store,
    a consumer that may need a supply beside it and supplies of many
    lengths, that a paired plan is valid and no better than the
    optimum, and that there is one only where the day has a plan."""
    tasks = [
        {
            "id": "c",
            "length": length,
            "delay_cost": 1,
            "schedule_cost": 0,
            "uses": {"battery": draw},
            "feasible_interval": [min(pin, horizon - length), horizon],
        }
    ] + [
        {
            "id": f"s{k}",
            "length": size,
            "delay_cost": 1,
            "schedule_cost": cost,
            "uses": {"battery": -rate, "camera": 1},
        }
        for k, (size, rate, cost) in enumerate(supplies)
    ]
    doc = {
        "horizon": horizon,
        "feasible_interval_applies_to": "task",
        "resources": {
            "binary": ["camera"],
            "consumable": {"battery": {"initial": 1, "max": cap}},
        },
        "tasks": tasks,
    }
    problem = decode_doc(doc)
    plan = paired_plan(problem)
    best = brute_force(problem)
    if plan is None:
        return
    assert best is not None, doc
    assert check_plan(problem, plan).ok, (doc, plan)
    assert plan.objective is not None
    assert plan.objective.total >= best[0].total, (doc, plan)
