"""What a CBC log says: its seconds and bound, and what they are worth.

CBC writes its answer to a solution file and what it did to its log. The
log says more than the answer: the root LP before cuts (a valid bound
when CBC's own is not), whether its bound went above a plan it held
(:func:`_overshot`), whether it restarted on a reduced model that kept
its root cuts (:func:`restarted_with_cuts`), and whether it took the
MIP start as given (:func:`start_refused`). :mod:`.cbc` reads every run's
log through :func:`read_log`.
"""

from __future__ import annotations

import re
from pathlib import Path
from typing import NamedTuple

# Every objective coefficient is an integer, so an absolute gap below one
# already proves the optimum; a relative gap would stop early on the big
# weight of the lexicographic objective.
ABS_GAP = 0.5

_SECONDS = re.compile(r"Time \(Wallclock seconds\):\s+([0-9.eE+-]+)")
_BOUND = re.compile(r"Lower bound:\s+([0-9.eE+-]+)")
_NUMBER = r"([0-9.eE+-]+)"
_ROOT_CUTS = re.compile(
    r"At root node, \d+ cuts changed objective from "
    + _NUMBER
    + " to "
    + _NUMBER
)
_BEST_POSSIBLE = re.compile(r"best possible " + _NUMBER)
#: The model's size as CBC read it.
_MODEL_ROWS = re.compile(r"Problem \S+ has (\d+) rows")
#: CBC's restart on a reduced model (variables fixed by reduced cost):
#: the rows of the model it starts from.
_RESTART = re.compile(
    r"Full problem (\d+) rows \d+ columns, reduced to \d+ rows \d+ "
    r"columns\s*\n[^\n]*restarting search"
)
_INCUMBENT = re.compile(r"Objective value:\s+" + _NUMBER)
#: Plans CBC says it holds, in full: each integer solution (the MIP
#: start's too, "found by Reduced search"), the best objective of a
#: search. ("MIPStart provided solution with cost" rounds to six digits.)
_HELD = re.compile(r"(?:Integer solution of|best objective) " + _NUMBER)
#: CBC's objective value when it holds no plan (1e+50); anything from
#: this on is not a plan.
_NO_PLAN = 1e49
#: Each search's last word: "Search completed" when its tree is exhausted
#: (the best objective it states is then the optimum), "Partial search"
#: when it stopped; and its best objective.
_SEARCH_SAID = re.compile(
    r"(Search completed|Partial search) - best objective " + _NUMBER
)
#: CBC ended the run itself (its summary).
_RESULT = "\nResult - "
#: CBC read a MIP start (``-mips``) ...
_START_READ = "MIPStart values read"
#: ... and took it as given, or, after :data:`_START_BROKEN`, what its
#: small search around the start's non-zero columns found.
_START_TAKEN = "MIPStart provided solution"
#: The start breaks a row: CBC keeps only its non-zero columns.
_START_BROKEN = "Fixing only non-zero variables"
#: CBC solved the root LP, after which it looks at the start.
_LP_SOLVED = "Continuous objective value"
#: CBC tried the start with its integer columns fixed (a start it then
#: says it could not use breaks a row).
_START_TRIED = "Trying just fixing integer variables"
#: CBC's own time limit ended, or the interrupt at the deadline came.
_OUT_OF_TIME = ("Exiting on maximum time", "Exiting on user event")
#: CBC gave up the start (after a try of it, or without one).
_START_DROPPED = "mipstart values could not be used"
#: A run that stopped with no simplex iteration and no node after its
#: root LP: its time was gone when CBC came back from the start.
_NO_SEARCH = re.compile(
    r"Partial search - best objective .* took 0 iterations"
)


#: How the solver's warning of :func:`start_refused` begins (tools that
#: watch the log match on it).
START_REFUSED = "cbc did not take the warm start as given"


def start_refused(text: str) -> bool:
    """True if a CBC log shows a MIP start read but not taken as given.

    A start that breaks a row of the model is a defect of the column
    values built for it (the plan behind it is valid): CBC then keeps
    only its non-zero columns and runs a small search from them, or
    cannot use it at all, and searches without the incumbent it was
    given (the large suite's f60-h1440 of seed 201: the disjunctive
    relaxation's load columns were left at 0, and it lost its proof).
    """
    if _START_READ not in text or _LP_SOLVED not in text:
        # No start, or stopped before CBC looks at it (after the LP).
        return False
    if _START_BROKEN in text:
        return True
    if _START_TAKEN in text:
        return False
    if _START_DROPPED not in text:
        # No word on the start yet: CBC was killed after its root LP,
        # before it took or dropped the start (a run stopped hard at its
        # deadline), so nothing says the start was refused.
        return False
    # Dropped. CBC's time ran out while it looked at the start, not the
    # start, when it never tried the start's integer columns fixed and
    # its time is up or its interrupt came (``tools/fuzz --large`` seed
    # 1111: a 5,323 x 5,048 model whose root LP took 1.2 s of a 1.7 s
    # run; from 30 s CBC takes the start; a 15-task part at 0.5 s, 0.125 s
    # for CBC, its root LP 0.07 s), or when its next word after the drop
    # is that exit: the LP over the start's fixed columns was cut (a
    # 15-task part at 0.3 s, 0.13 s for CBC, 4,797 x 2,402: its root LP
    # took 0.05 s; with 10 s CBC takes the start), or when the run
    # stopped with no simplex iteration after the drop: the LP over the
    # fixed columns took what was left, and the root's cut pass found its
    # time gone (the large suite's b45-h1440 of seed 241, a 4,787 x 1,049
    # sub-model: its root LP 0.39 s of a 0.84 s run, the fixed LP about
    # 0.7 s; with 20 s CBC takes the start).
    if not _stopped(text):
        return True
    if _START_TRIED not in text:
        return False
    if _NO_SEARCH.search(text):
        return False
    after = text.partition(_START_DROPPED)[2].splitlines()[1:]
    following = next((line for line in after if line.startswith("Cbc")), "")
    return not _stopped(following)


def _stopped(text: str) -> bool:
    """True if ``text`` holds CBC's exit on its time or on the interrupt."""
    return any(words in text for words in _OUT_OF_TIME)


class _Log(NamedTuple):
    """What a CBC log states: solve seconds, its lower bound, and whether
    its bound went above a plan it held (:func:`_overshot`)."""

    seconds: float | None
    bound: float | None
    overshot: bool
    #: The root LP's value before cuts, a valid lower bound (the first
    #: root's: a restart, :func:`restarted_with_cuts`, has its own).
    root: float | None
    #: A MIP start read and not taken as given (:func:`start_refused`).
    refused: bool = False
    #: A restart on a reduced model that kept the root's cuts
    #: (:func:`restarted_with_cuts`).
    restarted: bool = False
    #: The best objective of a search CBC completed (:func:`completed`).
    completed: float | None = None


def read_log(path: str) -> _Log:
    """Seconds, lower bound and their trust from a CBC log, and whether
    it shows a MIP start not taken as given."""
    try:
        text = Path(path).read_text(errors="replace")
    except OSError:
        return _Log(None, None, False, None)
    seconds = _SECONDS.findall(text)
    bound = _BOUND.findall(text)
    cuts = _ROOT_CUTS.findall(text)
    return _Log(
        float(seconds[-1]) if seconds else None,
        float(bound[-1]) if bound else None,
        _overshot(text, cuts),
        float(cuts[0][0]) if cuts else None,
        start_refused(text),
        restarted_with_cuts(text),
        completed(text),
    )


def completed(text: str) -> float | None:
    """The best objective of a CBC log's completed search, or None.

    CBC says "Search completed" when its tree is exhausted: its best
    objective is then the optimum, whatever its solution file says. After
    the search CBC solves the LP once more; when its time ends there, the
    file holds that LP's values under "Stopped on time" or "Optimal" (a
    30-task part over H = 300 of ``tools/fuzz --large`` seed 1414: the
    search done in 0.24 s of 0.237 s, "Optimal - objective value
    -1574728.57", below the optimum -1574603, its values fractional), so
    the proof was lost with them. Unless its cuts cut off valid plans
    (:func:`_overshot`, :func:`restarted_with_cuts`), that best objective
    is what the caller may read as proved.
    """
    # CBC's own small searches (around a MIP start, its mini
    # branch-and-bound) print "Search completed" too: only the last word
    # of a search counts, and only in a log CBC ended itself (a run killed
    # in its search leaves a small search's line last).
    said = _SEARCH_SAID.findall(text)
    if not said or said[-1][0] != "Search completed" or _RESULT not in text:
        return None
    return float(said[-1][1])


def claimed_optimal(solver_status: str) -> bool:
    """True if a run's status line (CBC's first word first) says CBC
    called its answer optimal, whether or not that was kept as a proof
    (:func:`restarted_with_cuts`, :func:`_overshot`)."""
    return solver_status.startswith("Optimal")


def restarted_with_cuts(text: str) -> bool:
    """True if a CBC log shows a restart on a reduced model that kept
    the root's cuts.

    With a MIP start, CBC 2.10 fixes the columns whose reduced cost
    exceeds the gap and searches again from a model of the rows *and the
    cuts* it had at the root, which its own source calls not totally
    safe. Seen on ``tools/fuzz`` seed 68044 (19 tasks, a battery and two
    power lines): the disjunctive relaxation with probing restarted from
    483 rows of a 414-row model and proved 79,990 optimal, where the
    optimum is 79,974 (the same model without probing, with another
    seed, or without the restart, finds it); the product answered
    ``optimal`` with the worse plan. Nothing such a run concludes is a
    proof.
    """
    rows = _MODEL_ROWS.search(text)
    if rows is None:
        return False
    return any(
        int(full) > int(rows.group(1)) for full in _RESTART.findall(text)
    )


def _overshot(text: str, cuts: list[tuple[str, str]]) -> bool:
    """True if CBC's bound went above a plan it held.

    In a minimisation no valid bound exceeds a feasible plan's value. Seen
    on a 24-task part over H = 1440: root cuts "changed objective from
    -3697587 to 1.0826268e+09" with the MIP start at -3697420 in hand;
    CBC then prints "Lower bound: -3697423, Gap: 0.00" (the bound clipped
    to the incumbent) though a plan 154 lower exists. Such cuts cut off
    valid plans, so nothing CBC concludes after them is a proof.

    The plans held are every one the log names in full (each integer
    solution found, the start's included, a search's best objective) and
    the final
    objective unless it is CBC's "no plan" value: on a 40-task part over
    H = 200 the root cuts "changed objective from -1495542.2 to
    6.9534241e+11" with the start at -1493791 in hand, CBC answered
    "Problem proven infeasible" with an objective value of 1e+50, and
    the test read that 1e+50 as the plan held; the run's "Search
    completed - best objective -1493791" was then taken as a proof of
    the start, and the part answered ``optimal`` 94 above a plan the
    search finds.
    """
    held = [
        float(v)
        for v in [*_INCUMBENT.findall(text), *_HELD.findall(text)]
        if float(v) < _NO_PLAN
    ]
    if not held:
        return False
    best = min(held)
    claims = [float(after) for _, after in cuts]
    claims += [float(v) for v in _BEST_POSSIBLE.findall(text)]
    return any(claim > best + ABS_GAP for claim in claims)
