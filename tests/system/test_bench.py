"""Tests of the benchmark kit (tools/bench_lib) and tools/bench."""

from __future__ import annotations

import importlib
import itertools
import json
import subprocess
import sys
from typing import TYPE_CHECKING, Any

import pytest

from fsw_scheduler.analysis.check import check_plan
from fsw_scheduler.model.plan import Activity, Plan, SolveStatus
from fsw_scheduler.model.problem import Problem, decode_problem

from ..factories import ROOT, bench_lib

if TYPE_CHECKING:
    from pathlib import Path

    from bench_lib.runner import Run
    from bench_lib.stability import StableRun


generator = bench_lib("generator")
report = bench_lib("report")
runner = bench_lib("runner")


def _has_ortools() -> bool:
    try:
        importlib.import_module("ortools.sat.python.cp_model")
    except ImportError:
        return False
    return True


def brute_force(problem: Problem) -> int | None:
    """Best objective total over every plan check_plan accepts (or None)."""
    choices = []
    for task in problem.tasks:
        low, high = problem.start_bounds(task)
        choices.append([None, *range(low, high + 1)])
    best = None
    for starts in itertools.product(*choices):
        activities = tuple(
            Activity(task.id, s, s + task.length)
            for task, s in zip(problem.tasks, starts, strict=True)
            if s is not None
        )
        unscheduled = tuple(
            task.id
            for task, s in zip(problem.tasks, starts, strict=True)
            if s is None
        )
        plan = Plan(SolveStatus.FEASIBLE, None, activities, unscheduled)
        checked = check_plan(problem, plan)
        if checked.ok and (best is None or checked.objective.total < best):
            best = checked.objective.total
    return best


def test_generator_is_deterministic() -> None:
    """Tests that the same seed gives byte-identical problems."""
    first = [p.to_json() for p in generator.suite("all", 7)]
    second = [p.to_json() for p in generator.suite("all", 7)]
    assert first == second
    other = [p.to_json() for p in generator.campaign(8)]
    assert other != first[: len(other)]


def test_problem_seed_regenerates_one_problem() -> None:
    """Tests that a problem's own seed rebuilds it alone, byte for byte."""
    bench = generator.campaign(0)[40]
    doc = generator.generate_problem(
        bench.num_tasks, bench.resource_class, bench.horizon, bench.seed
    )
    assert generator.dump_json(doc) == bench.to_json()


def test_suites_have_the_paper_shape() -> None:
    """Tests that the campaign is 3 sizes x 5 classes x 7 at H=336."""
    camp = generator.campaign(0)
    assert len(camp) == 105
    assert {p.horizon for p in camp} == {336}
    cells = {(p.num_tasks, p.resource_class) for p in camp}
    assert cells == set(itertools.product((5, 10, 15), generator.CLASSES))
    scale = generator.scaling(0)
    assert {(p.num_tasks, p.horizon) for p in scale} == set(
        itertools.product((30, 60, 100, 200), (336, 1440))
    )
    assert len({p.name for p in camp + scale}) == len(camp + scale)


def test_every_generated_problem_decodes() -> None:
    """Tests that every generated problem passes decode_problem."""
    for bench in generator.suite("all", 0) + generator.quick(0):
        problem = decode_problem(bench.to_json())
        assert problem.num_tasks == bench.num_tasks
        kinds = {
            kind
            for task in problem.tasks
            for name in task.uses
            if (kind := problem.resources.kind_of(name))
        }
        if bench.resource_class == "all":
            assert kinds == {"binary", "multiple", "consumable"}
        elif bench.resource_class in generator.CLASSES[1:]:
            assert kinds <= {bench.resource_class}


def test_generator_covers_every_feature() -> None:
    """Tests that the campaign holds every precedence kind and reading."""
    docs = [p.doc for p in generator.campaign(0)]
    precs = [e for d in docs for e in d["precedences"]]
    for kind, scope, sign in itertools.product(
        ("tight", "lax"), ("both", "at_least_first"), (-1, 0, 1)
    ):
        assert any(
            e["kind"] == kind
            and e["scope"] == scope
            and (e["offset"] > 0) - (e["offset"] < 0) == sign
            for e in precs
        ), (kind, scope, sign)
    tasks = [t for d in docs for t in d["tasks"]]
    readings = {d["feasible_interval_applies_to"] for d in docs}
    readings |= {
        t["feasible_interval_applies_to"]
        for t in tasks
        if "feasible_interval_applies_to" in t
    }
    assert readings == {"task", "start"}
    assert all(any(t["schedule_cost"] == 0 for t in d["tasks"]) for d in docs)
    assert any(t["feasible_interval"] for t in tasks)
    cons = [d for d in docs if "consumable" in d["resources"]]
    assert all(
        any(v < 0 for t in d["tasks"] for v in t["uses"].values())
        for d in cons
    )


def test_tight_precedences_are_chains() -> None:
    """Tests that each task has at most one tight predecessor and successor."""
    for bench in generator.suite("all", 0):
        tight = [e for e in bench.doc["precedences"] if e["kind"] == "tight"]
        befores = [e["before"] for e in tight]
        afters = [e["after"] for e in tight]
        assert len(set(befores)) == len(befores)
        assert len(set(afters)) == len(afters)


def test_percentile_interpolates() -> None:
    """Tests that percentile interpolates linearly between ranks."""
    assert report.percentile([1.0, 2.0, 3.0, 4.0, 5.0], 90) == pytest.approx(
        4.6
    )
    assert report.percentile([2.0], 90) == 2.0


def _run(solver: str, status: str, total: int | None) -> Run:
    return runner.Run(
        problem="p",
        suite="campaign",
        num_tasks=5,
        resource_class="none",
        horizon=336,
        seed=1,
        solver=solver,
        repeat=0,
        status=status,
        timeout=False,
        build_s=0.0,
        solve_s=0.0,
        overhead_s=0.0,
        wall_s=0.0,
        total=total,
    )


def test_compare_flags_contradictions() -> None:
    """Tests that compare reports differing optima and false infeasibility."""
    assert (
        runner.compare([_run("cbc", "optimal", 5), _run("x", "optimal", 5)])
        == []
    )
    assert runner.compare([_run("cbc", "optimal", 5), _run("x", "optimal", 6)])
    assert runner.compare(
        [_run("cbc", "optimal", 5), _run("x", "feasible", 4)]
    )
    assert runner.compare(
        [_run("cbc", "infeasible", None), _run("x", "feasible", 9)]
    )


TINY = [(4, cls, 8, seed) for cls in generator.CLASSES for seed in range(1, 6)]


@pytest.mark.parametrize(("size", "cls", "horizon", "seed"), TINY)
def test_cpsat_matches_brute_force(
    size: int, cls: str, horizon: int, seed: int
) -> None:
    """Tests that CP-SAT finds the brute-force optimum on tiny problems."""
    pytest.importorskip("ortools")
    cpsat = bench_lib("cpsat")
    doc = generator.generate_problem(size, cls, horizon, seed)
    problem = decode_problem(json.dumps(doc))
    best = brute_force(problem)
    assert best is not None  # mandatory tasks are always placeable
    plan = cpsat.solve_cpsat(problem, time_limit=20)
    assert plan.status is SolveStatus.OPTIMAL
    assert check_plan(problem, plan).ok
    assert plan.objective is not None
    assert plan.objective.total == best


def test_cpsat_matches_brute_force_on_consumable_charging() -> None:
    """Tests that CP-SAT counts consumption per unit run, with charging."""
    pytest.importorskip("ortools")
    cpsat = bench_lib("cpsat")
    problem = decode_problem(
        json.dumps(
            {
                "horizon": 7,
                "resources": {"consumable": {"bat": 2}},
                "tasks": [
                    {
                        "id": "use",
                        "length": 3,
                        "delay_cost": 5,
                        "schedule_cost": 2,
                        "uses": {"bat": 2},
                    },
                    {
                        "id": "charge",
                        "length": 2,
                        "delay_cost": 1,
                        "schedule_cost": 1,
                        "uses": {"bat": -1.5},
                    },
                    {
                        "id": "must",
                        "length": 1,
                        "delay_cost": 2,
                        "schedule_cost": 0,
                        "uses": {"bat": 0.5},
                        "feasible_interval": [2, 4],
                    },
                ],
                "precedences": [
                    {
                        "before": "charge",
                        "after": "use",
                        "kind": "lax",
                        "scope": "at_least_first",
                        "offset": -1,
                    },
                ],
            }
        )
    )
    plan = cpsat.solve_cpsat(problem)
    assert plan.status is SolveStatus.OPTIMAL
    assert check_plan(problem, plan).ok
    assert plan.objective is not None
    assert plan.objective.total == brute_force(problem)


def test_cpsat_reports_infeasible() -> None:
    """Tests that CP-SAT says infeasible when mandatory tasks cannot fit."""
    pytest.importorskip("ortools")
    cpsat = bench_lib("cpsat")
    problem = decode_problem(
        json.dumps(
            {
                "horizon": 3,
                "resources": {"binary": ["r"]},
                "tasks": [
                    {
                        "id": t,
                        "length": 2,
                        "delay_cost": 1,
                        "schedule_cost": 0,
                        "uses": {"r": 1},
                    }
                    for t in ("a", "b")
                ],
            }
        )
    )
    plan = cpsat.solve_cpsat(problem)
    assert plan.status is SolveStatus.INFEASIBLE
    assert plan.objective is None
    assert set(plan.unscheduled) == {"a", "b"}


@pytest.mark.parametrize("index", [0, 14, 21, 28])
def test_cpsat_agrees_with_cbc(index: int) -> None:
    """Tests that CP-SAT and CBC prove the same optimum on 5-task problems."""
    pytest.importorskip("ortools")
    cpsat = bench_lib("cpsat")
    from fsw_scheduler.solving.solve import solve

    problem = generator.campaign(0)[index].problem()
    mine = cpsat.solve_cpsat(problem, time_limit=30)
    theirs = solve(problem, "cbc", time_limit=30)
    assert mine.status is theirs.status is SolveStatus.OPTIMAL
    assert mine.objective == theirs.objective
    assert check_plan(problem, mine).ok


def test_quick_bench_runs_end_to_end(tmp_path: Path) -> None:
    """Tests that tools/bench --quick runs, checks plans and prints tables."""
    solvers = "cbc,cpsat" if _has_ortools() else "cbc"
    result = subprocess.run(
        [
            sys.executable,
            str(ROOT / "tools" / "bench"),
            "--quick",
            "--solvers",
            solvers,
            "--time-limit",
            "30",
            "--out",
            str(tmp_path),
        ],
        capture_output=True,
        text=True,
        timeout=120,
        check=False,
    )
    assert result.returncode == 0, result.stderr
    assert "by number of tasks" in result.stdout
    assert "by resource class" in result.stdout
    assert "check failures: 0" in result.stdout
    assert "solver disagreements: 0" in result.stdout
    assert result.stderr.count("q05-") >= 4  # one progress line per problem
    rows = (tmp_path / "runs.csv").read_text().splitlines()
    assert len(rows) == 1 + len(generator.CLASSES) * len(solvers.split(","))
    assert (tmp_path / "fig3_by_tasks.png").exists()
    written = list((tmp_path / "problems").glob("*.json"))
    assert len(written) == len(generator.CLASSES)


def test_bench_capacity_option(tmp_path: Path) -> None:
    """Tests tools/bench --capacity: consumables get a capacity, plans are
    checked and the solvers agree."""
    solvers = "cbc,cpsat" if _has_ortools() else "cbc"
    result = subprocess.run(
        [
            sys.executable,
            str(ROOT / "tools" / "bench"),
            "--quick",
            "--only",
            "cons",
            "--capacity",
            "1",
            "--solvers",
            solvers,
            "--time-limit",
            "30",
            "--out",
            str(tmp_path),
        ],
        capture_output=True,
        text=True,
        timeout=120,
        check=False,
    )
    assert result.returncode == 0, result.stderr
    assert "check failures: 0" in result.stdout
    assert "solver disagreements: 0" in result.stdout
    (saved,) = (tmp_path / "problems").glob("*.json")
    consumable = json.loads(saved.read_text())["resources"]["consumable"]
    assert consumable
    assert all(c["max"] == c["initial"] for c in consumable.values())


def test_bench_rejects_unknown_solver() -> None:
    """Tests that tools/bench exits 2 naming an unknown solver."""
    result = subprocess.run(
        [sys.executable, str(ROOT / "tools" / "bench"), "--solvers", "gurobi"],
        capture_output=True,
        text=True,
        timeout=60,
        check=False,
    )
    assert result.returncode == 2
    assert "gurobi" in result.stderr


def test_broad_generator_has_the_issue_shape() -> None:
    """Tests that the broad campaign is valid, deterministic and as broad as
    asked: windows, precedences per task, contradicting tight paths, busy
    binary resources and scarce consumables."""
    from fsw_scheduler.analysis.proofs import tight_conflicts

    first = generator.suite("all", 0, "broad")
    assert [p.to_json() for p in first] == [
        p.to_json() for p in generator.suite("all", 0, "broad")
    ]
    camp = [p for p in first if p.suite == "campaign"]
    assert len(camp) == 105 and all(p.name.startswith("b") for p in camp)
    tasks = [t for p in camp for t in p.doc["tasks"]]
    windows = sum(t.get("feasible_interval") is not None for t in tasks)
    assert 0.25 < windows / len(tasks) < 0.45
    precs = sum(len(p.doc["precedences"]) for p in camp)
    assert 0.35 < precs / len(tasks) < 0.6
    kinds = {
        (e["kind"], e["scope"], (e["offset"] > 0) - (e["offset"] < 0))
        for p in camp
        for e in p.doc["precedences"]
    }
    assert len(kinds) == 12  # every kind x scope x offset sign
    assert sum(bool(tight_conflicts(p.problem())) for p in camp) > 10
    for bench in camp:
        problem = bench.problem()
        horizon = problem.horizon
        for name in problem.resources.binary:
            busy = sum(t.length for t in problem.tasks if t.uses.get(name))
            assert busy >= 0.65 * horizon, bench.name
        for name, cap in problem.resources.multiple.items():
            for task in problem.tasks:
                amount = task.uses.get(name, 0)
                assert amount == 0 or cap / 6 - 1 <= amount <= 0.6 * cap
        for name, level in problem.resources.consumable.items():
            demand = sum(
                t.uses.get(name, 0) * t.length
                for t in problem.tasks
                if t.uses.get(name, 0) > 0
            )
            assert (
                level < 0.5 * demand
                or level
                <= sum(
                    t.uses.get(name, 0) * t.length
                    for t in problem.tasks
                    if t.mandatory and t.uses.get(name, 0) > 0
                )
                + 1
            ), bench.name


def test_reports_set_each_solver_against_cpsat() -> None:
    """Tests the problem-by-problem comparison with CP-SAT: ratios, proofs,
    and on scaling points left-out cost and gap to the best bound."""
    import dataclasses

    def run(solver: str, wall: float, **over: Any) -> Run:
        base = _run(solver, "optimal", 10)
        return dataclasses.replace(base, wall_s=wall, **over)

    runs = [run("cbc", 0.4), run("cpsat", 0.1)]
    text = report.format_versus(runs)
    assert "4.0x" in text and "1/1" in text
    scale = dict(suite="scaling", num_tasks=30, unscheduled_cost=2)
    runs = [
        run("cbc", 5.0, status="feasible", total=120, bound=None, **scale),
        run("cpsat", 5.0, status="feasible", total=130, bound=100.0, **scale),
    ]
    runs[1] = dataclasses.replace(runs[1], unscheduled_cost=3)
    text = report.format_scaling_versus(runs)
    assert "1/0/0" in text  # cbc leaves less out than cpsat
    assert "16.7 %" in text  # (120 - 100) / 120


def test_the_campaign_says_which_classes_meet_the_15_task_target() -> None:
    """Tests the line under the campaign's table: per class at 15 tasks,
    whether the ratio of medians is at most 3x and the worst problem at
    most 20x CP-SAT's, with the figures of each class that misses."""
    import dataclasses

    def run(name: str, cls: str, solver: str, wall: float) -> Run:
        return dataclasses.replace(
            _run(solver, "optimal", 10),
            problem=name,
            num_tasks=15,
            resource_class=cls,
            wall_s=wall,
        )

    runs = [
        run("b1", "binary", "cbc", 0.02),
        run("b1", "binary", "cpsat", 0.01),
        run("b2", "binary", "cbc", 0.03),
        run("b2", "binary", "cpsat", 0.01),
        run("m1", "multiple", "cbc", 0.04),
        run("m1", "multiple", "cpsat", 0.01),
        run("a1", "all", "cbc", 0.25),  # 25x CP-SAT: the class's worst
        run("a1", "all", "cpsat", 0.01),
        run("a2", "all", "cbc", 0.02),
        run("a2", "all", "cpsat", 0.01),
    ]
    line = report.format_versus(runs).splitlines()[-1]
    assert line.startswith("cbc at 15 tasks, target median <= 3x")
    assert "met for binary;" in line
    assert "NOT met for multiple (4.0x, worst 4x), all (13.5x, worst 25x)" in (
        line
    )
    smaller = [dataclasses.replace(r, num_tasks=10) for r in runs]
    assert "at 15 tasks" not in report.format_versus(smaller)


def test_the_large_shapes_are_set_against_cpsat_with_their_targets() -> None:
    """Tests the large suites' table: each problem's answers side by side
    with the verdict against CP-SAT, and per solver the three targets
    of the large shapes, met or not, with the problems that miss them
    named (proofs counted, ``unknown`` on a problem proved infeasible,
    ``feasible`` where CP-SAT proved the optimum)."""
    import dataclasses

    def run(name: str, solver: str, status: str, total: int | None) -> Run:
        return dataclasses.replace(
            _run(solver, status, total),
            problem=name,
            suite="large",
            unscheduled_cost=None if total is None else total // 100,
        )

    runs = [
        run("b30-h1440", "cbc", "optimal", 700),
        run("b30-h1440", "cpsat", "optimal", 700),
        run("f30-h1440", "cbc", "feasible", 910),
        run("f30-h1440", "cpsat", "optimal", 900),
        run("f45-h1440", "cbc", "feasible", 1200),
        run("f45-h1440", "cpsat", "feasible", 1250),
        run("b45-h2880", "cbc", "unknown", None),
        run("b45-h2880", "cpsat", "infeasible", None),
        # A later repeat is not read.
        dataclasses.replace(run("f45-h1440", "cbc", "optimal", 1), repeat=1),
    ]
    text = report.format_shapes_versus(runs)
    rows = {line.split()[0]: line for line in text.splitlines()[2:6]}
    assert "both proved" in rows["b30-h1440"]
    assert "cpsat alone proved" in rows["f30-h1440"]
    assert "better by 50" in rows["f45-h1440"]
    assert "feasible 0.00 s 1,200 [12]" in rows["f45-h1440"]
    summary = text.splitlines()[-1]
    assert summary.startswith("cbc: proved 1 of 4, cpsat 3 (NOT met")
    assert "unknown on an infeasible problem: 1 (b45-h2880) (NOT met)" in (
        summary
    )
    assert "proved the optimum: 1 (f30-h1440)" in summary
    assert (
        report.format_shapes_versus(runs[:2])
        .splitlines()[-1]
        .startswith("cbc: proved 1 of 1, cpsat 1 (met")
    )
    # Campaign runs alone: no such table in the report.
    assert report.format_shapes_versus([_run("cbc", "optimal", 5)]) == ""


def test_fresh_generator_has_its_shape() -> None:
    """Tests that the fresh campaign is valid, deterministic and shaped as
    documented in bench_lib/fresh.py."""
    fresh = bench_lib("fresh")
    camp = generator.suite("campaign", 0, "fresh")
    assert [p.to_json() for p in camp] == [
        p.to_json() for p in generator.suite("all", 0, "fresh")
    ]
    assert {(p.num_tasks, p.horizon) for p in camp} == {
        (n, h) for n in (15, 20, 25) for h in (336, 1440)
    }
    tasks = [t for p in camp for t in p.doc["tasks"]]
    windows = sum(t.get("feasible_interval") is not None for t in tasks)
    assert 0.28 < windows / len(tasks) < 0.45
    kinds = {
        (e["kind"], e["scope"], (e["offset"] > 0) - (e["offset"] < 0))
        for p in camp
        for e in p.doc["precedences"]
    }
    assert len(kinds) == 12  # every kind x scope x offset sign
    for bench in camp:
        problem = bench.problem()
        assert len(bench.doc["precedences"]) == bench.num_tasks // 3
        assert problem.resources.binary == fresh.BINARY_NAMES
        assert problem.resources.multiple == {"power": 60}
        mandatory = [t for t in problem.tasks if t.mandatory]
        assert len(mandatory) == round(0.1 * bench.num_tasks)
        must = sum(t.uses.get("battery", 0) * t.length for t in mandatory)
        assert must < fresh.BATTERY
        assert any(t.uses.get("battery", 0) < 0 for t in problem.tasks)
    assert camp[0].doc["resources"]["consumable"] == {"battery": 40}
    quick = generator.suite("quick", 0, "fresh")
    assert [p.name for p in quick] == ["f15-h336-0"]
    with pytest.raises(ValueError, match="no 'scaling' suite"):
        generator.suite("scaling", 0, "fresh")


def test_versus_flags_unknown_where_cpsat_planned() -> None:
    """Tests that the CP-SAT comparison groups by the sizes and horizons
    run, gives the mean and loudly lists unknowns CP-SAT could plan."""
    import dataclasses

    def run(solver: str, name: str, wall: float, **over: Any) -> Run:
        base = _run(solver, "optimal", 10)
        return dataclasses.replace(
            base, problem=name, wall_s=wall, resource_class="mixed", **over
        )

    runs = [
        run("cbc", "f20-h336-0", 0.4, num_tasks=20),
        run("cpsat", "f20-h336-0", 0.1, num_tasks=20),
        run(
            "cbc",
            "f25-h1440-0",
            20.0,
            num_tasks=25,
            horizon=1440,
            status="unknown",
            total=None,
        ),
        run(
            "cpsat",
            "f25-h1440-0",
            2.0,
            num_tasks=25,
            horizon=1440,
            status="feasible",
        ),
    ]
    text = report.format_versus(runs)
    rows = {
        line.split()[1]: line.split()
        for line in text.splitlines()
        if line.startswith("cbc ")
    }
    assert {"20", "25", "mixed", "H=336", "H=1440", "overall"} <= set(rows)
    # n, medians, ratio, median and worst ratio, mean, proofs, unknowns
    assert rows["overall"][2:] == [
        "2",
        "10.200",
        "1.050",
        "9.7x",
        "7.0x",
        "10x",
        "10.200",
        "1/2",
        "1/2",
        "1",
    ]
    assert rows["H=336"][-1] == "0" and rows["H=1440"][-1] == "1"
    assert "1 solves unknown where cpsat found a plan" in text
    assert "!!! cbc unknown on f25-h1440-0" in text
    assert "(feasible, total 10)" in text


def test_bench_refuses_a_suite_the_generator_lacks() -> None:
    """Tests that --generator fresh --suite scaling exits with code 2."""
    result = subprocess.run(
        [
            sys.executable,
            str(ROOT / "tools" / "bench"),
            "--generator",
            "fresh",
            "--suite",
            "scaling",
            "--solvers",
            "cbc",
        ],
        capture_output=True,
        text=True,
        timeout=60,
        check=False,
    )
    assert result.returncode == 2
    assert "no 'scaling' suite" in result.stderr


def test_mission_suite_has_its_shape() -> None:
    """Tests the mission suite (``tools/bench --suite mission``): 5, 10
    and 15 tasks x alternatives and profiles x 7 problems, each valid and
    rebuilt alone from its seed; the alternatives class has groups, the
    profiles class resources that change over time and no group."""
    problems = generator.suite("mission", 0)
    assert len(problems) == 42
    assert generator.suite("mission", 0)[5].to_json() == problems[5].to_json()
    grouped = 0
    for bench in problems:
        problem = decode_problem(bench.to_json())
        assert problem.num_tasks == bench.num_tasks
        if bench.resource_class == "alternatives":
            grouped += bool(problem.alternatives)
            assert not problem.resources.changing
        else:
            assert problem.resources.changing
            assert not problem.alternatives
    # A problem whose optional tasks are all in precedences has no pair.
    assert grouped >= 14


def test_stability_suite_prices_moves_on_the_quick_replans() -> None:
    """Tests the cost-of-stability suite on the quick set: every plan
    passes the checker with its move part, the unscheduled cost is the
    same in every mode (it comes first), and lexicographic never moves
    more than off or moves on a replan all three solved to optimality."""
    stability = bench_lib("stability")
    problems = generator.suite("quick", 0, "broad")
    runs = stability.run_stability(problems, 20.0)
    assert all(r.ok for r in runs)
    by_problem: dict[str, dict[str, StableRun]] = {}
    for run in runs:
        by_problem.setdefault(run.problem, {})[run.mode] = run
    for modes in by_problem.values():
        assert set(modes) == {"off", "moves", "lexicographic"}
        if all(m.status == "optimal" for m in modes.values()):
            costs = {m.unscheduled_cost for m in modes.values()}
            assert len(costs) == 1
            lex = modes["lexicographic"].moves
            assert lex <= modes["off"].moves
            assert lex <= modes["moves"].moves
    assert "| lexicographic |" in stability.format_stability(runs)


def test_large_suite_has_its_shape() -> None:
    """Tests the large suite (``tools/bench --suite large``): 30, 45 and
    60 tasks at H = 1440 and 2880, one fresh and one broad problem each,
    valid, the same from the same seed and different from another."""
    problems = generator.suite("large", 47)
    assert [b.name for b in problems[:2]] == ["f30-h1440", "b30-h1440"]
    assert len(problems) == 12
    assert {(b.num_tasks, b.horizon) for b in problems} == {
        (n, h) for n in (30, 45, 60) for h in (1440, 2880)
    }
    again = generator.suite("large", 47)
    assert [b.to_json() for b in again] == [b.to_json() for b in problems]
    other = generator.suite("large", 48)
    assert other[0].to_json() != problems[0].to_json()
    for bench in problems:
        problem = decode_problem(bench.to_json())
        assert problem.num_tasks == bench.num_tasks
        assert problem.horizon == bench.horizon


def test_orbit_suite_is_the_large_suite_under_passes_and_eclipses() -> None:
    """Tests the orbit suite (``tools/bench --suite orbit``): the large
    suite's problems, named ``o`` + theirs, every binary resource in
    passes and every multiple one in steps of the full capacity and 70 %
    of it, valid, the same from the same seed."""
    large = generator.suite("large", 47)
    orbit = generator.suite("orbit", 47)
    assert [b.name for b in orbit] == [f"o{b.name}" for b in large]
    assert [b.to_json() for b in generator.suite("orbit", 47)] == [
        b.to_json() for b in orbit
    ]
    for plain, bench in zip(large, orbit, strict=True):
        problem = decode_problem(bench.to_json())
        assert [t.id for t in problem.tasks] == [
            t["id"] for t in plain.doc["tasks"]
        ]
        resources = problem.resources
        assert set(resources.changing) == {
            *resources.binary,
            *resources.multiple,
        } - {n for n in resources.consumable}
        for name in resources.multiple:
            peak = resources.peak_capacity(name)
            profile = resources.capacity_profile(
                name, problem.start, problem.horizon
            )
            assert set(profile) == {peak, int(peak * 0.7)}


def test_cbc_and_cpsat_agree_on_every_feature_at_once() -> None:
    """Tests that CBC and CP-SAT prove the same answers on problems mixing
    windows, capacity steps, charges, alternatives and precedences."""
    pytest.importorskip("ortools")
    cpsat = bench_lib("cpsat")
    features = bench_lib("features")
    from fsw_scheduler.solving.solve import solve

    seen: set[str] = set()
    for seed in range(60):
        problem = decode_problem(
            json.dumps(features.generate_problem(seed)).encode()
        )
        mine = solve(problem, time_limit=30)
        theirs = cpsat.solve_cpsat(problem, time_limit=30)
        seen.add(mine.status.value)
        assert mine.status is theirs.status, seed
        assert mine.status in (SolveStatus.OPTIMAL, SolveStatus.INFEASIBLE)
        assert mine.objective == theirs.objective, seed
        if mine.status.has_plan:
            assert check_plan(problem, mine).ok, seed
            assert check_plan(problem, theirs).ok, seed
    # The draw reaches both answers: a test that only saw one would not
    # check the other.
    assert seen == {"optimal", "infeasible"}


@pytest.mark.parametrize("seed", [0, 5])
def test_infeasible_suite_is_answered_infeasible(seed: int) -> None:
    """Tests the infeasible suite (``tools/bench --suite infeasible``):
    28 valid problems of 30-60 tasks, two of each impossible core, the
    same from their seeds, and every one answered ``infeasible`` by the
    product (never ``unknown``) with a proof that names its core, and
    by CP-SAT where it is installed."""
    from fsw_scheduler.solving.solve import solve

    problems = generator.suite("infeasible", seed)
    assert len(problems) == 28
    kinds = {bench.resource_class for bench in problems}
    assert kinds == set(bench_lib("infeasible").KINDS)
    again = generator.suite("infeasible", seed)
    assert [b.to_json() for b in again] == [b.to_json() for b in problems]
    for bench in problems:
        problem = decode_problem(bench.to_json())
        assert 30 <= problem.num_tasks <= 60
        plan = solve(problem, time_limit=20)
        assert plan.status is SolveStatus.INFEASIBLE, (bench.name, plan.stats)
        core = {t.id for t in problem.tasks if not t.id.startswith("N")}
        if plan.why:
            assert {b.task for b in plan.why} <= core, (bench.name, plan.why)
        if _has_ortools():
            cpsat = bench_lib("cpsat").solve_cpsat(problem, time_limit=20)
            assert cpsat.status is SolveStatus.INFEASIBLE, bench.name
