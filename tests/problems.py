"""Random problems valid by construction, and a brute-force oracle.

Problems are generated valid by construction (every window holds at
least one start inside the horizon, pins sit on such a start); only
contradictory tight-precedence cycles are filtered out. The exhaustive
enumeration is written from the problem format alone: it shares no code
with the checker or the ILP, so it can judge both.
"""

from __future__ import annotations

import itertools
import json
import math
from typing import TYPE_CHECKING

from hypothesis import HealthCheck, assume, settings
from hypothesis import strategies as st

from fsw_scheduler.analysis.check import check_plan
from fsw_scheduler.analysis.domains import start_domains
from fsw_scheduler.errors import InputError
from fsw_scheduler.model.plan import Activity, Objective, Plan, SolveStatus
from fsw_scheduler.model.problem import decode_problem
from fsw_scheduler.solving.ilp.model import in_symmetry_order

if TYPE_CHECKING:
    from collections.abc import Collection, Iterable, Iterator, Sequence

    from fsw_scheduler.model.problem import Problem, Task
    from fsw_scheduler.model.stability import Stability

TOLERANCE = 1e-9
Assignment = dict[str, int | None]

# Binary fractions only: the solvers' feasibility tolerances (~1e-7) must
# not turn a rounding error into a reported "bug".
CAPACITIES = (0, 1, 2, 3, 4.5, 6, 10)
MULTIPLE_USES = (0, 1, 2, 2.5, 3, 5)
LEVELS = (0, 1, 2, 4, 6, 8, 12.5)
CONSUMABLE_USES = (-3, -1, -0.5, 1, 1.5, 2, 4)
#: With capacities: small stores, often full from the start (room 0), so
#: that generation is lost unless a consumer runs with it (None: the
#: object form without ``max``), and uses that generate as often as they
#: consume.
CAPPED_LEVELS = (1, 0, 2, 4)
HEADROOM = (0, 1, None, 2.5, 0.5)
CAPPED_USES = (-2, 3, -4, 1.5, -1, 4, 2)

COMMON = settings(
    deadline=None,
    derandomize=True,
    suppress_health_check=[HealthCheck.too_slow],
)


# --------------------------------------------------------------------------
# Problem generation


@st.composite
def problem_docs(
    draw: st.DrawFn,
    max_tasks: int = 6,
    max_horizon: int = 20,
    capacities: bool = False,
) -> dict:
    """Draw a problem document that passes validation (up to tight cycles).

    Parameters
    ----------
    draw
        Hypothesis' draw function.
    max_tasks
        At most this many tasks (at least one).
    max_horizon
        At most this many time units (at least one).
    capacities
        Also draw consumables in the object form, mostly with a capacity
        (``max``) at or a little above the initial level. Without it the
        draws are the same as before capacities existed.

    Returns
    -------
    dict
        A problem document of the problem format.
    """
    # With capacities: room for a charge and a draw one after the other.
    horizon = draw(
        st.integers(min(4, max_horizon) if capacities else 1, max_horizon)
    )
    start = draw(st.integers(0, 3))
    end = start + horizon
    names = st.sampled_from
    # With capacities: one consumable and one binary resource, which
    # orders the tasks using it (a charge before a draw is what a full
    # store can lose); three tasks in four use each. Shorter tasks, fewer
    # windows and precedences and no pins leave room for such orders.
    binary: list[str] = ["b0"] if capacities else []
    multiple: dict[str, float] = {}
    if not capacities:
        binary = draw(st.lists(names(["b0", "b1"]), unique=True, max_size=2))
        multiple = draw(
            st.dictionaries(names(["m0", "m1"]), names(CAPACITIES), max_size=2)
        )
    consumable: dict = (
        {"c0": draw(names(CAPPED_LEVELS))}
        if capacities
        else draw(
            st.dictionaries(names(["c0", "c1"]), names(LEVELS), max_size=2)
        )
    )
    if capacities:
        for name, level in consumable.items():
            room = draw(names(HEADROOM))
            if room is not None:
                consumable[name] = {"initial": level, "max": level + room}
            elif draw(st.booleans()):
                consumable[name] = {"initial": level}
    consumable_uses = CAPPED_USES if capacities else CONSUMABLE_USES
    reading = draw(names(["task", "start"]))
    # Hypothesis favours the first choice; more tasks exercise more rules.
    num_tasks = draw(names(range(max_tasks, 0, -1)))
    tasks = []
    for idx in range(num_tasks):
        length = draw(st.integers(1, min(horizon, 3 if capacities else 5)))
        # A start that every generated constraint of this task admits.
        anchor = draw(st.integers(start, end - length))
        task: dict = {
            "id": f"t{idx}",
            "length": length,
            "delay_cost": draw(st.integers(1, 5)),
            "schedule_cost": draw(names([3, 1, 2, 4, 5, 0])),
            "preemption": draw(
                names(["none", "from_start", "from_interrupt", "delete"])
            ),
        }
        uses: dict[str, float] = {}
        for name in binary:
            if draw(st.integers(0, 3) if capacities else st.booleans()):
                uses[name] = 1
        for name in multiple:
            if draw(st.booleans()):
                uses[name] = draw(names(MULTIPLE_USES))
        for name in consumable:
            if draw(st.integers(0, 3) if capacities else st.booleans()):
                uses[name] = draw(names(consumable_uses))
        if uses:
            task["uses"] = uses
        window = draw(
            names(
                [None, "inherit", None, "task"]
                if capacities
                else [None, "inherit", "task", "start"]
            )
        )
        if window is not None:
            own = reading if window == "inherit" else window
            low = draw(st.integers(max(0, anchor - 3), anchor))
            first_end = anchor + length if own == "task" else anchor
            high = draw(st.integers(first_end, first_end + 3))
            task["feasible_interval"] = [low, high]
            if window != "inherit":
                task["feasible_interval_applies_to"] = own
        if not capacities and draw(st.integers(0, 9)) == 0:
            task["fixed_start"] = anchor
        tasks.append(task)
    precedences = []
    if num_tasks >= 2:
        num_precedences = draw(
            names([0, 1, 2] if capacities else [2, 3, 4, 1, 0])
        )
        for _ in range(min(num_precedences, num_tasks + 1)):
            before, after = draw(
                st.lists(
                    st.integers(0, num_tasks - 1),
                    min_size=2,
                    max_size=2,
                    unique=True,
                )
            )
            precedences.append(
                {
                    "before": f"t{before}",
                    "after": f"t{after}",
                    "kind": draw(names(["tight", "lax"])),
                    "scope": draw(names(["both", "at_least_first"])),
                    "offset": draw(st.integers(-3, 3)),
                }
            )
    return {
        "horizon": horizon,
        "start": start,
        "feasible_interval_applies_to": reading,
        "resources": {
            "binary": binary,
            "multiple": multiple,
            "consumable": consumable,
        },
        "tasks": tasks,
        "precedences": precedences,
    }


@st.composite
def apart_docs(
    draw: st.DrawFn,
    max_tasks: int = 5,
    power: tuple[float, ...] = (6, 4, 5.5, 7, 3, 10),
) -> dict:
    """Draw a problem of mostly mandatory tasks that crowd one window on a
    multiple resource (uses above and below half its capacity) and a
    binary one: the shapes the "no two at once" proofs look at.

    Parameters
    ----------
    draw
        Hypothesis' draw function.
    max_tasks
        At most this many tasks (at least two).
    power
        The uses of ``power`` (capacity 10) drawn from.

    Returns
    -------
    dict
        A problem document of the problem format.
    """
    horizon = draw(st.integers(4, 9))
    num_tasks = draw(st.integers(2, max_tasks))
    tasks = []
    for idx in range(num_tasks):
        length = draw(st.integers(1, 3))
        uses: dict[str, float] = {}
        if draw(st.integers(0, 3)):
            uses["power"] = draw(st.sampled_from(power))
        if draw(st.integers(0, 3)) == 0:
            uses["cam"] = 1
        task: dict = {
            "id": f"t{idx}",
            "length": length,
            "delay_cost": 1,
            "schedule_cost": draw(st.sampled_from([0, 0, 1])),
        }
        if uses:
            task["uses"] = uses
        if draw(st.booleans()):
            low = draw(st.integers(0, horizon - length))
            high = draw(st.integers(low + length, horizon))
            task["feasible_interval"] = [low, high]
            task["feasible_interval_applies_to"] = "task"
        tasks.append(task)
    return {
        "horizon": horizon,
        "resources": {"binary": ["cam"], "multiple": {"power": 10}},
        "tasks": tasks,
    }


@st.composite
def mission_docs(
    draw: st.DrawFn, max_tasks: int = 5, max_horizon: int = 8
) -> dict:
    """A :func:`problem_docs` problem with every field of the mission model.

    Added to the drawn problem: a binary resource ``w0`` with availability
    windows, a multiple resource ``s0`` with capacity steps, a consumable
    ``e0`` with an external rate (sometimes a capacity), each used by some
    tasks, and (with two tasks or more) a group of two options of one or
    two tasks each, whose members mostly leave their cost out.
    """
    names = st.sampled_from
    doc = draw(problem_docs(max_tasks=max_tasks, max_horizon=max_horizon))
    start, end = doc["start"], doc["start"] + doc["horizon"]
    first = draw(st.integers(start - 1, start + 2))
    windows = [[first, draw(st.integers(first + 1, max(first + 1, end + 1)))]]
    if draw(st.booleans()) and windows[0][1] + 1 < end:
        again = draw(st.integers(windows[0][1] + 1, end - 1))
        windows.append([again, again + draw(st.integers(1, 3))])
    steps: list[list[int]] = [[draw(names([start, start - 1])), 0]]
    if end - 1 > start:
        later = st.lists(st.integers(start + 1, end - 1), max_size=2)
        steps += [[t, 0] for t in sorted(set(draw(later)))]
    for step in steps:
        step[1] = draw(names([2, 1, 3, 0, 4]))
    external = [
        [draw(names([start, start + 2])), draw(names([1, -1, 0.5, 2]))]
    ]
    if draw(st.booleans()):
        external.append([external[0][0] + 3, draw(names([0, -1, 1]))])
    store: dict = {"initial": draw(names([2, 0, 4, 1])), "external": external}
    if draw(st.booleans()):
        store["max"] = store["initial"] + draw(names([0, 1, 3]))
    resources = doc["resources"]
    resources["binary"] = {
        **{name: {} for name in resources["binary"]},
        "w0": {"available": windows},
    }
    resources["multiple"]["s0"] = {"steps": steps}
    resources["consumable"]["e0"] = store
    for task in doc["tasks"]:
        uses = task.setdefault("uses", {})
        if task["schedule_cost"] == 0 or "fixed_start" in task:
            continue  # a task every plan holds: keep most problems feasible
        if draw(st.integers(0, 2)) == 0:
            uses["w0"] = 1
        if draw(st.booleans()):
            uses["s0"] = draw(names([1, 2, 3]))
        if draw(st.integers(0, 2)) == 0:
            uses["e0"] = draw(names([1, 2, -1]))
    ids = [task["id"] for task in doc["tasks"]]
    if len(ids) >= 2:
        picked = draw(st.permutations(ids))
        split = draw(st.integers(1, max(1, min(2, len(ids) - 1))))
        rest = picked[split:][: draw(st.integers(1, 2))]
        cost = draw(names([3, 1, 0]))
        doc["alternatives"] = [
            {
                "id": "g0",
                "schedule_cost": cost,
                "options": [picked[:split], rest],
            }
        ]
        for task in doc["tasks"]:
            if task["id"] in picked[:split] or task["id"] in rest:
                task["schedule_cost"] = cost
                if draw(st.booleans()):
                    del task["schedule_cost"]
    return doc


def decode_doc(doc: dict) -> Problem:
    """Decode ``doc``, discarding the example if validation rejects it."""
    try:
        return decode_problem(json.dumps(doc))
    except InputError:
        assume(False)
        raise  # unreachable: assume(False) raises


# --------------------------------------------------------------------------
# Brute force, from the problem format only


def reading(problem: Problem, task: Task) -> str:
    return task.feasible_interval_applies_to or (
        problem.feasible_interval_applies_to
    )


def start_ok(problem: Problem, task: Task, start: int) -> bool:
    """Horizon, feasible interval and pin for one task on its own."""
    if start < problem.start:
        return False
    if start + task.length > problem.start + problem.horizon:
        return False
    if task.fixed_start is not None and start != task.fixed_start:
        return False
    if task.feasible_interval is None:
        return True
    low, high = task.feasible_interval
    if reading(problem, task) == "task":
        return low <= start and start + task.length <= high
    return low <= start <= high


def joint_ok(problem: Problem, starts: Assignment) -> bool:
    """Precedences, scopes and the three resource kinds together."""
    lengths = {task.id: task.length for task in problem.tasks}
    for prec in problem.precedences:
        before, after = starts[prec.before], starts[prec.after]
        if prec.scope == "both" and (before is None) != (after is None):
            return False
        if after is not None and before is None:
            return False  # at_least_first (both is covered above)
        if before is None or after is None:
            continue
        target = before + lengths[prec.before] + prec.offset
        if prec.kind == "tight" and after != target:
            return False
        if prec.kind == "lax" and after < target:
            return False
    if not groups_ok(problem, starts):
        return False
    resources = problem.resources
    levels: dict[str, float] = {}
    tops: dict[str, float] = {}
    outside: dict[str, tuple[tuple[int, float], ...]] = {}
    for name, spec in resources.consumable.items():
        # The raw field: a number, or an object with initial, max and
        # external steps.
        if isinstance(spec, int | float):
            levels[name], tops[name] = spec, math.inf
            outside[name] = ()
        else:
            levels[name] = spec.initial
            tops[name] = math.inf if spec.max is None else spec.max
            outside[name] = spec.external
    for t in range(problem.start, problem.start + problem.horizon):
        use: dict[str, float] = {}
        for task in problem.tasks:
            start = starts[task.id]
            if start is None or not start <= t < start + task.length:
                continue
            for name, amount in task.uses.items():
                use[name] = use.get(name, 0) + amount
        for name in resources.binary:
            if use.get(name, 0) > (1 if open_at(problem, name, t) else 0):
                return False
        for name, capacity in resources.multiple.items():
            if not isinstance(capacity, int | float):
                capacity = step_at(capacity.steps, t)
            if use.get(name, 0) > capacity + TOLERANCE:
                return False
        for name in levels:
            # Net use of the unit, then the capacity: a full store loses
            # what it is offered beyond it.
            levels[name] = min(
                tops[name],
                levels[name] + step_at(outside[name], t) - use.get(name, 0),
            )
            if levels[name] < -TOLERANCE:
                return False
    return True


def step_at(steps: Iterable[Sequence[float]], t: int) -> float:
    """The value of the last step ``[t_k, v_k]`` at or before ``t``, 0
    before the first."""
    value = 0.0
    for since, amount in steps:
        if since <= t:
            value = amount
    return value


def open_at(problem: Problem, name: str, t: int) -> bool:
    """Whether binary ``name`` is available in unit ``t``."""
    binary = problem.resources.binary
    if not isinstance(binary, dict):
        return True
    available = binary[name].available
    if available is None:
        return True
    return any(a <= t < b for a, b in available)


def members_of(problem: Problem) -> set[str]:
    return {
        n for g in problem.alternatives for option in g.options for n in option
    }


def groups_ok(problem: Problem, starts: Assignment) -> bool:
    """All or none of an option, at most one option, mandatory groups."""
    for group in problem.alternatives:
        full = 0
        for option in group.options:
            placed = [starts[n] is not None for n in option]
            if any(placed) and not all(placed):
                return False
            full += all(placed)
        if full > 1 or (group.schedule_cost == 0 and full == 0):
            return False
    return True


def is_feasible(problem: Problem, starts: Assignment) -> bool:
    """Whether ``starts`` (task id to start, None = left out) is valid."""
    members = members_of(problem)
    for task in problem.tasks:
        start = starts[task.id]
        if start is None:
            if task.fixed_start is not None or (
                task.schedule_cost == 0 and task.id not in members
            ):
                return False
        elif not start_ok(problem, task, start):
            return False
    return joint_ok(problem, starts)


def objective_of(problem: Problem, starts: Assignment) -> Objective:
    weight = 1 + problem.horizon * sum(t.delay_cost for t in problem.tasks)
    members = members_of(problem)
    left_out = sum(
        t.schedule_cost
        for t in problem.tasks
        if starts[t.id] is None and t.id not in members
    )
    left_out += sum(
        g.schedule_cost
        for g in problem.alternatives
        if all(starts[n] is None for o in g.options for n in o)
    )
    delay = 0
    for t in problem.tasks:
        at = starts[t.id]
        if at is not None:
            delay += t.delay_cost * (at - problem.start)
    return Objective(left_out, delay, weight * left_out + delay)


def candidates(problem: Problem) -> Iterator[Assignment]:
    """Every assignment of a start (or None: left out) to each task whose
    start alone is valid (:func:`start_ok`), in a fixed order; the joint
    constraints (:func:`joint_ok`) are not checked. Exponential in the
    tasks: small problems only."""
    options = []
    members = members_of(problem)
    for task in problem.tasks:
        starts: list[int | None] = [
            s
            for s in range(problem.start, problem.start + problem.horizon)
            if start_ok(problem, task, s)
        ]
        if task.fixed_start is None and (
            task.schedule_cost != 0 or task.id in members
        ):
            starts.append(None)
        options.append(starts)
    ids = [task.id for task in problem.tasks]
    for combo in itertools.product(*options):
        yield dict(zip(ids, combo, strict=True))


def warm_starts(
    problem: Problem, twins: list[list[str]], limit: int = 40
) -> Iterator[dict[str, int]]:
    """Up to ``limit`` plans the exhaustive search accepts, as the solver
    hands a plan to CBC: the starts of the placed tasks, identical tasks'
    (``twins``, the model's) in problem order (:func:`in_symmetry_order`).
    """
    seen = 0
    for starts in candidates(problem):
        if seen >= limit:
            return
        if not is_feasible(problem, starts):
            continue
        seen += 1
        yield in_symmetry_order(
            twins, {k: v for k, v in starts.items() if v is not None}
        )


def row_holds(
    terms: dict[int, float], sense: str, rhs: float, values: Sequence[float]
) -> bool:
    """True if the program row ``terms (sense) rhs`` holds at ``values``."""
    total = sum(coef * values[col] for col, coef in terms.items())
    if sense == "L":
        return total <= rhs + 1e-6
    if sense == "G":
        return total >= rhs - 1e-6
    return abs(total - rhs) <= 1e-6


def brute_force(
    problem: Problem, stability: Stability | None = None
) -> tuple[Objective, Assignment] | None:
    """Enumerate every selection and start; return the best, if any.

    Parameters
    ----------
    problem
        A small problem (the enumeration is exponential in its tasks).
    stability
        Price moves from these previous starts (the objective of
        :mod:`fsw_scheduler.model.stability`); default: the paper's.

    Returns
    -------
    tuple of Objective and dict, or None
        The optimal objective and one optimal assignment (task id to start,
        None for left out), or None when no assignment is feasible.
    """
    best: tuple[Objective, Assignment] | None = None
    for starts_of in candidates(problem):
        objective = objective_of(problem, starts_of)
        if stability is not None:
            placed = {k: v for k, v in starts_of.items() if v is not None}
            objective = stability.objective(
                problem,
                objective.unscheduled_cost,
                objective.delay_cost,
                placed,
            )
        if best is not None and objective.total >= best[0].total:
            continue  # cheap bound before the costly feasibility walk
        if joint_ok(problem, starts_of):
            best = (objective, starts_of)
    return best


def assert_brute_force_optimum(
    doc: dict, problem: Problem, plan: Plan
) -> Objective | None:
    """Assert that ``plan`` is what exhaustive search finds: infeasible
    when no assignment is feasible, else optimal with the same total.

    Returns
    -------
    Objective or None
        The optimum (None when infeasible), for further checks.
    """
    best = brute_force(problem)
    if best is None:
        assert plan.status is SolveStatus.INFEASIBLE, show(doc, plan)
        return None
    objective, starts = best
    found = f"{show(doc, plan)}\nbrute force: {objective} {starts}"
    assert plan.status is SolveStatus.OPTIMAL, found
    assert plan.objective is not None, found
    assert plan.objective.total == objective.total, found
    return objective


def plan_of(problem: Problem, starts: Assignment) -> Plan:
    """The plan of ``starts`` in the plan format (groups listed by id)."""
    lengths = {task.id: task.length for task in problem.tasks}
    members = members_of(problem)
    left = [n for n, s in starts.items() if s is None and n not in members]
    left += [
        g.id
        for g in problem.alternatives
        if all(starts[n] is None for o in g.options for n in o)
    ]
    return Plan(
        SolveStatus.OPTIMAL,
        objective_of(problem, starts),
        tuple(
            Activity(name, s, s + lengths[name])
            for name, s in starts.items()
            if s is not None
        ),
        tuple(left),
    )


def at_earliest_but(problem: Problem, drop: Collection[int]) -> Plan | None:
    """The plan of every placeable task at its earliest start but those at
    the indexes ``drop`` (left out), if the checker accepts it; else
    None."""
    domains = start_domains(problem)
    plan = plan_of(
        problem,
        {
            t.id: None
            if k in drop or domains[t.id].empty
            else domains[t.id].earliest
            for k, t in enumerate(problem.tasks)
        },
    )
    return plan if check_plan(problem, plan).ok else None


def starts_of(problem: Problem, plan: Plan) -> Assignment:
    placed = {a.task: a.start for a in plan.activities}
    return {task.id: placed.get(task.id) for task in problem.tasks}


def show(doc: dict, *plans: Plan) -> str:
    text = [json.dumps(doc)]
    text += [json.dumps(plain(plan)) for plan in plans]
    return "\n".join(text)


def plain(plan: Plan) -> dict:
    return {
        "status": plan.status.value,
        "objective": None
        if plan.objective is None
        else {
            "unscheduled_cost": plan.objective.unscheduled_cost,
            "delay_cost": plan.objective.delay_cost,
            "total": plan.objective.total,
        },
        "activities": [[a.task, a.start, a.end] for a in plan.activities],
        "unscheduled": list(plan.unscheduled),
    }
