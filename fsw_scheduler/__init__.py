"""fsw_scheduler: on-board activity scheduler for spacecraft.

The public API: :func:`solve` a problem into a :class:`Plan`,
:func:`check_plan` a plan independently of the solver, :func:`replan` a
running plan when a goal or an event arrives. Each takes the typed
objects, plain dicts or JSON text (:mod:`fsw_scheduler.api`); a plan
gives itself back as :meth:`Plan.to_dict` or :meth:`Plan.to_json`.
Importing the package imports neither PuLP nor Zenoh.
"""

from .analysis.check import CheckReport as CheckReport
from .api import (
    as_change as as_change,
)
from .api import (
    as_plan as as_plan,
)
from .api import (
    as_problem as as_problem,
)
from .api import (
    check_plan as check_plan,
)
from .api import (
    replan as replan,
)
from .api import (
    solve as solve,
)
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
