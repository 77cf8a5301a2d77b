"""Time-indexed ILP of the scheduling problem, built with PuLP.

The model is split the way the problem is read: :mod:`.variables` (step
variables over each task's start domain), :mod:`.constraints` (one method
per constraint family), :mod:`.objective` (the lexicographic objective) and
:mod:`.model` (build, run CBC or HiGHS, map the solver's status).
"""

from .model import SOLVERS as SOLVERS
from .model import backend_ready as backend_ready
from .model import solve_ilp as solve_ilp
