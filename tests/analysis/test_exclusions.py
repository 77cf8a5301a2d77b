"""Tests of the pairs of tasks no plan holds together (analysis/exclusions)."""

from __future__ import annotations

import copy
from pathlib import Path

from hypothesis import event, find, given, settings
from hypothesis import strategies as st

from fsw_scheduler.analysis.exclusions import exclusive_pairs
from fsw_scheduler.analysis.keptset import KeptSetSearch
from fsw_scheduler.model.plan import SolveStatus
from fsw_scheduler.model.problem import decode_problem
from fsw_scheduler.solving.solve import solve
from tests.factories import make_doc, make_task, problem_from
from tests.problems import brute_force

#: broad seed 130's b15-multiple-4 (tools/bench): 15 tasks over H = 336
#: on a power resource of 120, T000 held by tight precedences beside
#: T004, T007 and T014, T008 ten units after T007 ends. CP-SAT's optimum:
#: 48,867, T008 left out.
TIGHT_CHAIN = (
    Path(__file__).parents[1] / "solving" / "data" / "tight-chain.json"
)


def _chain(offset: int = 10) -> dict:
    """The heart of :data:`TIGHT_CHAIN`: T000 starts when T007 ends and
    one unit after T004 starts; T008 starts ``offset`` units after T007
    ends. With the default both are on the power at T000's eleventh unit:
    61 + 49 + 26 = 136 over 120."""
    tasks = [
        make_task("T000", 11, uses={"power": 61}),
        make_task("T004", 20, uses={"power": 49}),
        make_task("T007", 10),
        make_task("T008", 17, uses={"power": 26}),
    ]
    precedences = [
        {"before": "T007", "after": "T008", "kind": "tight",
         "scope": "at_least_first", "offset": offset},
        {"before": "T007", "after": "T000", "kind": "tight",
         "scope": "at_least_first", "offset": 0},
        {"before": "T004", "after": "T000", "kind": "tight",
         "scope": "at_least_first", "offset": -19},
    ]  # fmt: skip
    return make_doc(
        tasks,
        horizon=80,
        resources={"multiple": {"power": 120}},
        precedences=precedences,
    )


def test_two_tasks_whose_tight_blocks_overlap_over_a_capacity_are_apart() -> (
    None
):
    """Tests that the pair is found, and only it: T004 and T007 are what
    T000 needs (it cannot be held without them), and T008 alone fits."""
    assert exclusive_pairs(problem_from(_chain())) == (("T000", "T008"),)


def test_a_chain_that_fits_gives_no_pair() -> None:
    """Tests that T008 placed after T004 ends (30 units after T007 ends)
    makes no pair: the uses at fixed offsets stay within the power."""
    assert exclusive_pairs(problem_from(_chain(offset=30))) == ()


def test_the_kept_set_search_never_keeps_an_exclusive_pair() -> None:
    """Tests that the relaxation's cheapest kept set leaves one of the
    pair out though its rows (earliest starts, energy) would hold all."""
    problem = problem_from(_chain())
    from fsw_scheduler.analysis.domains import start_domains

    search = KeptSetSearch(problem, start_domains(problem), cutoff=10**12)
    assert search.run(10_000)
    assert search.best is not None
    assert not {"T000", "T008"} <= search.best
    assert {"T004", "T007"} <= search.best


@st.composite
def _chains(draw: st.DrawFn) -> dict:
    """Four tasks on a camera and a power resource, no windows: t1-t3
    each held by a tight precedence after an earlier task (mostly t0),
    and one more precedence of any kind: tight blocks that may put two
    users side by side, as in :func:`_chain`."""
    tasks = []
    for idx in range(4):
        uses: dict[str, float] = {}
        if idx and draw(st.booleans()):
            uses["cam"] = 1
        if idx and draw(st.booleans()):
            uses["power"] = draw(st.sampled_from([3, 4, 6, 7]))
        tasks.append(
            make_task(
                f"t{idx}",
                draw(st.integers(1, 3)),
                schedule_cost=draw(st.integers(1, 5)),
                uses=uses,
            )
        )
    precedences = [
        {
            "before": f"t{draw(st.sampled_from([0, 0, idx - 1]))}",
            "after": f"t{idx}",
            "kind": "tight",
            "scope": "at_least_first",
            "offset": draw(st.integers(-3, 2)),
        }
        for idx in range(1, 4)
    ]
    if draw(st.booleans()):
        before, after = draw(
            st.lists(st.integers(0, 3), min_size=2, max_size=2, unique=True)
        )
        precedences.append(
            {
                "before": f"t{before}",
                "after": f"t{after}",
                "kind": draw(st.sampled_from(["tight", "lax"])),
                "scope": draw(st.sampled_from(["both", "at_least_first"])),
                "offset": draw(st.integers(-3, 2)),
            }
        )
    return make_doc(
        tasks,
        horizon=draw(st.integers(5, 8)),
        resources={"binary": ["cam"], "multiple": {"power": 10}},
        precedences=precedences,
    )


@settings(max_examples=300, deadline=None)
@given(_chains())
def test_no_plan_holds_an_exclusive_pair(doc: dict) -> None:
    """Tests, by enumerating every plan, that a pair found exclusive can
    never be scheduled together: with both made mandatory (schedule cost
    0) no plan exists."""
    try:
        problem = problem_from(doc)
    except Exception:  # tight cycles the format rejects
        event("rejected by validation")
        return
    pairs = exclusive_pairs(problem)
    event(f"pairs found: {bool(pairs)}")
    for first, second in pairs:
        forced = copy.deepcopy(doc)
        for task in forced["tasks"]:
            if task["id"] in (first, second):
                task["schedule_cost"] = 0
        assert brute_force(problem_from(forced)) is None, (first, second)


def test_the_drawn_chains_do_find_pairs() -> None:
    """Tests that the generator of the property above is not vacuous: it
    draws days with a pair."""

    def has_pair(doc: dict) -> bool:
        try:
            return bool(exclusive_pairs(problem_from(doc)))
        except Exception:  # tight cycles the format rejects
            return False

    assert has_pair(
        find(_chains(), has_pair, settings=settings(database=None))
    )


def test_the_tight_chain_day_is_proved() -> None:
    """Tests that the 15-task day the pair comes from is proved at
    CP-SAT's optimum: before the pair's rows CBC searched its whole 10 s
    at a bound of 1,524 under the optimal plan (45,843 for the part)."""
    problem = decode_problem(TIGHT_CHAIN.read_bytes())
    plan = solve(problem, time_limit=30)
    assert plan.status is SolveStatus.OPTIMAL, plan.stats
    assert plan.objective is not None and plan.objective.total == 48867
    assert "T008" in plan.unscheduled


def test_a_star_of_tight_successors_is_held_to_the_cap() -> None:
    """Tests that a root with 300 tight successors on one camera (44,850
    pairs, no two successors fit together) gives at most
    :data:`~fsw_scheduler.analysis.exclusions.MAX_PAIRS` pairs, each of
    two successors, the first ones in task order."""
    from fsw_scheduler.analysis import exclusions

    tasks = [make_task("r", 1)] + [
        make_task(f"b{k:03d}", 3, uses={"cam": 1}) for k in range(300)
    ]
    precedences = [
        {
            "before": "r",
            "after": f"b{k:03d}",
            "kind": "tight",
            "scope": "at_least_first",
            "offset": k % 3,
        }
        for k in range(300)
    ]
    problem = problem_from(
        make_doc(
            tasks,
            horizon=2000,
            resources={"binary": ["cam"]},
            precedences=precedences,
        )
    )
    pairs = exclusive_pairs(problem)
    assert len(pairs) == exclusions.MAX_PAIRS
    assert pairs[0] == ("b000", "b001")
    assert all(a.startswith("b") and b.startswith("b") for a, b in pairs)
