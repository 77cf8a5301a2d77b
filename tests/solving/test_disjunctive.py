"""Tests of the disjunctive model and the rule that picks it."""

from __future__ import annotations

import random
from pathlib import Path
from typing import TYPE_CHECKING

import pytest
from hypothesis import given, settings

from fsw_scheduler.analysis import energetic
from fsw_scheduler.analysis.check import check_plan, format_report
from fsw_scheduler.analysis.domains import start_count, start_domains
from fsw_scheduler.errors import SolverError
from fsw_scheduler.model.plan import SolveStatus
from fsw_scheduler.model.problem import decode_problem
from fsw_scheduler.solving.ilp.disjunctive import rule
from fsw_scheduler.solving.ilp.disjunctive.model import DisjunctiveModel
from fsw_scheduler.solving.ilp.disjunctive.rule import pairwise_exact, pick
from fsw_scheduler.solving.ilp.model import solve_ilp
from fsw_scheduler.solving.solve import best_start, solve
from fsw_scheduler.solving.stats import stopped_on_nodes

from ..factories import make_doc, make_task, problem_from
from ..problems import (
    COMMON,
    apart_docs,
    brute_force,
    decode_doc,
    problem_docs,
    row_holds,
    show,
    warm_starts,
)

if TYPE_CHECKING:
    from fsw_scheduler.model.problem import Problem


def _without_consumables(doc: dict) -> dict:
    """``doc`` with its consumables and their uses taken out."""
    doc["resources"]["consumable"] = {}
    for task in doc["tasks"]:
        uses = {
            name: amount
            for name, amount in task.get("uses", {}).items()
            if not name.startswith("c")
        }
        task["uses"] = uses
    return doc


@settings(COMMON, max_examples=60)
@given(doc=problem_docs(max_tasks=5, max_horizon=12))
def test_agrees_with_time_indexed_model(doc: dict) -> None:
    """Tests that both formulations find the same status and optimum, and
    that the disjunctive plan passes the checker."""
    problem = decode_doc(_without_consumables(doc))
    indexed = solve_ilp(problem, formulation="time-indexed")
    disjunctive = solve_ilp(problem, formulation="disjunctive")
    assert disjunctive.status is indexed.status, show(
        doc, indexed, disjunctive
    )
    if indexed.objective is not None:
        assert disjunctive.objective == indexed.objective, show(
            doc, indexed, disjunctive
        )
        report = check_plan(problem, disjunctive)
        assert report.ok, f"{format_report(report)}\n{show(doc, disjunctive)}"


@settings(COMMON, max_examples=40)
@given(doc=problem_docs(max_tasks=4, max_horizon=8))
def test_matches_brute_force(doc: dict) -> None:
    """Tests that the disjunctive optimum is the exhaustive search's."""
    problem = decode_doc(_without_consumables(doc))
    plan = solve_ilp(problem, formulation="disjunctive")
    best = brute_force(problem)
    if best is None:
        assert plan.status is SolveStatus.INFEASIBLE, show(doc, plan)
    else:
        assert plan.objective == best[0], show(doc, plan)


@settings(COMMON, max_examples=40)
@given(doc=problem_docs(max_tasks=5, max_horizon=12))
def test_a_plan_has_the_same_objective_in_both_models(doc: dict) -> None:
    """Tests that the disjunctive program's objective at a plan's columns
    is the plan's objective total."""
    problem = decode_doc(_without_consumables(doc))
    plan = solve_ilp(problem, formulation="time-indexed")
    if plan.objective is None:
        return
    built = DisjunctiveModel(problem, start_domains(problem))
    values = built.vars.initial(plan.starts(), built.num_variables)
    assert built.program.value(values) == plan.objective.total
    assert _broken_rows(built, values) == [], show(doc, plan)


def _broken_rows(
    built: DisjunctiveModel, values: list[float]
) -> list[tuple[dict[int, float], str, float]]:
    """The rows of ``built`` that ``values`` break."""
    return [row for row in built.program.rows if not row_holds(*row, values)]


def _warm_starts_keep_every_row(doc: dict) -> None:
    """Assert that the columns :meth:`Variables.initial` gives for each
    plan the exhaustive search accepts (up to 40) keep every row, its
    identical tasks' starts in problem order as the solver hands them
    over (:func:`in_symmetry_order`)."""
    problem = decode_doc(_without_consumables(doc))
    built = DisjunctiveModel(problem, start_domains(problem))
    for placed in warm_starts(problem, built.constraints.twins):
        values = built.vars.initial(placed, built.num_variables)
        assert _broken_rows(built, values) == [], (show(doc), placed)


@settings(COMMON, max_examples=60)
@given(doc=problem_docs(max_tasks=5, max_horizon=8))
def test_every_plan_as_a_warm_start_keeps_every_row(doc: dict) -> None:
    """Tests that any valid plan, as a warm start, keeps every row of the
    model: CBC drops a warm start that breaks one, and then searches
    without it."""
    _warm_starts_keep_every_row(doc)


@settings(COMMON, max_examples=150)
@given(doc=apart_docs(max_tasks=5))
def test_every_plan_as_a_warm_start_keeps_the_load_rows(doc: dict) -> None:
    """Tests the same on tasks crowding a power resource whose users fit
    two by two but not always three together: the load at each start
    and its columns ("runs when the other starts", which
    :func:`problem_docs` never makes the model build)."""
    _warm_starts_keep_every_row(doc)


def test_a_start_with_users_running_together_keeps_every_row() -> None:
    """Tests that a warm start in which two users of a multiple resource
    run together (they fit; all three would not) gives every column a
    value that keeps every row, the columns saying "runs when the other
    starts" included: a start that breaks a row is dropped by CBC
    whole."""
    # A second resource the same way: each pair has its columns on both.
    doc = _three_on_power(100)
    doc["resources"]["multiple"]["heat"] = 9
    for task in doc["tasks"]:
        task["uses"]["heat"] = 4
    problem = problem_from(doc)
    built = DisjunctiveModel(problem, start_domains(problem))
    on = {(first, second) for first, second, _, _ in built.vars.runs_at}
    assert len(built.vars.runs_at) == 2 * len(on) == 12
    # Identical tasks start in problem order (the symmetry rows).
    for starts in ({"a": 0, "b": 0, "c": 2}, {"a": 0, "b": 1, "c": 2}):
        values = built.vars.initial(starts, built.num_variables)
        assert _broken_rows(built, values) == [], starts


def _three_on_power(capacity: float) -> dict:
    """Three mandatory 2-unit tasks drawing 50 of ``capacity`` each."""
    tasks = [
        make_task(name, schedule_cost=0, uses={"power": 50})
        for name in ("a", "b", "c")
    ]
    return make_doc(
        tasks, horizon=6, resources={"multiple": {"power": capacity}}
    )


def test_three_users_over_a_capacity_only_together_are_staggered() -> None:
    """Tests that three users that fit two by two but not all together
    never run all at once, at the optimal delay."""
    problem = problem_from(_three_on_power(100))
    plan = solve_ilp(problem, formulation="disjunctive")
    assert plan.status is SolveStatus.OPTIMAL
    assert check_plan(problem, plan).ok
    assert plan.objective is not None and plan.objective.delay_cost == 2
    assert "disjunctive" in (plan.stats.solver_status if plan.stats else "")


def test_pairwise_exact_sees_sets_beyond_pairs() -> None:
    """Tests that pairwise_exact is False only when some users fit two by
    two but not together."""
    assert pairwise_exact([50, 50, 50], 120) is False
    assert pairwise_exact([70, 70, 70], 120) is True  # every pair is over
    assert pairwise_exact([30, 30, 30], 120) is True
    assert pairwise_exact([10, 60, 60], 120) is False
    assert pairwise_exact([130, 50, 50], 120) is True  # 130 never fits


@pytest.mark.parametrize(
    ("resources", "uses", "expected"),
    [
        ({"binary": ["cam"]}, {"cam": 1}, "disjunctive"),
        ({"multiple": {"power": 3}}, {"power": 2}, "disjunctive"),
        ({"multiple": {"power": 6}}, {"power": 2}, "disjunctive"),
        ({"multiple": {"power": 5}}, {"power": 2}, "time-indexed"),
        (
            {"binary": ["cam"], "consumable": {"bat": 4}},
            {"cam": 1, "bat": 1},
            "time-indexed",
        ),
        ({"binary": ["cam"]}, {}, "disjunctive"),
        ({"consumable": {"bat": 4}}, {"bat": 1}, "time-indexed"),
    ],
)
def test_rule_picks_disjunctive_without_consumables(
    resources: dict, uses: dict, expected: str
) -> None:
    """Tests that the rule picks the disjunctive model for binary and
    pairwise multiple resources without consumables and for parts that
    use no resource (precedences only), time-indexed otherwise."""
    tasks = [make_task(name, uses=uses) for name in ("a", "b", "c")]
    problem = problem_from(make_doc(tasks, resources=resources))
    assert pick(problem, start_domains(problem)) == expected


def test_solve_picks_the_model_per_part() -> None:
    """Tests that solve builds the disjunctive model for a part sharing a
    camera and the time-indexed one for a part drawing on a battery."""
    tasks = [
        make_task("a", uses={"cam": 1}),
        make_task("b", uses={"cam": 1}),
        make_task("c", uses={"bat": 3}),
        make_task("d", uses={"bat": 3}, delay_cost=2),
    ]
    resources = {"binary": ["cam"], "consumable": {"bat": 8}}
    problem = problem_from(make_doc(tasks, resources=resources))
    plan = solve(problem)
    assert plan.status is SolveStatus.OPTIMAL
    assert check_plan(problem, plan).ok
    status = plan.stats.solver_status if plan.stats else ""
    assert "2 independent parts" in status
    # Smallest part first, the status ends with the largest one's.
    whole = solve_ilp(problem.replace(tasks=problem.tasks[:2]))
    assert whole.stats is not None
    assert "disjunctive model" in (whole.stats.solver_status or "")
    battery = solve_ilp(problem.replace(tasks=problem.tasks[2:]))
    assert battery.stats is not None
    assert "disjunctive" not in (battery.stats.solver_status or "")


def test_forced_on_consumables_is_refused() -> None:
    """Tests that the disjunctive model refuses a problem with consumables
    in use rather than ignore them."""
    tasks = [make_task("a", uses={"bat": 1})]
    problem = problem_from(
        make_doc(tasks, resources={"consumable": {"bat": 4}})
    )
    with pytest.raises(SolverError, match="consumables"):
        solve_ilp(problem, formulation="disjunctive")


def _crowded_power(seed: int) -> Problem:
    """Five tasks on a power bus of 10 whose uses (3-7) let two or three
    run at once: a disjunctive model that branches."""
    rnd = random.Random(seed)
    tasks = [
        make_task(
            f"t{idx}",
            length=rnd.randint(2, 4),
            delay_cost=rnd.randint(1, 5),
            uses={"power": rnd.randint(3, 7)},
        )
        for idx in range(5)
    ]
    return problem_from(
        make_doc(tasks, horizon=12, resources={"multiple": {"power": 10}})
    )


@pytest.mark.parametrize("seed", [0, 3])
def test_an_unproved_disjunctive_run_hands_over_to_the_time_indexed_model(
    seed: int, monkeypatch: pytest.MonkeyPatch
) -> None:
    """Tests that a disjunctive run on a multiple resource that is still
    unproved after the switch's node count goes on in the time-indexed
    model from its plan, and proves the optimum; its status line says so
    without reading as a run stopped on its nodes."""
    monkeypatch.setattr(rule, "SWITCH_NODES_MULTIPLE_ONLY", 1)
    problem = _crowded_power(seed)
    domains = start_domains(problem)
    assert pick(problem, domains) == "disjunctive"
    assert rule.switch_nodes(problem, domains, 15) == 1
    start = best_start(problem, None)
    assert start is not None
    plan = solve_ilp(problem, warm=start.starts())
    said = plan.stats.solver_status if plan.stats else ""
    assert "disjunctive model unproved after 1 nodes" in said
    assert "time-indexed model from its plan: Optimal" in said
    assert not stopped_on_nodes(said)
    assert plan.status is SolveStatus.OPTIMAL
    best = brute_force(problem)
    assert best is not None and plan.objective is not None
    assert plan.objective.total == best[0].total
    assert plan.stats is not None and plan.stats.bound == best[0].total
    assert check_plan(problem, plan).ok
    # A caller's own node limit at or under the switch's is kept: a probe
    # stays a probe of the disjunctive model.
    probe = solve_ilp(problem, warm=start.starts(), max_nodes=1)
    probe_said = probe.stats.solver_status if probe.stats else ""
    assert "time-indexed" not in probe_said
    assert "disjunctive model" in probe_said


def test_only_small_parts_with_a_multiple_resource_switch(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """Tests that binary-only parts and parts over the size measured keep
    their disjunctive run to the end, unless their time-indexed model is
    small (few start times: a short horizon); that a part whose only
    shared resources are multiple ones switches early, and one with a
    binary resource in use as well after the later count, and when it is
    over the measured size only under the smaller column count."""
    crowded = _crowded_power(0)
    domains = start_domains(crowded)
    starts = start_count(domains)
    early = rule.SWITCH_NODES_MULTIPLE_ONLY
    assert early < rule.SWITCH_NODES
    assert starts <= rule.SWITCH_COLUMNS
    assert rule.switch_nodes(crowded, domains, 15) == early
    # More tasks than measured, but as few start times as a small part's.
    assert rule.switch_nodes(crowded, domains, 4) == early
    monkeypatch.setattr(rule, "SWITCH_COLUMNS", starts - 1)
    assert rule.switch_nodes(crowded, domains, 4) is None
    assert rule.switch_nodes(crowded, domains, 15) == early
    tasks = [make_task(f"t{idx}", uses={"cam": 1}) for idx in range(4)]
    binary = problem_from(make_doc(tasks, resources={"binary": ["cam"]}))
    assert rule.switch_nodes(binary, start_domains(binary), 15) is None
    both = [
        make_task(f"t{idx}", uses={"cam": 1, "power": 6}) for idx in range(4)
    ]
    mixed = problem_from(
        make_doc(
            both, resources={"binary": ["cam"], "multiple": {"power": 10}}
        )
    )
    mixed_domains = start_domains(mixed)
    assert rule.switch_nodes(mixed, mixed_domains, 15) == rule.SWITCH_NODES
    # A part over the measured size with a camera switches only while its
    # time-indexed model is smaller still.
    assert rule.switch_nodes(mixed, mixed_domains, 2) == rule.SWITCH_NODES
    monkeypatch.setattr(
        rule, "SWITCH_COLUMNS_BINARY", start_count(mixed_domains) - 1
    )
    assert rule.switch_nodes(mixed, mixed_domains, 2) is None
    assert rule.switch_nodes(mixed, mixed_domains, 15) == rule.SWITCH_NODES


#: 19 tasks over H = 60: a 16-task part sharing a camera and a multiple
#: resource of capacity 3 at 166 of its 180 units of energy (CP-SAT's
#: optimum of the whole: 4,327).
SHORT_HORIZON = Path(__file__).parent / "data" / "short-horizon-crowded.json"


def test_a_larger_part_with_few_start_times_switches_and_is_proved(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """Tests that a part of more tasks than the switch's measured sizes,
    over a short horizon, switches to the time-indexed model after the
    switch's nodes and is proved: its disjunctive run alone went to the
    end of a 30 s limit unproved. (Without the energy rows: with them
    the kept-set bound narrows it so that the disjunctive model proves
    it at once, see the next test.)"""
    monkeypatch.setattr(energetic, "MAX_ROWS", 0)
    problem = decode_problem(SHORT_HORIZON.read_bytes())
    plan = solve(problem, time_limit=30)
    assert plan.stats is not None
    said = plan.stats.solver_status
    assert plan.status is SolveStatus.OPTIMAL, said
    assert "the time-indexed model from its plan: Optimal" in said
    assert plan.objective is not None and plan.objective.total == 4327
    assert check_plan(problem, plan).ok


def test_energy_rows_prove_the_crowded_short_horizon_unswitched() -> None:
    """Tests that the same part, with the kept-set relaxation's energy
    rows (a power resource asked for more than the horizon holds), is
    proved by the disjunctive model before the switch's nodes (4.0 s
    with the switch, 0.8 s without it when measured)."""
    problem = decode_problem(SHORT_HORIZON.read_bytes())
    plan = solve(problem, time_limit=30)
    assert plan.stats is not None
    said = plan.stats.solver_status
    assert plan.status is SolveStatus.OPTIMAL, said
    assert "time-indexed model from its plan" not in said
    assert plan.objective is not None and plan.objective.total == 4327


def test_a_switch_with_no_time_for_the_second_model_keeps_the_first_plan(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """Tests that when the time-indexed model cannot run in what is left
    (here: its build estimate exceeds the limit), the answer is the
    disjunctive run's plan, ``feasible``, with that run's bound, and the
    status line names both."""
    from fsw_scheduler.solving.ilp import model

    monkeypatch.setattr(rule, "SWITCH_NODES_MULTIPLE_ONLY", 1)
    monkeypatch.setattr(model, "BUILD_S_PER_COLUMN", 1e6)
    problem = _crowded_power(0)
    start = best_start(problem, None)
    assert start is not None
    plan = solve_ilp(problem, warm=start.starts(), time_limit=30)
    said = plan.stats.solver_status if plan.stats else ""
    assert plan.status is SolveStatus.FEASIBLE
    assert "disjunctive model unproved after 1 nodes" in said
    assert "time limit too short to build a model" in said
    assert plan.objective is not None and plan.stats is not None
    assert plan.stats.bound is not None
    assert plan.stats.bound <= plan.objective.total
    assert check_plan(problem, plan).ok
