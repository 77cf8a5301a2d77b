"""fsw_scheduler: on-board activity scheduler for spacecraft.

The public API: decode a :class:`Problem`, :func:`solve` it into a
:class:`Plan`, check it with :func:`fsw_scheduler.check.check_plan`.
Importing the package imports neither PuLP nor Zenoh.
"""

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
from .model import (
    Precedence as Precedence,
)
from .model import (
    Problem as Problem,
)
from .model import (
    Resources as Resources,
)
from .model import (
    Task as Task,
)
from .model import (
    decode_problem as decode_problem,
)
from .solution import (
    Activity as Activity,
)
from .solution import (
    Objective as Objective,
)
from .solution import (
    Plan as Plan,
)
from .solution import (
    SolveStatus as SolveStatus,
)
from .solve import solve as solve

__version__ = "0.1.0"
