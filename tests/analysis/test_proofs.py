"""Tests of forced tasks and cheap infeasibility proofs (proofs.py)."""

from __future__ import annotations

import json
import subprocess

import msgspec
from hypothesis import given, settings
from hypothesis import strategies as st

from fsw_scheduler.analysis.check import check_plan
from fsw_scheduler.analysis.domains import start_domains
from fsw_scheduler.analysis.greedy import greedy_plan
from fsw_scheduler.analysis.proofs import (
    apart_cliques,
    block_conflicts,
    forced_tasks,
    infeasibility,
    tight_conflicts,
)
from fsw_scheduler.model.plan import SolveStatus
from fsw_scheduler.solving.solve import solve

from ..factories import CLI, make_doc, make_task, problem_from
from ..problems import (
    COMMON,
    apart_docs,
    brute_force,
    decode_doc,
    problem_docs,
)


def _tight(before: str, after: str, offset: int = 0, **over: object) -> dict:
    prec: dict[str, object] = {
        "before": before,
        "after": after,
        "kind": "tight",
    }
    prec.update(offset=offset, **over)
    return prec


def _two_paths(
    scope: str = "at_least_first", **over: dict[str, object]
) -> dict:
    """a -> b -> c fixes s_c - s_a = 5; a -> c says 3: they contradict."""
    tasks = [
        make_task("a", 2),
        make_task("b", 3),
        make_task("c", 1),
        make_task("m", 2),
    ]
    for task in tasks:
        task.update(over.get(task["id"], {}))
    return {
        "horizon": 20,
        "tasks": tasks,
        "precedences": [
            _tight("a", "b", scope=scope),
            _tight("b", "c", scope=scope),
            _tight("a", "c", 1, scope=scope),
        ],
    }


# -- defect 1: contradicting tight paths are valid input --------------------


def test_contradicting_tight_paths_are_valid_and_solved() -> None:
    """Tests that contradicting tight paths only keep tasks apart.

    Before, decoding rejected the problem (exit 2); now the plan leaves
    one task of the contradiction out and passes the checker.
    """
    for scope in ("at_least_first", "both"):
        problem = problem_from(_two_paths(scope, m={"schedule_cost": 0}))
        assert [c.position for c in tight_conflicts(problem)] == [2]
        plan = solve(problem, explain=True, explain_budget=60.0)
        assert plan.status is SolveStatus.OPTIMAL, plan
        assert check_plan(problem, plan).ok
        assert "m" in plan.starts()
        assert plan.unscheduled, scope  # not all of a, b, c together
        start = greedy_plan(problem)
        assert start is not None and check_plan(problem, start).ok


def test_contradiction_among_forced_tasks_is_infeasible() -> None:
    """Tests that forced tasks in a contradiction make it infeasible.

    ``c`` is mandatory; it needs ``a`` and ``b`` (its predecessors), so all
    three must be scheduled and the tight paths cannot both hold: ``c``
    alone is named, as the task whose needs contradict.
    """
    problem = problem_from(_two_paths(c={"schedule_cost": 0}))
    assert forced_tasks(problem) == {"a", "b", "c"}
    plan = solve(problem)
    assert plan.status is SolveStatus.INFEASIBLE
    assert {b.task for b in plan.why} == {"c"}
    assert all(b.cause == "precedence" for b in plan.why)
    assert "contradict" in plan.why[0].detail
    assert plan.stats is not None and plan.stats.solver == "proof"


def test_cli_solves_contradicting_paths(tmp_path: object) -> None:
    """Tests that ``solve`` exits 0 on contradicting optional tasks, 1 when
    forced ones contradict (with the reason on stderr)."""
    from pathlib import Path

    base = Path(str(tmp_path))
    for name, doc, code in (
        ("ok.json", _two_paths(), 0),
        ("bad.json", _two_paths(c={"schedule_cost": 0}), 1),
    ):
        path = base / name
        path.write_text(json.dumps(doc))
        result = subprocess.run(
            [*CLI, "solve", str(path)],
            capture_output=True,
            text=True,
            check=False,
        )
        assert result.returncode == code, result.stderr
        if code:
            assert "contradict" in result.stderr


def test_forced_closure_follows_needs() -> None:
    """Tests that forced tasks take in needed tasks and both-partners."""
    doc = {
        "horizon": 20,
        "tasks": [
            make_task("m", schedule_cost=0, length=1),
            make_task("p", length=1),
            make_task("q", length=1),
            make_task("r", length=1),
            make_task("s", length=1),
        ],
        "precedences": [
            {"before": "p", "after": "m", "kind": "lax"},  # m needs p
            {"before": "m", "after": "q", "kind": "lax"},  # both: drags q
            {
                "before": "m",
                "after": "r",
                "kind": "lax",
                "scope": "at_least_first",
            },
            {"before": "q", "after": "s", "kind": "lax"},  # q drags s
        ],
    }
    assert forced_tasks(problem_from(doc)) == {"m", "p", "q", "s"}


# -- defect 3: cheap infeasibility proofs ---------------------------------


def _proof(doc: dict) -> tuple:
    problem = problem_from(doc)
    plan = solve(problem, time_limit=10)
    assert plan.status is SolveStatus.INFEASIBLE, plan
    assert plan.stats is not None and plan.stats.solver == "proof", plan
    return tuple((b.task, b.cause) for b in plan.why)


def test_binary_over_subscribed_inside_windows() -> None:
    """Tests that mandatory users crowding one binary window are infeasible
    without a solve, though the horizon has room for them."""
    doc = {
        "horizon": 300,
        "resources": {"binary": ["cam"]},
        "tasks": [
            make_task(
                n,
                4,
                schedule_cost=0,
                uses={"cam": 1},
                feasible_interval=[10, 21],
            )
            for n in ("a", "b", "c")
        ]
        + [make_task("x", 5, uses={"cam": 1})],
    }
    assert _proof(doc) == (("a", "binary"), ("b", "binary"), ("c", "binary"))


def test_multiple_over_subscribed() -> None:
    """Tests the energy test on a multiple resource and a lone task that
    needs more than the capacity."""
    doc = {
        "horizon": 50,
        "resources": {"multiple": {"power": 10}},
        "tasks": [
            make_task(
                "a",
                6,
                schedule_cost=0,
                uses={"power": 6},
                feasible_interval=[0, 10],
            ),
            make_task(
                "b",
                6,
                schedule_cost=0,
                uses={"power": 6},
                feasible_interval=[0, 10],
            ),
        ],
    }
    assert {c for _, c in _proof(doc)} == {"multiple"}
    doc["tasks"] = [make_task("a", 2, schedule_cost=0, uses={"power": 11})]
    assert _proof(doc) == (("a", "multiple"),)


def test_consumable_over_subscribed_before_generation() -> None:
    """Tests that mandatory consumers needing more than the level plus the
    generation possible by their end are infeasible without a solve."""
    doc = {
        "horizon": 100,
        "resources": {"consumable": {"fuel": 4}},
        "tasks": [
            make_task(
                "a",
                3,
                schedule_cost=0,
                uses={"fuel": 1},
                feasible_interval=[0, 10],
            ),
            make_task(
                "b",
                3,
                schedule_cost=0,
                uses={"fuel": 1},
                feasible_interval=[0, 10],
            ),
            # Plenty of generation, but only after both must have ended.
            make_task("g", 5, uses={"fuel": -5}, feasible_interval=[40, 60]),
        ],
    }
    assert {c for _, c in _proof(doc)} == {"consumable"}


def test_mandatory_pinned_against_window() -> None:
    """Tests that a mandatory task with no start time is caught early."""
    doc = {
        "horizon": 20,
        "tasks": [make_task("a", 3, schedule_cost=0), make_task("b", 2)],
        "precedences": [_tight("a", "b", 16)],  # b would end past 20
    }
    # b is forced by a ("both"), and cannot start by 19 - 2.
    assert _proof(doc)[0][1] == "precedence"


@settings(COMMON, max_examples=200)
@given(doc=problem_docs(max_tasks=4, max_horizon=8))
def test_proofs_never_reject_a_feasible_problem(doc: dict) -> None:
    """Tests that a cheap proof of infeasibility agrees with brute force,
    and that the start plan exists whenever forced tasks fit alone."""
    problem = decode_doc(doc)
    proof = infeasibility(problem, start_domains(problem))
    if proof:
        assert brute_force(problem) is None, proof
    start = greedy_plan(problem)
    if start is not None:
        assert check_plan(problem, start).ok


# -- tasks no two of which can run at once --------------------------------


def _crowded(
    uses: list[dict],
    window: tuple[int, int] = (10, 40),
    horizon: int = 200,
) -> dict:
    """Mandatory tasks of length 7 with ``uses``, all in ``window``."""
    return {
        "horizon": horizon,
        "resources": {"binary": ["cam"], "multiple": {"power": 100}},
        "tasks": [
            make_task(
                f"t{idx}",
                7,
                schedule_cost=0,
                uses=use,
                feasible_interval=list(window),
                feasible_interval_applies_to="task",
            )
            for idx, use in enumerate(uses)
        ],
    }


def test_tasks_over_half_a_capacity_cannot_share_a_short_window() -> None:
    """Tests that five mandatory tasks each needing more than half of a
    multiple resource, in a window shorter than their total length, are
    proved infeasible without a solve, at once."""
    # 35 units of work in 30 units of time; the energy (5 x 60 x 7 =
    # 2100 of 3000) fits, so only the pairwise argument proves it.
    doc = _crowded([{"power": 60}] * 5)
    plan = solve(problem_from(doc), time_limit=30)
    assert plan.status is SolveStatus.INFEASIBLE, plan
    assert plan.stats is not None and plan.stats.solver == "proof"
    assert plan.stats.wall_s < 1.0, plan.stats
    assert {(b.task, b.cause) for b in plan.why} == {
        (f"t{idx}", "multiple") for idx in range(5)
    }
    assert "[10, 40)" in plan.why[0].detail, plan.why[0].detail
    # One more unit of room and they fit one after the other.
    roomy = _crowded([{"power": 60}] * 5, window=(10, 45))
    assert solve(problem_from(roomy), time_limit=30).status.has_plan


def test_a_clique_held_by_two_resources_proves_what_neither_does() -> None:
    """Tests that tasks kept apart partly by a binary resource and partly
    by pairs over a multiple capacity form one clique whose proof neither
    resource's energy test gives, and that brute force agrees."""
    # a, b share the camera (50 + 40 power fit together); c needs 65, too
    # much beside either. 9 units of work, 8 of time; the camera holds 6
    # units and the power 3 x 155 = 465 of 800.
    uses = [{"power": 50, "cam": 1}, {"power": 40, "cam": 1}, {"power": 65}]
    doc = _crowded(uses, window=(2, 10), horizon=12)
    for task in doc["tasks"]:
        task["length"] = 3
    problem = problem_from(doc)
    found = [
        ([t.id for t in clique], kind)
        for clique, kind in apart_cliques(problem, problem.tasks)
    ]
    assert found[-1] == (["t0", "t1", "t2"], "multiple"), found
    proof = infeasibility(problem, start_domains(problem))
    assert {(b.task, b.cause) for b in proof} == {
        ("t0", "multiple"),
        ("t1", "multiple"),
        ("t2", "multiple"),
    }, proof
    assert brute_force(problem) is None
    doc["tasks"][2]["uses"] = {"power": 55}  # c fits beside b: solvable
    relaxed = problem_from(doc)
    assert not infeasibility(relaxed, start_domains(relaxed))
    assert brute_force(relaxed) is not None


def test_tasks_over_a_third_of_a_capacity_run_two_at_a_time() -> None:
    """Tests that five mandatory tasks each needing 34 % of a multiple
    resource (so at most two run at once), in a window shorter than 2.5
    lengths, are proved infeasible without a solve; that a capacity step
    leaving one lane for a while is counted; and that the same tasks in
    a window of three lengths are planned."""
    # 5 x 34 x 7 = 1,190 of 1,700 units of energy in [10, 27): the
    # energetic test lets it pass, and no two are apart.
    doc = _crowded([{"power": 34}] * 5, window=(10, 27))
    plan = solve(problem_from(doc), time_limit=30)
    assert plan.status is SolveStatus.INFEASIBLE, plan
    assert plan.stats is not None and plan.stats.solver == "proof"
    detail = plan.why[0].detail
    assert "at most 2 of them can run at once on power" in detail, detail
    assert "need 35 time units in [10, 27), where 2 at a time have 34" in (
        detail
    ), detail
    # 35 of 40 lanes in [10, 30), but one lane holds three of the five:
    # 21 units.
    rounds = _crowded([{"power": 34}] * 5, window=(10, 30))
    problem = problem_from(rounds)
    proof = infeasibility(problem, start_domains(problem))
    assert proof, "three of five on two lanes"
    assert "3 of them must run one after the other: 21 time units in " in (
        proof[0].detail
    ), proof[0].detail
    roomy = _crowded([{"power": 34}] * 5, window=(10, 31))
    assert solve(problem_from(roomy), time_limit=30).status.has_plan
    # 50 until 20 holds one of them: 10 + 2 x 11 = 32 lanes of 35.
    stepped = _crowded([{"power": 34}] * 5, window=(10, 31))
    stepped["resources"]["multiple"] = {
        "power": {"steps": [[0, 100], [10, 50], [20, 100]]}
    }
    problem = problem_from(stepped)
    proof = infeasibility(problem, start_domains(problem))
    assert proof and "2 at a time have 32" in proof[0].detail, proof


def test_the_proofs_stop_when_told() -> None:
    """Tests that the interval sweeps give up without a proof once their
    ``stop`` says time is up (the solver then decides)."""
    problem = problem_from(_crowded([{"power": 34}] * 5, window=(10, 27)))
    domains = start_domains(problem)
    assert infeasibility(problem, domains)
    assert not infeasibility(problem, domains, stop=lambda: True)


@settings(COMMON, max_examples=150)
@given(doc=apart_docs(max_tasks=6, power=(3, 3.5, 4, 4.5, 5)))
def test_lanes_proof_never_rejects_a_feasible_problem(doc: dict) -> None:
    """Tests that with uses of a third to a half of a capacity (two or
    three at once) a proof of infeasibility is only ever given for a
    problem brute force cannot solve."""
    problem = decode_doc(doc)
    proof = infeasibility(problem, start_domains(problem))
    if proof:
        assert brute_force(problem) is None, proof


@settings(COMMON, max_examples=150)
@given(doc=apart_docs())
def test_apart_proof_never_rejects_a_feasible_problem(doc: dict) -> None:
    """Tests that on crowded multiple and binary resources a proof of
    infeasibility is only ever given for a problem brute force cannot
    solve."""
    problem = decode_doc(doc)
    proof = infeasibility(problem, start_domains(problem))
    if proof:
        assert brute_force(problem) is None, proof


# -- tight blocks that cannot hold ------------------------------------------


def _block(kind: str, scope: str = "both", **resources: object) -> dict:
    """``a -> b`` tight with offset -1: ``b`` starts one unit before ``a``
    ends, so the two overlap on whatever both use."""
    uses = {"binary": {"cam": 1}, "multiple": {"power": 4}}[kind]
    res = {"binary": ["cam"], "multiple": {"power": 6}}[kind]
    return {
        "horizon": 20,
        "resources": {kind: res, **resources},
        "tasks": [
            make_task("a", 3, uses=dict(uses)),
            make_task("b", 2, uses=dict(uses)),
            make_task("c", 2, uses=dict(uses)),
        ],
        "precedences": [_tight("a", "b", -1, scope=scope)],
    }


def test_tight_block_overlapping_on_a_binary_resource_is_left_out() -> None:
    """Tests that tasks whose tight block overlaps on a binary resource
    get no start time, the reason naming the resource, and no solve."""
    problem = problem_from(_block("binary"))
    conflicts = block_conflicts(problem)
    assert sorted(conflicts) == ["a", "b"]
    assert conflicts["a"][0] == "binary"
    assert "a and b overlap on cam" in conflicts["a"][1]
    domains = start_domains(problem)
    assert domains["a"].empty and domains["b"].empty
    assert not domains["c"].empty
    plan = solve(problem, explain=True)
    assert plan.status is SolveStatus.OPTIMAL
    assert plan.starts() == {"c": 0}
    assert {(b.task, b.cause) for b in plan.why} == {
        ("a", "binary"),
        ("b", "binary"),
    }
    assert plan.stats is not None and plan.stats.solver == "greedy"


def _beside_mandatory(mandatory_c: bool = True, clash: bool = False) -> dict:
    """``a`` mandatory; ``c`` (mandatory or not) fixed 6 units after it,
    ``b`` (worth 5) fixed 4 units after it for 10 units, both on the
    camera: ``b`` needs only ``a``, but every plan holds ``c`` too."""
    return make_doc(
        [
            make_task("a", 3, schedule_cost=0),
            make_task("b", 10, schedule_cost=5, uses={"cam": 1}),
            make_task(
                "c", 1, schedule_cost=0 if mandatory_c else 1, uses={"cam": 1}
            ),
            make_task("d", 2, schedule_cost=0, uses={"cam": 1}),
        ],
        horizon=16,
        resources={"binary": ["cam"]},
        precedences=[
            _tight("a", "b", 1, scope="at_least_first"),
            _tight("a", "c", 3, scope="at_least_first"),
            # d and c overlap: the tasks every plan holds conflict.
            *([_tight("c", "d", -1)] if clash else []),
        ],
    )


def test_a_block_beside_tasks_every_plan_holds_is_impossible() -> None:
    """Tests that a task whose tight block with a mandatory task holds
    another mandatory one it overlaps is impossible, the reason naming
    what every plan holds, and the solve proves its plan at once."""
    problem = problem_from(_beside_mandatory())
    conflicts = block_conflicts(problem)
    assert sorted(conflicts) == ["b"]
    cause, why = conflicts["b"]
    assert cause == "binary"
    assert "b and c overlap on cam" in why and "every plan holds c" in why
    assert start_domains(problem)["b"].empty
    plan = solve(problem, time_limit=5)
    assert plan.status is SolveStatus.OPTIMAL
    assert plan.unscheduled == ("b",)
    best = brute_force(problem)
    assert best is not None and plan.objective is not None
    assert plan.objective.total == best[0].total


def test_a_block_beside_an_optional_task_stays_possible() -> None:
    """Tests that the same block is no proof when the task it overlaps may
    be left out, nor when the tasks every plan holds conflict among
    themselves (the problem is infeasible, said once, by the proofs)."""
    assert block_conflicts(problem_from(_beside_mandatory(False))) == {}
    clashing = problem_from(_beside_mandatory(clash=True))
    assert "b" not in block_conflicts(clashing)
    assert infeasibility(clashing, start_domains(clashing))


def test_at_least_first_block_leaves_the_first_task_free() -> None:
    """Tests that with scope ``at_least_first`` only the follower is
    impossible: the first task may run alone."""
    problem = problem_from(_block("binary", "at_least_first"))
    assert sorted(block_conflicts(problem)) == ["b"]
    plan = solve(problem)
    assert plan.status is SolveStatus.OPTIMAL
    assert set(plan.starts()) == {"a", "c"}


def test_tight_block_over_a_multiple_capacity() -> None:
    """Tests that block members using more than a multiple resource's
    capacity at once are impossible, and mandatory ones infeasible."""
    problem = problem_from(_block("multiple"))
    conflicts = block_conflicts(problem)
    assert sorted(conflicts) == ["a", "b"]
    assert conflicts["b"][0] == "multiple"
    assert "use 8 power at once, over its capacity 6" in conflicts["b"][1]
    doc = _block("multiple")
    doc["tasks"][1]["schedule_cost"] = 0
    plan = solve(problem_from(doc))
    assert plan.status is SolveStatus.INFEASIBLE
    assert plan.stats is not None and plan.stats.solver == "proof"
    assert [b.cause for b in plan.why] == ["multiple", "multiple"]
    # Apart by one unit (offset 0) they fit: no proof.
    doc["precedences"][0]["offset"] = 0
    assert block_conflicts(problem_from(doc)) == {}


def test_block_reaches_through_lax_needs_and_checks_lax_gaps() -> None:
    """Tests that a block is formed among everything a task needs, lax
    links included, and that a lax precedence it breaks is a proof."""
    doc = {
        "horizon": 30,
        "tasks": [make_task(n, 2) for n in "abcd"],
        "precedences": [
            _tight("a", "b", 0),  # s_b = s_a + 2
            {"before": "b", "after": "a", "kind": "lax"},  # s_a >= s_b + 2
            # d needs c (lax), c needs nothing: no block, no proof.
            {"before": "c", "after": "d", "kind": "lax", "offset": 5},
        ],
    }
    conflicts = block_conflicts(problem_from(doc))
    assert sorted(conflicts) == ["a", "b"]
    assert conflicts["a"][0] == "precedence"
    assert "a lax one needs at least 2" in conflicts["a"][1]


@settings(COMMON, max_examples=150)
@given(doc=problem_docs(max_tasks=4, max_horizon=7))
def test_block_conflicts_never_remove_a_schedulable_task(doc: dict) -> None:
    """Tests that no task a block proof removes is in any feasible plan
    (brute force with that task made mandatory finds none)."""
    problem = decode_doc(doc)
    for name in block_conflicts(problem):
        forced = problem.replace(
            tasks=tuple(
                msgspec.structs.replace(t, schedule_cost=0)
                if t.id == name
                else t
                for t in problem.tasks
            )
        )
        assert brute_force(forced) is None, (name, doc)


@settings(COMMON, max_examples=300)
@given(doc=problem_docs(max_tasks=4, max_horizon=8, capacities=True))
def test_proofs_never_reject_a_feasible_problem_with_stores(doc: dict) -> None:
    """Tests that a cheap proof of infeasibility (the store test among
    them: consumables with a capacity) agrees with brute force."""
    problem = decode_doc(doc)
    proof = infeasibility(problem, start_domains(problem))
    if proof:
        assert brute_force(problem) is None, proof


def _store_day(units: int) -> dict:
    """A forced consumer of 2 a unit for ``units`` units, a store of 10
    (initial 5) charged 1 a unit from outside from unit 10 on, and a
    generator that shares its camera (it cannot run beside it)."""
    return make_doc(
        [
            make_task(
                "use", units, schedule_cost=0, uses={"cam": 1, "bat": 2}
            ),
            make_task("gen", 20, uses={"cam": 1, "bat": -1}),
        ],
        horizon=80,
        resources={
            "binary": ["cam"],
            "consumable": {
                "bat": {"initial": 5, "max": 10, "external": [[10, 1]]}
            },
        },
    )


def test_a_consumer_that_drains_more_than_the_store_holds_is_refused() -> None:
    """Tests that a forced consumer taking more in its run than the store
    can hold plus what can come in meanwhile is proved impossible at once
    (fuzz case 11021: CBC had not proved it in 20 s), and that one unit
    less is not claimed (the store refills to 10 before it, and the
    outside charge gives 10 more while it runs)."""
    problem = problem_from(_store_day(11))
    proof = infeasibility(problem, start_domains(problem))
    assert [b.task for b in proof] == ["use"]
    assert proof[0].cause == "consumable"
    assert "more than the store holds (10)" in proof[0].detail
    plan = solve(problem, time_limit=5)
    assert plan.status is SolveStatus.INFEASIBLE
    assert plan.stats is not None and plan.stats.solver == "proof"
    fits = problem_from(_store_day(10))
    assert infeasibility(fits, start_domains(fits)) == ()
    assert solve(fits, time_limit=5).status is SolveStatus.OPTIMAL


@st.composite
def _store_docs(draw: st.DrawFn) -> dict:
    """A small day around one store with a capacity: a forced consumer,
    optional generators (some on its camera), an outside charge."""
    horizon = draw(st.integers(4, 9))
    initial = draw(st.integers(0, 4))
    store: dict = {
        "initial": initial,
        "max": initial + draw(st.integers(0, 2)),
    }
    if draw(st.booleans()):
        store["external"] = [
            [draw(st.integers(0, horizon - 1)), draw(st.sampled_from([1, 2]))]
        ]
    tasks = [
        make_task(
            "use",
            draw(st.integers(1, min(4, horizon))),
            schedule_cost=0,
            uses={
                "bat": draw(st.integers(1, 3)),
                "cam": draw(st.integers(0, 1)),
            },
        )
    ]
    for k in range(draw(st.integers(0, 2))):
        tasks.append(
            make_task(
                f"gen{k}",
                draw(st.integers(1, 3)),
                uses={
                    "bat": -draw(st.integers(1, 2)),
                    "cam": draw(st.integers(0, 1)),
                },
            )
        )
    return make_doc(
        tasks,
        horizon=horizon,
        resources={"binary": ["cam"], "consumable": {"bat": store}},
    )


@settings(COMMON, max_examples=300)
@given(doc=_store_docs())
def test_the_store_test_never_rejects_a_feasible_day(doc: dict) -> None:
    """Tests the store test against brute force on days built around it:
    a proof only where no plan exists."""
    problem = decode_doc(doc)
    proof = infeasibility(problem, start_domains(problem))
    if proof:
        assert brute_force(problem) is None, (proof, doc)
