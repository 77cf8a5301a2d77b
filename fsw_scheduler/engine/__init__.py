"""The functional core: events in, commands out.

:class:`Engine` never solves, publishes or reads the clock; the shell
does the I/O its commands ask for. The names below are the engine's
vocabulary, so ``from fsw_scheduler.engine import Engine, Tick`` works.
"""

from .config import EngineConfig as EngineConfig
from .core import (
    Engine as Engine,
)
from .events import ClockStalled as ClockStalled
from .events import Command as Command
from .events import Event as Event
from .events import Explained as Explained
from .events import ForecastArrived as ForecastArrived
from .events import GoalArrived as GoalArrived
from .events import InputRejected as InputRejected
from .events import LevelArrived as LevelArrived
from .events import Log as Log
from .events import Publish as Publish
from .events import ReportArrived as ReportArrived
from .events import SolveDone as SolveDone
from .events import SolveFailed as SolveFailed
from .events import StartExplain as StartExplain
from .events import StartSolve as StartSolve
from .events import Tick as Tick
from .solves import problem_hash as problem_hash
