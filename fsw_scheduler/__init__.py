"""fsw_scheduler: on-board activity scheduler for spacecraft.

The public API: :func:`solve` a problem into a :class:`Plan`,
:func:`check_plan` a plan independently of the solver, :func:`replan` a
running plan when a goal or an event arrives. Each takes the typed
objects, plain dicts or JSON text (:mod:`fsw_scheduler.api`); a plan
gives itself back as :meth:`Plan.to_dict` or :meth:`Plan.to_json`.
Importing the package imports neither PuLP nor Zenoh.
"""

from __future__ import annotations

import sys
import types
from typing import TYPE_CHECKING

from .errors import (
    BusError as BusError,
)
from .errors import (
    ConfigError as ConfigError,
)
from .errors import (
    FieldIssue as FieldIssue,
)
from .errors import (
    InputError as InputError,
)
from .errors import (
    SchedulerError as SchedulerError,
)
from .errors import (
    SolverError as SolverError,
)

if TYPE_CHECKING:
    from .analysis.check import CheckReport as CheckReport
    from .api import as_change as as_change
    from .api import as_plan as as_plan
    from .api import as_problem as as_problem
    from .api import check_plan as check_plan
    from .api import replan as replan
    from .api import solve as solve
    from .model.change import decode_change as decode_change
    from .model.goal import Goal as Goal
    from .model.goal import decode_goal as decode_goal
    from .model.plan import Activity as Activity
    from .model.plan import Objective as Objective
    from .model.plan import Plan as Plan
    from .model.plan import SolveStatus as SolveStatus
    from .model.problem import Consumable as Consumable
    from .model.problem import Precedence as Precedence
    from .model.problem import Problem as Problem
    from .model.problem import Resources as Resources
    from .model.problem import Task as Task
    from .model.problem import decode_problem as decode_problem
    from .replan.diff import PlanDiff as PlanDiff

__version__ = "0.1.0"

_API = ("as_change", "as_plan", "as_problem", "check_plan", "solve")
_PLAN = ("Activity", "Objective", "Plan", "SolveStatus")
_PROBLEM = (
    "Consumable",
    "Precedence",
    "Problem",
    "Resources",
    "Task",
    "decode_problem",
)


def __getattr__(name: str) -> object:
    """The public names, imported when first used (PEP 562).

    ``import fsw_scheduler`` (and so every command line run) loads only
    the exception tree; the solver's and the model's modules come with
    the first name that needs them.
    """
    module: object
    if name in _API:
        from . import api as module
    elif name in _PLAN:
        from .model import plan as module
    elif name in _PROBLEM:
        from .model import problem as module
    elif name in ("Goal", "decode_goal"):
        from .model import goal as module
    elif name == "decode_change":
        from .model import change as module
    elif name == "CheckReport":
        from .analysis import check as module
    elif name == "PlanDiff":
        from .replan import diff as module
    else:
        raise AttributeError(
            f"module 'fsw_scheduler' has no attribute {name!r}"
        )
    value = getattr(module, name)
    globals()[name] = value
    return value


def __dir__() -> list[str]:
    """Every public name, loaded or not yet."""
    return sorted({*globals(), *__all__})


class _Package(types.ModuleType):
    """The package's module type: ``fsw_scheduler.replan`` is the function.

    The subpackage of the same name (``fsw_scheduler.replan.rules``, ...)
    is reached through ``sys.modules`` as always; importing it would set
    the attribute to the subpackage, which an eager ``from .api import
    replan`` used to overwrite. Lazily, the function must win whatever
    was imported first: a property, whose setter keeps the subpackage
    aside.
    """

    @property
    def replan(self) -> object:
        from .api import replan

        return replan

    @replan.setter
    def replan(self, module: object) -> None:
        self.__dict__["_replan_package"] = module


sys.modules[__name__].__class__ = _Package

__all__ = [
    "Activity",
    "BusError",
    "CheckReport",
    "ConfigError",
    "Consumable",
    "FieldIssue",
    "Goal",
    "InputError",
    "Objective",
    "Plan",
    "PlanDiff",
    "Precedence",
    "Problem",
    "Resources",
    "SchedulerError",
    "SolveStatus",
    "SolverError",
    "Task",
    "as_change",
    "as_plan",
    "as_problem",
    "check_plan",
    "decode_change",
    "decode_goal",
    "decode_problem",
    "replan",
    "solve",
]
