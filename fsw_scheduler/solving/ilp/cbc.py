"""Running the CBC executable with a time limit it cannot overrun.

The program is written as MPS (:meth:`Program.mps`), CBC runs as a child
process, and its solution file is read back. A separate process is what
makes the limit enforceable on board:

* CBC's ``-sec`` is honoured during the root LP only when the time is
  counted in CPU seconds: with ``-timeMode elapsed`` CBC prints "Problem is
  stopped" and then carries on, and large models were seen running four
  times past their limit. The limit is therefore given in CPU time (one
  thread, so close to wall time on an idle core).
* Even so CBC checks its clock only now and then, and nothing stops a CBC
  that hangs or starves. Here the process runs under a wall-clock
  deadline of its limit less ``STOP_MARGIN_S``; past it CBC gets
  SIGINT (it then stops as at a limit and writes its best solution), and
  ``GRACE_S`` later it is killed, which reads as "no solution found".

Starting the process costs a few milliseconds; writing and reading the
files a few more (tools/bench reports both as solver overhead).

Process lifetime: on Linux the kernel kills CBC when the thread that
started it goes (:mod:`.child`), so a node killed with SIGKILL leaves no
CBC running on; and a :class:`Cancel` installed with
:func:`cancel_scope` stops every CBC run of its scope at once (a node
being stopped), and refuses to start new ones.
"""

from __future__ import annotations

import contextlib
import dataclasses
import functools
import logging
import os
import shutil
import signal
import subprocess
import tempfile
import threading
import time
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING

from ...errors import SolverError
from ...model.plan import SolveStatus
from .cbclog import ABS_GAP, START_REFUSED, read_log
from .child import dir_prefix, guarded

if TYPE_CHECKING:
    from collections.abc import Callable, Iterator, Sequence

    from .program import Program

#: Seconds before the end of its share at which CBC gets SIGINT: it checks
#: its own clock only now and then (a root LP of a 1440-unit, 60-task
#: model ran 0.8 s past a 1 s limit), and needs a moment to stop. The
#: most: a small model's margin is smaller (:func:`stop_margin`).
STOP_MARGIN_S = 0.3

#: The least margin, and its growth per matrix entry (:func:`stop_margin`).
#: A 15-task model (1,500 columns, 9,022 entries) stopped by its CPU limit
#: in its root cuts ends 10-20 ms past it, from a limit of 0.02 s or 0.1 s
#: alike; the fixed 0.3 s margin kept CBC from ever starting under a 0.35 s
#: limit, so that a problem CBC proves in 20 ms came back ``feasible``
#: with its start plan after 0.07 s of a 0.3 s limit.
STOP_MARGIN_MIN_S = 0.05
STOP_MARGIN_S_PER_ENTRY = 3e-6

#: The margin is at least this share of CBC's limit: the solve reads,
#: checks and polishes CBC's answer within the caller's limit too (a
#: 14-task part at a 1 s limit answered after 0.97-1.03 s with a margin
#: of 0.05 s, after 0.76-0.79 s with 0.3 s). From a 2 s limit on the
#: margin is the whole :data:`STOP_MARGIN_S`, as before.
STOP_MARGIN_SHARE = 0.15

#: Wall-clock seconds from SIGINT to kill, for CBC to write its solution.
GRACE_S = 1.0

#: A large model's grace grows by this much per matrix entry: CBC answers
#: SIGINT only between nodes, and a node of a large model can take over a
#: second (20,111 columns, 116,000 entries: 0.4-1.4 s from SIGINT to exit,
#: measured), so a fixed grace killed CBC with better plans found than its
#: start, and they were lost. The interrupt comes earlier by as much.
GRACE_S_PER_ENTRY = 1.5e-5

#: CBC reads about a million matrix entries a second from MPS.
READ_S_PER_ENTRY = 1e-6

#: CBC is not started with less time than this left of its limit.
MIN_CBC_S = 0.05

#: An option that speeds CBC up but can crash it; dropped on a retry.
FRAGILE = "preprocess off"
#: CBC without cut generators: a run whose cuts cut off valid plans is
#: run again so (:meth:`CbcRun.solve`).
CUTS_OFF = "cuts off"

#: CBC without its restart on a reduced model (its default strategy 1
#: turns it on; :mod:`fsw_scheduler.solving.confirm`): a run that
#: restarted with its root cuts, and whose cuts cut off no plan it held,
#: is run again so (:meth:`CbcRun.solve`), its cuts on. First among the
#: options: CBC reads them in order, and a strategy resets what came
#: before it. The broad campaign's b15-multiple-6 of seed 217 (a 15-task
#: day, 2,198 columns): from the restarted run's optimum, 18 nodes and
#: 0.92 s so, 78 nodes and 1.64 s with cuts off.
NO_RESTART = "strategy 0"


log = logging.getLogger("fsw_scheduler.solver")


class Cancel:
    """Stops the CBC runs started under it (see :func:`cancel_scope`)."""

    def __init__(self) -> None:
        self._lock = threading.Lock()
        self._running: set[subprocess.Popen] = set()
        self.cancelled = False

    def cancel(self) -> None:
        """Kill every run of the scope now; start no new one."""
        with self._lock:
            self.cancelled = True
            running = list(self._running)
        for process in running:
            with contextlib.suppress(OSError):
                process.kill()

    def _enter(self, process: subprocess.Popen) -> bool:
        with self._lock:
            if not self.cancelled:
                self._running.add(process)
            return not self.cancelled

    def _leave(self, process: subprocess.Popen) -> None:
        with self._lock:
            self._running.discard(process)


_scope = threading.local()


@contextlib.contextmanager
def cancel_scope(cancel: Cancel) -> Iterator[Cancel]:
    """Run the CBC solves of this thread under ``cancel``."""
    outer = getattr(_scope, "cancel", None)
    _scope.cancel = cancel
    try:
        yield cancel
    finally:
        _scope.cancel = outer


@functools.cache
def cbc_path() -> str:
    """The CBC executable: PuLP's bundled binary, else ``cbc`` on PATH.

    Looked up once per process: finding the bundled binary imports PuLP.
    """
    from pulp.apis import coin_api

    bundled = Path(coin_api.pulp_cbc_path)
    if bundled.is_file() and os.access(bundled, os.X_OK):
        return str(bundled.resolve())
    found = shutil.which("cbc")
    if found is None:
        raise SolverError(
            "no CBC executable: PuLP's bundled one is missing and 'cbc' is "
            "not on PATH (pip install 'pulp[cbc]' or apt install coinor-cbc)"
        )
    return found


@dataclass
class CbcResult:
    """What one CBC run gave.

    Attributes
    ----------
    status
        Read from the first line of CBC's solution file.
    values
        Column values when CBC wrote a solution (``has_plan`` statuses).
    seconds
        CBC's own wall-clock time, from its log.
    bound
        CBC's lower bound on the objective, constant included.
    interrupted
        True when the deadline passed and CBC was interrupted.
    retried
        True when CBC crashed and was run again with its defaults.
    solver_status
        CBC's status line, with what was made of it.
    overshot
        True when CBC's log showed its bound above a plan it held (cuts
        that cut off valid plans, :func:`.cbclog._overshot`): nothing it
        concluded is a proof.
    restarted
        True when CBC restarted on a reduced model that kept its root
        cuts (:func:`.cbclog.restarted_with_cuts`): nothing it concluded is a
        proof either; its plan is one.
    completed
        The optimum, constant included, when CBC's log shows its search
        completed (:func:`.cbclog.completed`) and its cuts cut off no
        valid plan; else None. Its solution file may still hold other
        values (its last LP, stopped on time).
    """

    status: SolveStatus
    values: list[float] | None
    seconds: float | None = None
    bound: float | None = None
    interrupted: bool = False
    retried: bool = False
    solver_status: str = ""
    overshot: bool = False
    restarted: bool = False
    completed: float | None = None

    @property
    def cut_off(self) -> bool:
        """True when its cuts may have cut off valid plans (``overshot``
        or ``restarted``): nothing it concluded is a proof."""
        return self.overshot or self.restarted


#: CBC's objective when it holds no solution (1e50): no optimum.
NO_SOLUTION = 1e49


def read_completed(
    program: Program,
    result: CbcResult,
    start: list[float] | None,
    notes: list[str],
) -> None:
    """Read a search CBC completed (:attr:`CbcResult.completed`) as the
    proof it is, whatever its solution file held: its best objective is
    the optimum, so the bound; the MIP start, or else the plan written,
    is optimal when its objective is that one (checked, as every plan)."""
    optimum = result.completed
    if (
        optimum is None
        or abs(optimum) >= NO_SOLUTION
        or result.status is SolveStatus.OPTIMAL
    ):
        return
    result.bound = optimum
    # The start first: a valid plan, where the values written may be the
    # last LP's, stopped with rows broken.
    for values, said in (
        (start, "the start is optimal"),
        (result.values, "the plan written is optimal"),
    ):
        if (
            values is not None
            and abs(program.value(values) - optimum) <= ABS_GAP
        ):
            result.status, result.values = SolveStatus.OPTIMAL, list(values)
            notes.append(f"its search completed: {said}")
            return


def read_status(first_line: str) -> tuple[SolveStatus, bool]:
    """(status, has values) from the first line of a CBC solution file.

    "Stopped on time - objective value 12" is a plan found at a limit;
    "Stopped on time - no solution" has none; "Integer infeasible" is a
    proven infeasibility like "Infeasible".
    """
    words = first_line.split()
    head = words[0] if words else ""
    if head == "Optimal":
        return SolveStatus.OPTIMAL, True
    if head in ("Infeasible", "Integer"):
        return SolveStatus.INFEASIBLE, False
    if head == "Stopped" and len(words) >= 5 and words[4] == "objective":
        return SolveStatus.FEASIBLE, True
    return SolveStatus.UNKNOWN, False


def _read_solution(path: str, columns: int) -> tuple[str, list[float]]:
    values = [0.0] * columns
    with open(path) as lines:
        first = lines.readline()
        for line in lines:
            words = line.split()
            if len(words) < 3:
                break
            if words[0] == "**":  # marks a value breaking its bounds
                words = words[1:]
            name = words[1]
            if name.startswith("X"):
                values[int(name[1:])] = float(words[2])
    return first, values


class CbcRun:
    """One configured CBC: options, seed, time limit and deadline.

    Parameters
    ----------
    time_limit
        Seconds for :meth:`solve`, None for no limit. Writing the files
        comes out of it; CBC gets the rest as CPU seconds (``-sec``).
    deadline_s
        Wall-clock seconds after CBC starts at which it is interrupted;
        None waits for CBC however long it takes. Defaults to CBC's share
        of the limit less ``STOP_MARGIN_S``; ``GRACE_S`` later it is
        killed.
    threads
        CBC threads; 1 (CBC's serial search) keeps results reproducible.
    seed
        Seed of CBC's random choices.
    path
        The executable (default :func:`cbc_path`).
    """

    def __init__(
        self,
        *,
        time_limit: float | None = None,
        deadline_s: float | None = None,
        threads: int = 1,
        seed: int = 0,
        path: str | None = None,
    ) -> None:
        self.path = path or cbc_path()
        self.time_limit = time_limit
        self.deadline_s = deadline_s
        self.options = [
            # CBC's own seeds: the same input gives the same plan.
            f"randomSeed {seed + 1}",
            f"randomCbcSeed {seed + 1}",
            # CGL preprocessing costs more than it saves on these models:
            # half the median time on the paper's campaign (tools/bench,
            # 15 tasks: 0.67 s -> 0.31 s).
            FRAGILE,
            # Nor does CLP's presolve of each LP pay on these sparse
            # models (campaign, 10 and 15 tasks: median CBC run 0.051 ->
            # 0.045 s, none slower beyond noise but one).
            "presolve off",
            "timeMode cpu",
            "ratio 0",
            f"allow {ABS_GAP}",
        ]
        if threads > 1:
            # Not for one thread: "-threads 1" starts CBC's parallel code
            # with one worker, which on a trivial model hung in a futex
            # about 1 run in 300 (until killed at the deadline); CBC's
            # default is the serial, equally reproducible, search.
            self.options.append(f"threads {threads}")
        self.interrupted = False
        #: Seconds from SIGINT to kill in the current run (:meth:`solve`).
        self.grace_s = GRACE_S
        #: Matrix entries of the current run's program.
        self.entries = 0

    def solve(
        self, program: Program, warm: Sequence[float] | None = None
    ) -> CbcResult:
        """Solve ``program``, starting from ``warm`` column values if given.

        A run whose cuts cut off valid plans (:attr:`CbcResult.overshot`)
        and that ended before its limit is run once more with cuts off
        (:data:`CUTS_OFF`), one that restarted with its root cuts
        (:attr:`CbcResult.restarted`) without the restart
        (:data:`NO_RESTART`), from the best plan the first run held, for
        the time left: a 15-task paper problem (seed 7's c15-multiple-4)
        came back ``feasible`` after 0.2 s of a 20 s limit, its bound
        refused, where CBC without cuts proves it at once. The second
        answer is kept unless its cuts misled it too.

        Raises
        ------
        SolverError
            When CBC fails without being interrupted, even on a retry.
        """
        began = time.monotonic()
        first = self._solve_once(program, warm)
        if (
            not first.cut_off
            or self.interrupted
            or CUTS_OFF in self.options
            or (not first.overshot and NO_RESTART in self.options)
        ):
            return first
        left = None
        if self.time_limit is not None:
            left = self.time_limit - (time.monotonic() - began)
            if left < MIN_CBC_S + stop_margin(program.num_entries, left):
                return first
        saved = self.options, self.time_limit, self.deadline_s
        if first.overshot:
            self.options, said = [*self.options, CUTS_OFF], "with cuts off"
        else:
            self.options = [NO_RESTART, *self.options]
            said = "without the restart"
        self.time_limit, self.deadline_s = left, None
        try:
            again = self._solve_once(
                program, first.values if first.values is not None else warm
            )
        finally:
            self.options, self.time_limit, self.deadline_s = saved
        if again.cut_off or again.status is SolveStatus.UNKNOWN:
            return first
        return dataclasses.replace(
            again,
            solver_status=(
                f"{first.solver_status}; again {said}: {again.solver_status}"
            ),
        )

    def _limits(
        self, program: Program, began: float
    ) -> tuple[list[str], float | None] | None:
        """CBC's ``-sec`` flag and the deadline of its run (seconds from
        its start) for what is left of the limit since ``began``; None
        when that is too short for CBC to do more than read the model."""
        deadline = self.deadline_s
        if self.time_limit is None:
            return [], deadline
        # Large models take a while to write, and CBC to read: it gets
        # the rest as CPU time, and SIGINT a little before the end of its
        # share in case its clock lags.
        left = self.time_limit - (time.monotonic() - began)
        reading = READ_S_PER_ENTRY * program.num_entries
        margin = stop_margin(program.num_entries, left)
        cpu_limit = round(left - reading - margin, 3)
        if cpu_limit < MIN_CBC_S:
            return None
        if deadline is None:
            # The interrupt leaves a large model its longer grace.
            deadline = left - margin - (self.grace_s - GRACE_S)
            if deadline < reading + MIN_CBC_S:
                # Interrupted before it has read the model (a 42,010-column
                # model given 3.7 s, its grace 3.4 s): not started, and
                # the caller keeps the time.
                return None
        return ["-sec", str(cpu_limit)], deadline

    def _solve_once(
        self, program: Program, warm: Sequence[float] | None = None
    ) -> CbcResult:
        """One CBC run of :meth:`solve` (retried once with preprocessing
        if CBC crashes)."""
        began = time.monotonic()
        if self.time_limit is not None and self.time_limit < MIN_CBC_S:
            return _not_started()
        self.grace_s = max(GRACE_S, GRACE_S_PER_ENTRY * program.num_entries)
        self.entries = program.num_entries
        with tempfile.TemporaryDirectory(prefix=dir_prefix()) as tmp:
            files = {
                kind: os.path.join(tmp, f"model.{kind}")
                for kind in ("mps", "mst", "prio", "sol", "log")
            }
            Path(files["mps"]).write_text(program.mps())
            head = [self.path, files["mps"]]
            if warm is not None:
                _write_start(files["mst"], program, warm)
                head += ["-mips", files["mst"]]
            if program.priorities:
                _write_priorities(files["prio"], program)
                head += ["-priorityIn", files["prio"]]
            limits = self._limits(program, began)
            if limits is None:
                # CBC would only read the model and stop.
                return _not_started()
            sec, deadline = limits
            tail = ["-solve", "-solution", files["sol"]]
            options = list(self.options)
            code = self._run(
                head + sec + _flags(options) + tail, files["log"], deadline
            )
            retried = False
            if self._failed(code, files["sol"]) and not self.interrupted:
                # CBC 2.10 can crash without preprocessing on some
                # infeasible models: retry once with its defaults, in
                # what is left (with the first run's share again, a 20 s
                # solve answered after 20.6 s).
                log.warning(
                    "cbc exited with %s; retrying with preprocessing", code
                )
                limits = self._limits(program, began)
                if limits is None:
                    return dataclasses.replace(
                        _not_started(),
                        solver_status=f"cbc exited with {code}; no time "
                        "left to run it again",
                    )
                sec, deadline = limits
                options.remove(FRAGILE)
                retried = True
                code = self._run(
                    head + sec + _flags(options) + tail, files["log"], deadline
                )
            seconds, bound, overshot, root, refused, restarted, done = (
                read_log(files["log"])
            )
            if refused:
                log.warning(
                    "%s (it breaks a row of the %d x %d model): searched "
                    "without it",
                    START_REFUSED,
                    program.num_rows,
                    program.num_columns,
                )
            if overshot or restarted:
                # Numerical trouble or a restart with the root's cuts cut
                # off valid plans: only the root LP before cuts bounds the
                # optimum (less one unit: the log rounds it).
                bound = None if root is None else root - 1
                done = None  # nor is a search it completed a proof
            if bound is not None:
                bound += program.constant
            if done is not None:
                done += program.constant
            if self._failed(code, files["sol"]):
                if not self.interrupted:
                    raise SolverError(f"cbc exited with code {code}")
                return CbcResult(
                    SolveStatus.UNKNOWN,
                    None,
                    seconds,
                    bound,
                    interrupted=True,
                    retried=retried,
                    solver_status="killed at the deadline",
                    completed=done,
                )
            first, values = _read_solution(files["sol"], program.num_columns)
        status, has_values = read_status(first)
        line, _, value = first.strip().partition(" - objective value ")
        if status is SolveStatus.INFEASIBLE and self.interrupted:
            # Interrupted in its root, CBC calls the LP "infeasible or too
            # expensive" and writes "Integer infeasible" (tools/fuzz
            # --large seed 633: a 13,660-column model whose root LP had
            # been solved, interrupted 0.4 s in, while a valid plan was
            # known). An interrupted run proves nothing.
            status = SolveStatus.UNKNOWN
            line += "; interrupted: no proof"
        if overshot or restarted:
            line += (
                "; cuts cut off valid plans: no proof, root LP bound"
                if overshot
                else "; restarted with its root cuts: no proof, root LP bound"
            )
            if status in (SolveStatus.OPTIMAL, SolveStatus.INFEASIBLE):
                # Its plan may be flown; its claim is not kept.
                status = (
                    SolveStatus.FEASIBLE
                    if status is SolveStatus.OPTIMAL
                    else SolveStatus.UNKNOWN
                )
        if bound is None and "continuous used" in line and value:
            # Stopped before any integer solution: the value is that of
            # the LP relaxation, still a valid lower bound.
            with contextlib.suppress(ValueError):
                bound = float(value) + program.constant
        return CbcResult(
            status,
            values if has_values else None,
            seconds,
            bound,
            interrupted=self.interrupted,
            retried=retried,
            solver_status=line,
            overshot=overshot,
            restarted=restarted,
            completed=done,
        )

    def _failed(self, code: int, solution: str) -> bool:
        """No usable solution file (crash, or killed at the deadline)."""
        empty = not os.path.exists(solution) or os.path.getsize(solution) == 0
        return empty or (code != 0 and not self.interrupted)

    def _run(
        self, args: list[str], log_path: str, deadline: float | None
    ) -> int:
        cancel: Cancel | None = getattr(_scope, "cancel", None)
        if cancel is not None and cancel.cancelled:
            self.interrupted = True
            return -signal.SIGKILL
        command, preexec = guarded(args)
        with open(log_path, "w") as out:
            process = subprocess.Popen(
                command,
                stdout=out,
                stderr=out,
                stdin=subprocess.DEVNULL,
                env=self._environment(),
                preexec_fn=preexec,
            )
            if cancel is not None and not cancel._enter(process):
                process.kill()
            try:
                self._wait(process, deadline)
            finally:
                if cancel is not None:
                    cancel._leave(process)
        if cancel is not None and cancel.cancelled:
            self.interrupted = True
        return process.returncode

    def _environment(self) -> dict[str, str] | None:
        """CBC's environment; None inherits this process's."""
        return None

    def _wait(
        self,
        process: subprocess.Popen,
        deadline: float | None,
        stop: Callable[[subprocess.Popen], None] | None = None,
    ) -> None:
        """Wait for CBC; past the deadline interrupt it, then kill it
        (``stop``, :meth:`_stop` by default, on a timer thread).

        The wait itself blocks in ``waitpid``: ``Popen.wait(timeout)``
        polls with sleeps of up to 50 ms, which added about 20 ms to every
        small solve. A timer thread enforces the deadline instead.
        """
        if deadline is None:
            process.wait()
            return
        timer = threading.Timer(deadline, stop or self._stop, (process,))
        timer.daemon = True
        timer.start()
        try:
            process.wait()
        finally:
            timer.cancel()

    def _stop(
        self, process: subprocess.Popen, grace_s: float | None = None
    ) -> None:
        """SIGINT (CBC then writes its best solution), kill after
        ``grace_s`` (default :attr:`grace_s`)."""
        if process.poll() is not None:
            return
        self.interrupted = True
        process.send_signal(signal.SIGINT)
        try:
            process.wait(self.grace_s if grace_s is None else grace_s)
        except subprocess.TimeoutExpired:
            process.kill()


def stop_margin(entries: int, limit: float | None = None) -> float:
    """Seconds before the end of its share at which CBC on a model of
    ``entries`` matrix entries, with ``limit`` seconds, is stopped:
    :data:`STOP_MARGIN_S_PER_ENTRY` per entry, and
    :data:`STOP_MARGIN_SHARE` of the limit, whichever is more, between
    :data:`STOP_MARGIN_MIN_S` and :data:`STOP_MARGIN_S` (reached from
    100,000 entries or a 2 s limit on)."""
    margin = max(STOP_MARGIN_MIN_S, STOP_MARGIN_S_PER_ENTRY * entries)
    if limit is not None:
        margin = max(margin, STOP_MARGIN_SHARE * limit)
    return min(STOP_MARGIN_S, margin)


def _not_started() -> CbcResult:
    return CbcResult(
        SolveStatus.UNKNOWN,
        None,
        solver_status="time limit spent before CBC started",
    )


def _flags(options: list[str]) -> list[str]:
    return [word for option in options for word in ("-" + option).split()]


def _write_start(path: str, program: Program, values: Sequence[float]) -> None:
    """A MIP start in CBC's solution-file format (read by ``-mips``).

    Only the integer columns are given: CBC fixes them and computes the
    continuous ones (consumable levels) itself.
    """
    lines = ["Stopped on time - objective value 0\n"]
    lines += [
        f"{col} {program.column_name(col)} {value:g}\n"
        for col, value in enumerate(values)
        if program.integer[col]
    ]
    Path(path).write_text("".join(lines))


def _write_priorities(path: str, program: Program) -> None:
    """Branching priorities in CBC's CSV format (read by ``-priorityIn``)."""
    lines = ["name,priority\n"]
    lines += [
        f"{program.column_name(col)},{priority}\n"
        for col, priority in sorted(program.priorities.items())
    ]
    Path(path).write_text("".join(lines))
