"""The node's policy, without Zenoh: settings to engine, solve, explain.

One mapping from the node's settings to what decides: the engine's
settings (:func:`engine_config`), the journal's record of them
(:func:`node_info`) and back (:func:`config_from_info`, for replay), and
the solve and explanation calls (:func:`run_solve`, :func:`run_explain`).
The bus node and deterministic replay both call these, so that
``replay --verify`` runs the same decisions without importing Zenoh.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

import msgspec

from ..engine.config import EngineConfig
from ..solving.budget import BUDGET
from ..wire import messages

if TYPE_CHECKING:
    from collections.abc import Mapping

    from ..engine.events import (
        StartSolve,
    )
    from ..model.plan import Blocker, Plan
    from ..model.problem import Problem
    from ..model.stability import Stability
    from .config import NodeConfig


def engine_config(config: NodeConfig) -> EngineConfig:
    """The engine settings carried by a node configuration."""
    return EngineConfig(
        report_timeout=config.report_timeout,
        tolerance=config.tolerance,
        heartbeat=config.heartbeat,
        replan_lead=config.lead,
        max_tasks_per_goal=config.tasks_per_goal,
        max_live_tasks=config.live_tasks,
        max_goals_waiting=config.goals_waiting,
        max_goals_per_solve=config.goals_per_solve,
        node_id=config.node_id,
        explain_after_plan=config.explain and config.explain_after_plan,
        max_goal_ids=config.goal_ids,
        reports_need_dispatch=config.reports_need_dispatch,
        report_ahead=config.report_ahead,
        cancel_timeout=config.cancel_timeout,
        commit_window=config.commit_window,
        stability=config.stability,
        move_cost=config.move_cost,
        early_completion_gain=config.early_completion_gain,
        late_completion=config.late_completion,
    )


#: NodeInfo fields that are not node settings.
_NOT_SETTINGS = frozenset(
    {"version", "problem", "security", "resumed", "durable"}
)
#: NodeInfo fields named otherwise in NodeConfig (info name -> config name).
_RENAMED = {"time_limit_s": "time_limit"}
#: Settings that change decisions but are not NodeInfo fields (its schema
#: is a recorded format): the journal keeps them in its
#: ``fsw_scheduler.settings`` metadata, which replay reads back.
IN_METADATA = (
    "threads",
    "commit_window",
    "stability",
    "move_cost",
    "early_completion_gain",
    "late_completion",
)


def _setting_fields() -> list[tuple[str, str]]:
    """(NodeInfo field, NodeConfig field) of every recorded setting."""
    return [
        (name, _RENAMED.get(name, name))
        for name in messages.NodeInfo.__struct_fields__
        if name not in _NOT_SETTINGS
    ]


def node_info(
    config: NodeConfig,
    problem: Problem,
    security: messages.SecurityInfo | None = None,
    *,
    resumed: str = "",
) -> messages.NodeInfo:
    """What a recording needs to replay this node's decisions.

    ``resumed``: the status event (``resumed``, ``took_over``) a node
    whose state was rebuilt starts with (replay then expects it first).
    """
    from .. import __version__

    values = {info: getattr(config, name) for info, name in _setting_fields()}
    # The replan lead as resolved (its default depends on the clock).
    values["replan_lead"] = config.lead
    return messages.NodeInfo(
        **values,
        version=__version__,
        problem=problem,
        resumed=resumed,
        security=security,
    )


def config_from_info(
    info: messages.NodeInfo, settings: Mapping[str, str] | None = None
) -> NodeConfig:
    """The node configuration a journal was made with.

    Parameters
    ----------
    info
        The journal's ``scheduler/config`` message.
    settings
        The journal's ``fsw_scheduler.settings`` metadata, if it has one:
        the settings of :data:`IN_METADATA` come from there (a journal
        without it was made with their defaults, one solver thread).
    """
    from .config import NodeConfig

    values: dict[str, Any] = {
        name: getattr(info, field) for field, name in _setting_fields()
    }
    recorded = settings or {}
    # Metadata values are text, under the settings' kebab-case names.
    kebab = {
        name.replace("_", "-"): recorded[name.replace("_", "-")]
        for name in IN_METADATA
        if recorded.get(name.replace("_", "-"))
    }
    if recorded.get("threads"):
        kebab["threads"] = recorded["threads"]
    if kebab:
        read = msgspec.convert(kebab, NodeConfig, strict=False)
        values.update(
            {
                name: getattr(read, name)
                for name in IN_METADATA
                if name.replace("_", "-") in kebab
            }
        )
    return NodeConfig(**values)


def deadline_config(
    config: NodeConfig, waited_s: list[float], goals_waiting: int
) -> NodeConfig:
    """The settings of a solve: its limit cut to its goals' deadline.

    The response deadline runs from the arrival of the oldest goal of the
    solve (``waited_s``: how long each has waited); decoding, merging and
    waiting behind another solve came out of it already, the start plan,
    model and solver share the rest (less a margin to publish) with the
    solves that the ``goals_waiting`` queued behind this one will need.
    """
    if config.response_deadline is None or not waited_s:
        return config
    left = config.response_deadline - max(waited_s)
    # Goals queued behind this solve need solves of their own within
    # their deadlines: each batch gets an equal share of what is left.
    batches = -(-goals_waiting // config.goals_per_solve)
    limit = BUDGET.deadline_limit(left, batches, config.time_limit)
    if limit == config.time_limit:
        return config
    return config.replace(time_limit=limit)


def stability_of(config: NodeConfig, command: StartSolve) -> Stability:
    """The move term of ``command``'s solve under the node's settings
    (mode ``off``: none)."""
    from ..model.stability import Stability

    return Stability(
        previous=dict(command.previous),
        mode=config.stability,
        move_cost=config.move_cost,
    )


def run_solve(config: NodeConfig, command: StartSolve) -> Plan:
    """Solve as the node does (shared with deterministic replay).

    With ``explain_after_plan`` a plan comes back unexplained (the node
    explains it once published); a solve that gives no plan is explained
    here, since the rejection it causes names the blockers.
    """
    from ..solving.solve import solve

    later = config.explain_after_plan
    plan = solve(
        command.problem,
        config.solver,
        time_limit=config.time_limit,
        threads=config.threads,
        seed=config.seed,
        # The shedding solve explains at once: its alarm must say why.
        explain=(config.explain and not later) or command.explain,
        warm=command.warm,
        explain_budget=config.explain_budget,
        stability=stability_of(config, command),
    )
    if config.explain and later and not plan.status.has_plan:
        plan = plan.replace(why=run_explain(config, command.problem, plan))
    return plan


def run_explain(
    config: NodeConfig, problem: Problem, plan: Plan
) -> tuple[Blocker, ...]:
    """Why tasks of ``plan`` are out, within ``config.explain_budget``."""
    from ..analysis.explain import explain
    from ..solving.ilp import solve_ilp

    def run(relaxed: Problem, time_limit: float) -> Plan:
        return solve_ilp(
            relaxed,
            config.solver,
            time_limit=time_limit,
            threads=config.threads,
            seed=config.seed,
        )

    return explain(problem, plan, BUDGET.budgeted(run, config.explain_budget))
