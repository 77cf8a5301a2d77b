"""The functional core: events in, commands out.

:class:`Engine` never solves, publishes or reads the clock; the shell
does the I/O its commands ask for. The names below are the engine's
vocabulary, so ``from fsw_scheduler.engine import Engine, Tick`` works.
"""

from .core import (
    ClockStalled as ClockStalled,
)
from .core import (
    Command as Command,
)
from .core import (
    Engine as Engine,
)
from .core import (
    EngineConfig as EngineConfig,
)
from .core import (
    Event as Event,
)
from .core import (
    Explained as Explained,
)
from .core import (
    GoalArrived as GoalArrived,
)
from .core import (
    InputRejected as InputRejected,
)
from .core import (
    LevelArrived as LevelArrived,
)
from .core import (
    Log as Log,
)
from .core import (
    Publish as Publish,
)
from .core import (
    ReportArrived as ReportArrived,
)
from .core import (
    SolveDone as SolveDone,
)
from .core import (
    SolveFailed as SolveFailed,
)
from .core import (
    StartExplain as StartExplain,
)
from .core import (
    StartSolve as StartSolve,
)
from .core import (
    Tick as Tick,
)
from .core import (
    problem_hash as problem_hash,
)
