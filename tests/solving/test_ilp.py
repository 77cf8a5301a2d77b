"""Tests of the ILP's program, its MPS text and the cost-based domains."""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

import pytest
from hypothesis import given, settings

from fsw_scheduler.analysis.check import check_plan
from fsw_scheduler.analysis.domains import cost_caps, start_domains
from fsw_scheduler.model.plan import Objective, Plan, SolveStatus
from fsw_scheduler.solving.ilp.cbc import CbcRun
from fsw_scheduler.solving.ilp.model import (
    BuiltModel,
    in_symmetry_order,
    solve_ilp,
)
from fsw_scheduler.solving.ilp.program import EQ, GE, LE, Program
from fsw_scheduler.solving.solve import best_start, solve

from ..factories import bench_lib, make_doc, make_task, problem_from
from ..problems import (
    COMMON,
    brute_force,
    decode_doc,
    problem_docs,
    row_holds,
    show,
    warm_starts,
)

if TYPE_CHECKING:
    from pathlib import Path

    from bench_lib.generator import BenchProblem

    from fsw_scheduler.model.problem import Problem

generator = bench_lib("generator")


def _small_program() -> Program:
    """min -x - 2y + 0.5z + 3  s.t.  x + y <= 1.5, y - z = 0, x + z >= 0.

    x, y integer in [0, 1]; z continuous in [0, 0.75]; w (in no row)
    fixed at 2.
    """
    program = Program()
    x = program.add_column(0, 1, integer=True)
    y = program.add_column(0, 1, integer=True)
    z = program.add_column(0, 0.75)
    w = program.add_column(2, 2, integer=True)
    program.add_row({x: 1, y: 1}, LE, 1.5)
    program.add_row({y: 1.0, z: -1.0}, EQ, 0)
    program.add_row({x: 1, z: 1, w: 0}, GE, 0)
    program.set_objective({x: -1, y: -2, z: 0.5}, constant=3)
    assert w == 3
    return program


def test_program_drops_zero_coefficients_and_constant_rows() -> None:
    """Tests that zero terms vanish and an all-zero row is not added."""
    program = _small_program()
    assert program.rows[2][0] == {0: 1, 2: 1}
    assert not program.add_row({0: 0.0}, LE, 1)
    assert program.num_rows == 3


def test_program_mps_solves_in_cbc() -> None:
    """Tests that CBC reads the MPS text and finds the known optimum."""
    program = _small_program()
    result = CbcRun().solve(program)
    assert result.status is SolveStatus.OPTIMAL
    assert result.values is not None
    # y = 1 forces z = 1 > 0.75, so y = 0, z = 0 and x = 1.
    assert result.values == [1.0, 0.0, 0.0, 2.0]
    assert program.value(result.values) == pytest.approx(2.0)


def test_program_to_pulp_has_the_same_optimum() -> None:
    """Tests that the PuLP copy of a program solves to the same point."""
    import pulp

    program = _small_program()
    lp, columns = program.to_pulp()
    lp.solve(pulp.COIN_CMD(path=CbcRun().path, msg=False))
    # PuLP drops the column that is in no row (w): it keeps no value.
    assert [c.varValue for c in columns[:3]] == [1.0, 0.0, 0.0]
    assert pulp.value(lp.objective) == pytest.approx(2.0)


def test_highs_reads_a_column_in_no_row_at_its_bound() -> None:
    """Tests that HiGHS plans decode a column PuLP dropped (no crash)."""
    # One start only, at the origin, and no schedule cost: the column of
    # "a scheduled" has a zero objective coefficient and no row.
    problem = problem_from(_doc([make_task("a", schedule_cost=0)], horizon=2))
    plan = solve_ilp(problem, solver="highs")
    assert plan.status is SolveStatus.OPTIMAL
    assert plan.objective == Objective(0, 0, 0)


def test_mps_text_is_fixed_format_and_stable() -> None:
    """Tests the MPS layout: markers, 8-character fields, bounds."""
    text = _small_program().mps()
    assert text == _small_program().mps()
    lines = text.splitlines()
    assert lines[:3] == ["NAME          MODEL", "ROWS", " N  OBJ"]
    assert "    MARK      'MARKER'                 'INTORG'" in lines
    assert "    X0000000  OBJ       -1" in lines
    assert "    X0000002  C0000001  -1" in lines
    assert " FX BND       X0000003  2" in lines
    assert " UP BND       X0000002  0.75" in lines
    assert "    RHS       C0000000  1.5" in lines
    assert lines[-1] == "ENDATA"


def _doc(tasks: list[dict], horizon: int = 20) -> dict:
    return make_doc(tasks, horizon, resources={})


def test_cost_caps_bound_starts_by_the_spare_delay() -> None:
    """Tests the caps on a plan with 4 units of delay to spare."""
    problem = problem_from(
        _doc(
            [
                make_task("a", feasible_interval=[3, 20]),
                make_task("b", delay_cost=2),
                make_task("opt", schedule_cost=0, delay_cost=4),
            ]
        )
    )
    domains = start_domains(problem)
    # a at 3 (its earliest), b at 2, opt left out: delay 3 + 2 * 2 = 7,
    # of which 3 is unavoidable (a's window): 4 to spare.
    plan = Plan(
        status=SolveStatus.FEASIBLE,
        objective=Objective(0, 7, 7),
        activities=(),
    )
    caps = cost_caps(problem, domains, plan)
    assert caps == {"a": 3 + 4, "b": 0 + 2, "opt": 0 + 1}
    left_out = plan.replace(objective=Objective(1, 7, 99))
    assert cost_caps(problem, domains, left_out) is None


def test_capped_domains_propagate_through_precedences() -> None:
    """Tests that a cap on a tight predecessor also caps its successor."""
    doc = _doc([make_task("a"), make_task("b")])
    doc["precedences"] = [
        {"before": "a", "after": "b", "kind": "tight", "offset": 1}
    ]
    problem = problem_from(doc)
    domains = start_domains(problem, {"a": 4})
    assert (domains["a"].earliest, domains["a"].latest) == (0, 4)
    assert (domains["b"].earliest, domains["b"].latest) == (3, 7)


@pytest.mark.parametrize(
    "problem", generator.suite("campaign")[:28], ids=lambda p: p.name
)
def test_cost_capped_model_keeps_the_optimum(problem: BenchProblem) -> None:
    """Tests that solve() (with caps) and the full model agree.

    Every 5-task problem of the campaign is solved both ways; where the
    start plan leaves nothing out, the capped model is smaller.
    """
    prob = problem.problem()
    capped = solve(prob)
    full = solve_ilp(prob)
    assert capped.status is SolveStatus.OPTIMAL
    assert full.status is SolveStatus.OPTIMAL
    assert capped.objective == full.objective
    assert check_plan(prob, capped).ok
    start = best_start(prob, None)
    if (
        start is not None
        and start.objective is not None
        and not start.objective.unscheduled_cost
        and capped.stats is not None
        and capped.stats.solver == "cbc"
    ):
        assert capped.stats.num_variables is not None
        assert full.stats is not None
        assert full.stats.num_variables is not None
        assert capped.stats.num_variables <= full.stats.num_variables


def _twins_doc() -> dict:
    """Five identical downlinks on one antenna, and one other task."""
    tasks = [
        make_task(f"dl{k}", length=3, delay_cost=2, uses={"antenna": 1})
        for k in range(5)
    ]
    tasks.append(make_task("other", length=3, uses={"antenna": 1}))
    return {
        "horizon": 18,
        "resources": {"binary": ["antenna"]},
        "tasks": tasks,
    }


def test_identical_tasks_are_found() -> None:
    """Tests that only tasks alike in everything form a class."""
    from fsw_scheduler.solving.ilp.constraints import identical_tasks

    problem = problem_from(_twins_doc())
    classes = identical_tasks(problem, start_domains(problem))
    assert classes == [[f"dl{k}" for k in range(5)]]


@pytest.mark.parametrize("solver", ["cbc", "highs"])
def test_identical_tasks_start_in_problem_order(solver: str) -> None:
    """Tests the symmetry rows: same optimum, twins in problem order."""
    problem = problem_from(_twins_doc())
    plan = solve_ilp(problem, solver=solver)
    assert plan.status is SolveStatus.OPTIMAL
    assert check_plan(problem, plan).ok
    # 18 units hold all six back to back, the cheaper-delay task last.
    assert plan.objective == Objective(0, 2 * (0 + 3 + 6 + 9 + 12) + 15, 75)
    starts = plan.starts()
    assert [starts[f"dl{k}"] for k in range(5)] == [0, 3, 6, 9, 12]


def test_warm_start_is_put_in_symmetry_order() -> None:
    """Tests that a start breaking the order is permuted, not refused."""
    from fsw_scheduler.solving.ilp.constraints import identical_tasks

    problem = problem_from(_twins_doc())
    twins = identical_tasks(problem, start_domains(problem))
    starts = {"dl4": 0, "dl2": 3, "other": 6, "dl0": 9}
    assert in_symmetry_order(twins, starts) == {
        "other": 6,
        "dl0": 0,
        "dl1": 3,
        "dl2": 9,
    }
    plan = solve_ilp(problem, warm=starts)
    assert plan.status is SolveStatus.OPTIMAL
    assert plan.objective is not None and plan.objective.total == 75


def test_symmetry_rows_keep_the_brute_force_optimum() -> None:
    """Tests twins against every plan the checker accepts."""
    doc = {
        "horizon": 7,
        "resources": {"binary": ["antenna"], "consumable": {"battery": 5}},
        "tasks": [
            *(
                make_task(f"dl{k}", uses={"antenna": 1, "battery": 1})
                for k in range(3)
            ),
            make_task("other", length=1, schedule_cost=5, uses={"antenna": 1}),
        ],
    }
    problem = problem_from(doc)
    plan = solve_ilp(problem)
    assert plan.objective is not None
    assert plan.objective.total == _optimum(problem)


def _optimum(problem: Problem) -> float:
    """The optimal total of ``problem`` by exhaustive enumeration."""
    best = brute_force(problem)
    assert best is not None
    return best[0].total


def _plan(status: SolveStatus, total: int | None) -> Plan:
    objective = None if total is None else Objective(0, total, total)
    return Plan(status=status, objective=objective, activities=())


@pytest.mark.parametrize(
    ("claim", "total", "kept"),
    [
        (SolveStatus.OPTIMAL, 10, "solver"),
        (SolveStatus.OPTIMAL, 12, "start"),  # an "optimum" worse than start
        (SolveStatus.INFEASIBLE, None, "start"),  # but the start is valid
        (SolveStatus.FEASIBLE, 11, "solver"),
        (SolveStatus.UNKNOWN, None, "start"),
    ],
)
def test_solver_claims_contradicting_the_start_are_not_trusted(
    claim: SolveStatus, total: int | None, kept: str
) -> None:
    """Tests that the start plan wins over an impossible solver claim."""
    from fsw_scheduler.model.plan import SolverStats
    from fsw_scheduler.solving.solve import _keep_better

    start = _plan(SolveStatus.FEASIBLE, 11)
    solver = _plan(claim, total).replace(stats=SolverStats(solver="cbc"))
    result = _keep_better(solver, start)
    if kept == "solver":
        assert result is solver
    else:
        assert result.objective == start.objective
        assert result.status is SolveStatus.FEASIBLE
        assert result.stats is not None and result.stats.solver == "cbc"


def test_fractional_cbc_values_are_refused() -> None:
    """Tests that relaxation values called optimal are never decoded."""
    from fsw_scheduler.solving.ilp.cbc import CbcResult
    from fsw_scheduler.solving.ilp.model import _integral

    program = _small_program()
    whole = CbcResult(SolveStatus.OPTIMAL, [1.0, 0.0, 0.3, 2.0])
    assert _integral(program, whole)  # column 2 is continuous
    relaxed = CbcResult(SolveStatus.OPTIMAL, [0.5, 0.0, 0.0, 2.0])
    assert not _integral(program, relaxed)


def test_consumable_models_branch_on_scheduled_first(tmp_path: Path) -> None:
    """Tests that a consumable budget gives "scheduled" a priority file."""
    from fsw_scheduler.solving.ilp.cbc import _write_priorities
    from fsw_scheduler.solving.ilp.model import BuiltModel

    doc: dict[str, Any] = {
        "horizon": 10,
        "resources": {"consumable": {"fuel": 6}},
        "tasks": [
            make_task(name, length=1, uses={"fuel": 4}) for name in ("a", "b")
        ],
    }
    built = BuiltModel(problem_from(doc))
    scheduled = {built.vars.scheduled(n) for n in ("a", "b")}
    assert built.program.priorities == dict.fromkeys(scheduled, 1)
    path = tmp_path / "prio.csv"
    _write_priorities(str(path), built.program)
    lines = path.read_text().splitlines()
    assert lines[0] == "name,priority"
    assert len(lines) == 3
    plan = solve_ilp(problem_from(doc))
    assert plan.status is SolveStatus.OPTIMAL
    assert len(plan.unscheduled) == 1
    # No budget to choose within: no priorities.
    doc["resources"]["consumable"]["fuel"] = 8
    assert BuiltModel(problem_from(doc)).program.priorities == {}


def test_one_column_rows_implied_by_bounds_are_dropped() -> None:
    """Tests that rows the bounds already satisfy are not written."""
    program = Program()
    z = program.add_column(0, 1, integer=True)
    level = program.add_column(0)  # no upper bound
    assert not program.add_row({z: -1.0}, LE, 0)  # -z <= 0
    assert not program.add_row({z: 1.0}, LE, 1)
    assert not program.add_row({level: 1.0}, GE, 0)
    assert not program.add_row({level: -2.0}, LE, 0)
    assert program.num_rows == 0
    assert program.add_row({z: 1.0}, LE, 0)  # fixes z at 0: kept
    assert program.add_row({level: 1.0}, LE, 5)
    assert program.add_row({z: 1.0}, EQ, 1)
    assert program.num_rows == 3


def test_no_solver_is_started_without_time_left() -> None:
    """Tests that a spent limit gives the start plan, not a late solve."""
    problem = problem_from(_twins_doc())
    plan = solve_ilp(problem, time_limit=0.0)
    assert plan.status is SolveStatus.UNKNOWN
    assert plan.stats is not None
    assert any(
        words in plan.stats.solver_status
        for words in ("before the solver started", "too short to build")
    )
    assert CbcRun(time_limit=0.01).solve(_small_program()).values is None
    kept = solve(problem, time_limit=1e-9)
    assert kept.status is SolveStatus.FEASIBLE
    assert check_plan(problem, kept).ok


def _budget_doc(offset: int) -> dict:
    """``big`` needs 6 fuel of 4; ``gen`` makes 3 but follows ``big``."""
    return {
        "horizon": 10,
        "resources": {"consumable": {"fuel": 4}},
        "tasks": [
            make_task("big", length=2, uses={"fuel": 3}),
            make_task("gen", length=3, uses={"fuel": -1}),
            make_task("small", length=1, uses={"fuel": 2}),
        ],
        "precedences": [
            {"before": "big", "after": "gen", "kind": "lax", "offset": offset}
        ],
    }


def test_consumer_over_its_budget_is_never_placed() -> None:
    """Tests the budget rule: generation after its end cannot help it."""
    problem = problem_from(_budget_doc(offset=0))
    domains = start_domains(problem)
    assert domains["big"].empty
    assert domains["big"].cause == "consumable"
    assert "needs 6 fuel" in domains["big"].detail
    # gen needs big (at_least_first): it goes too, by precedence.
    assert domains["gen"].empty and domains["gen"].cause == "precedence"
    assert not domains["small"].empty


def test_overlapping_generation_still_counts() -> None:
    """Tests that a follower starting before the end may supply it."""
    problem = problem_from(_budget_doc(offset=-1))
    assert not start_domains(problem)["big"].empty
    plan = solve(problem)
    assert plan.objective is not None
    assert plan.objective.total == _optimum(problem)


def test_progress_lines_are_parsed() -> None:
    """Tests that incumbent and bound are read from CBC's log lines."""
    from fsw_scheduler.solving.ilp.progress import LogState

    state = LogState(constant=100.0, incumbent=900.0)
    assert state.summary() == "incumbent 900, bound none, gap -"
    state.feed("Continuous objective value is 250.5 - 1.20 seconds")
    state.feed("Cbc0012I Integer solution of 700 found by DiveCoefficient")
    state.feed(
        "Cbc0010I After 100 nodes, 12 on tree, 650 best solution, "
        "best possible 300 (3.1 seconds)"
    )
    assert state.incumbent == 750.0 and state.bound == 400.0
    assert state.summary() == "incumbent 750, bound 400, gap 46.67 %"


def test_limit_bounds_the_whole_call_and_progress_is_logged(
    caplog: pytest.LogCaptureFixture, monkeypatch: pytest.MonkeyPatch
) -> None:
    """Tests that a large problem answers within its limit, explanations
    included, logging CBC's progress meanwhile."""
    import time

    from fsw_scheduler.solving.ilp import model, progress

    monkeypatch.setattr(progress, "PROGRESS_S", 0.25)
    # 15 tasks on a busy binary resource: CBC needs about 4 s to prove it
    # in the time-indexed model (the disjunctive one is much faster), so
    # a 1.5 s limit stops it with a plan.
    monkeypatch.setattr(model, "pick", lambda *_: "time-indexed")
    (bench,) = [
        b for b in generator.campaign(0, "broad") if b.name == "b15-binary-2"
    ]
    problem = bench.problem()
    caplog.set_level("INFO", logger="fsw_scheduler.solver")
    began = time.perf_counter()
    plan = solve(problem, time_limit=1.5, explain=True)
    wall = time.perf_counter() - began
    assert wall < 1.5 + 0.75, wall
    assert plan.status is SolveStatus.FEASIBLE
    assert check_plan(problem, plan).ok
    lines = [r.getMessage() for r in caplog.records]
    assert any("cbc running" in m and "incumbent" in m for m in lines)


def test_large_problems_improve_by_neighbourhood_search() -> None:
    """Tests that a 60-task solve under a limit improves its start plan by
    neighbourhood search, within the limit, with a valid plan."""
    import time

    bench = generator.scaling(0, style="broad")[3]  # 60 tasks, H = 336
    problem = bench.problem()
    start = best_start(problem, None)
    assert start is not None and start.objective is not None
    began = time.perf_counter()
    # 6 s: at 3 s, with the suite's other worker on the same core, the
    # search once found nothing better before its limit.
    plan = solve(problem, time_limit=6.0)
    assert time.perf_counter() - began < 6.0 + 0.5
    assert plan.stats is not None and plan.stats.solver == "cbc-lns"
    assert plan.status is SolveStatus.FEASIBLE
    assert check_plan(problem, plan).ok
    assert plan.objective is not None
    assert plan.objective.total < start.objective.total


def test_neighbourhood_search_logs_progress(
    caplog: pytest.LogCaptureFixture, monkeypatch: pytest.MonkeyPatch
) -> None:
    """Tests that a long neighbourhood search logs its incumbent (a
    60-task day's search from its start plan, given 2 s)."""
    import functools
    import time

    from fsw_scheduler.solving import improve

    # A line at each round (here from the first). The search is called
    # by itself: inside a 4.5 s solve, what is left for it after the
    # start plan, the bounds and the relaxation depends on the machine
    # (a fresh clone's CI run on two idle cores had no round left).
    monkeypatch.setattr(improve, "PROGRESS_S", 0.0)
    problem = generator.scaling(0, style="broad")[3].problem()
    domains = start_domains(problem)
    start = best_start(problem, None, domains=domains)
    assert start is not None
    caplog.set_level("INFO", logger="fsw_scheduler.solver")
    run = functools.partial(solve_ilp, solver="cbc", threads=1)
    improve.improve(problem, start, domains, run, time.perf_counter() + 2.0)
    lines = [r.getMessage() for r in caplog.records]
    assert any("neighbourhood search" in m and "left-out" in m for m in lines)


def test_a_long_start_plan_says_it_is_still_working(
    caplog: pytest.LogCaptureFixture, monkeypatch: pytest.MonkeyPatch
) -> None:
    """Tests that a large part's start plan logs a progress line while it
    works (every PROGRESS_S seconds; here at each step), not only when it
    begins and ends."""
    from fsw_scheduler.solving import solve as solve_module

    monkeypatch.setattr(solve_module, "PROGRESS_S", 0.0)
    problem = generator.scaling(0, style="broad")[3].problem()  # 60 tasks
    caplog.set_level("INFO", logger="fsw_scheduler.solver")
    best = solve_module.best_start(problem, None)
    solve(problem, time_limit=1.5)
    lines = [r.getMessage() for r in caplog.records]
    assert any("still list scheduling" in m for m in lines), lines[:5]
    assert best is not None


def _camera_and_battery(initial: int, generator: bool = True) -> dict:
    """Three consumers of a battery and a generator sharing a camera;
    the battery holds ``initial`` (``generator=False``: the last task
    uses the camera alone)."""
    uses = [{"camera": 1, "battery": 3}] * 3
    uses.append({"camera": 1, "battery": -3} if generator else {"camera": 1})
    return {
        "horizon": 12,
        "resources": {
            "binary": ["camera"],
            "consumable": {"battery": initial},
        },
        "tasks": [
            make_task(
                f"t{idx}",
                length=2,
                delay_cost=idx + 1,
                schedule_cost=4 - idx,
                uses=use,
            )
            for idx, use in enumerate(uses)
        ],
    }


@pytest.mark.parametrize("initial", [13, 7])
def test_consumable_beside_a_shared_resource_runs_cbc_without_cuts(
    initial: int,
) -> None:
    """Tests that a time-indexed model with a consumable beside a binary
    resource asks CBC for no cuts when its start plan leaves nothing out
    (keeps them when it leaves a task out, or without a consumable), and
    that CBC still proves the exhaustive search's optimum."""
    from fsw_scheduler.solving.ilp.model import (
        CONSUMABLES_AND_SHARED,
        TUNED_MAX_TASKS,
        BuiltModel,
        cbc_options,
    )

    assert "cuts off" in CONSUMABLES_AND_SHARED
    problem = problem_from(_camera_and_battery(initial))
    built = BuiltModel(problem)
    start = best_start(problem, None)
    assert start is not None
    options = cbc_options(built, start.starts()) or []
    # 13 and the generator's 6 cover all three consumers; 7 only one.
    assert ("cuts off" in options) is (not start.unscheduled)
    assert bool(start.unscheduled) is (initial == 7)
    everything = {task.id: 0 for task in problem.tasks}
    assert "cuts off" in (cbc_options(built, everything) or [])
    # Without a MIP start CBC keeps its defaults.
    assert cbc_options(built, None) is None
    # Larger parts than those measured keep CBC's cuts.
    doc = _camera_and_battery(initial)
    doc["tasks"] += [
        make_task(f"free{idx}", length=1) for idx in range(TUNED_MAX_TASKS)
    ]
    larger = problem_from(doc)
    assert "cuts off" not in (
        cbc_options(BuiltModel(larger), {t.id: 0 for t in larger.tasks}) or []
    )
    # Without a consumable the camera keeps CBC's cuts.
    doc = _camera_and_battery(initial, generator=False)
    doc["resources"].pop("consumable")
    for task in doc["tasks"]:
        task["uses"].pop("battery", None)
    camera_only = BuiltModel(problem_from(doc))
    assert "cuts off" not in (cbc_options(camera_only, everything) or [])
    plan = solve_ilp(problem, warm=start.starts(), formulation="time-indexed")
    best = brute_force(problem)
    assert best is not None
    assert plan.status is SolveStatus.OPTIMAL
    assert plan.objective is not None
    assert plan.objective.total == best[0].total
    assert check_plan(problem, plan).ok


def test_multiple_resource_models_strong_branch_by_formulation() -> None:
    """Tests that a time-indexed model of a multiple resource without a
    consumable asks CBC for two strong-branching candidates, without its
    two costliest cut generators and with at most 10 passes of cuts, and
    a disjunctive one of the same part for ten candidates."""
    from fsw_scheduler.solving.ilp.disjunctive.model import DisjunctiveModel
    from fsw_scheduler.solving.ilp.model import (
        BINARY_STRONG,
        DISJUNCTIVE_STRONG,
        MULTIPLE_TIME_INDEXED,
        BuiltModel,
        cbc_options,
    )

    assert MULTIPLE_TIME_INDEXED == [
        "strong 2",
        "twoMir off",
        "zeroHalf off",
        "passC 10",
    ]
    doc = {
        "horizon": 8,
        "resources": {"multiple": {"power": 10}},
        "tasks": [
            make_task(f"t{idx}", length=2, uses={"power": amount})
            for idx, amount in enumerate((6, 5, 4))
        ],
    }
    problem = problem_from(doc)
    everything = {task.id: 0 for task in problem.tasks}
    indexed = cbc_options(BuiltModel(problem), everything) or []
    assert "strong 2" in indexed
    assert "twoMir off" in indexed and "zeroHalf off" in indexed
    assert "passC 10" in indexed
    assert "cuts off" not in indexed
    disjunctive = DisjunctiveModel(problem, start_domains(problem))
    options = cbc_options(disjunctive, everything) or []
    assert "strong 2" not in options
    # The disjunctive model branches on more candidates instead, and
    # without CBC's mini branch-and-bound (its nodes escape node limits).
    assert DISJUNCTIVE_STRONG == ["strong 10", "depthMiniBab -999"]
    assert "strong 10" in options
    assert "depthMiniBab -999" in options
    binary = problem_from(
        {
            "horizon": 8,
            "resources": {"binary": ["camera"]},
            "tasks": [
                make_task(f"t{idx}", length=2, uses={"camera": 1})
                for idx in range(3)
            ],
        }
    )
    alone = DisjunctiveModel(binary, start_domains(binary))
    kept = cbc_options(alone, {task.id: 0 for task in binary.tasks}) or []
    assert "depthMiniBab -999" not in kept
    # Binary-only parts branch on two candidates.
    assert BINARY_STRONG == ["strong 2"]
    assert "strong 2" in kept and "strong 10" not in kept
    start = best_start(problem, None)
    assert start is not None
    plan = solve_ilp(problem, formulation="time-indexed", warm=start.starts())
    best = brute_force(problem)
    assert best is not None
    assert plan.status is SolveStatus.OPTIMAL
    assert plan.objective is not None
    assert plan.objective.total == best[0].total


@settings(COMMON, max_examples=120)
@given(doc=problem_docs(max_tasks=5, max_horizon=10))
def test_every_plan_as_a_warm_start_keeps_every_row(doc: dict) -> None:
    """Tests that the columns the time-indexed model's
    :meth:`Variables.initial` gives for any plan the exhaustive search
    accepts (identical tasks' starts in problem order, as the solver
    hands them over) keep every row written on integer columns alone:
    CBC drops a warm start that breaks one and searches without it. The
    level columns are CBC's to fill."""
    problem = decode_doc(doc)
    built = BuiltModel(problem)
    program = built.program
    rows = [
        row
        for row in program.rows
        if all(program.integer[col] for col in row[0])
    ]
    for placed in warm_starts(problem, built.constraints.twins):
        values = built.vars.initial(placed, program.num_columns)
        for terms, sense, rhs in rows:
            assert row_holds(terms, sense, rhs, values), (
                show(doc),
                placed,
                terms,
                sense,
                rhs,
            )
