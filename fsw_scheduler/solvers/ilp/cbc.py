"""Running CBC with a time limit it cannot overrun.

Two things in PuLP's ``COIN_CMD`` are not good enough on board:

* CBC's ``-sec`` is honoured during the root LP only when the time is
  counted in CPU seconds: with ``-timeMode elapsed`` (PuLP's default) CBC
  prints "Problem is stopped" and then carries on, and large models were
  seen running four times past their limit. The limit is therefore given in
  CPU time (one thread, so close to wall time on an idle core).
* Nothing stops a CBC process that hangs or starves. Here the process runs
  under a wall-clock deadline of ``limit + grace``; past it CBC gets
  SIGINT (it then stops as at a limit and writes its best solution), and
  past a second grace it is killed, which reads as "no solution found".
"""

from __future__ import annotations

import logging
import os
import signal
import subprocess
from typing import Any

import pulp

#: Wall-clock seconds allowed past the time limit before SIGINT, then kill.
GRACE_S = 2.0

#: An option that speeds CBC up but can crash it; dropped on a retry.
FRAGILE = "preprocess off"

log = logging.getLogger("fsw_scheduler.solver")


def _flags(options: list[str]) -> list[str]:
    return [word for option in options for word in ("-" + option).split()]


def _failed(code: int, solution: str, interrupted: bool) -> bool:
    """No usable solution file (crash, or killed at the deadline)."""
    empty = not os.path.exists(solution) or os.path.getsize(solution) == 0
    return empty or (code != 0 and not interrupted)


class HardLimitCBC(pulp.COIN_CMD):
    """``COIN_CMD`` with CPU-time limits and a wall-clock deadline.

    Parameters
    ----------
    deadline_s
        Wall-clock seconds after which the process is interrupted; None
        waits for CBC however long it takes.
    **options
        As for :class:`pulp.COIN_CMD`.
    """

    def __init__(self, *, deadline_s: float | None, **options: Any) -> None:
        options.setdefault("timeMode", "cpu")
        super().__init__(**options)
        self.deadline_s = deadline_s
        self.interrupted = False
        self.killed = False

    def solve_CBC(self, lp: pulp.LpProblem, use_mps: bool = True) -> int:
        """Write the MPS, run CBC under the deadline, read the solution."""
        tmp_lp, tmp_mps, tmp_sol, tmp_mst = self.create_tmp_files(
            lp.name, "lp", "mps", "sol", "mst"
        )
        variables, var_names, con_names, _ = lp.writeMPS(tmp_mps, rename=1)
        head = [self.path, tmp_mps]
        if self.optionsDict.get("warmStart", False):
            self.writesol(tmp_mst, lp, variables, var_names, con_names)
            head += ["-mips", tmp_mst]
        if self.timeLimit is not None:
            head += ["-sec", str(self.timeLimit)]
        options = [*self.options, *self.getOptions()]
        tail = ["-solve", "-printingOptions", "all", "-solution", tmp_sol]
        try:
            code = self._run(head + _flags(options) + tail)
            if (
                _failed(code, tmp_sol, self.interrupted)
                and not self.interrupted
                and FRAGILE in options
            ):
                # CBC 2.10 can crash without preprocessing on some
                # infeasible models: retry once with its defaults.
                log.warning(
                    "cbc exited with %s; retrying with preprocessing", code
                )
                options = [o for o in options if o != FRAGILE]
                code = self._run(head + _flags(options) + tail)
            if _failed(code, tmp_sol, self.interrupted):
                if not self.interrupted:
                    raise pulp.PulpSolverError(f"cbc exited with code {code}")
                lp.assignStatus(
                    pulp.LpStatusNotSolved, pulp.LpSolutionNoSolutionFound
                )
                return pulp.LpStatusNotSolved
            status, values, _, _, _, sol_status = self.readsol_MPS(
                tmp_sol, lp, variables, var_names, con_names
            )
            lp.assignVarsVals(values)
            lp.assignStatus(status, sol_status)
            return status
        finally:
            self.delete_tmp_files(tmp_mps, tmp_lp, tmp_sol, tmp_mst)

    def _run(self, args: list[str]) -> int:
        log_path = self.optionsDict.get("logPath")
        with open(log_path or os.devnull, "w") as out:
            process = subprocess.Popen(
                args, stdout=out, stderr=out, stdin=subprocess.DEVNULL
            )
            self._wait(process)
        return process.returncode

    def _wait(self, process: subprocess.Popen) -> None:
        if self.deadline_s is None:
            process.wait()
            return
        try:
            process.wait(self.deadline_s)
            return
        except subprocess.TimeoutExpired:
            self.interrupted = True
            process.send_signal(signal.SIGINT)
        try:
            process.wait(GRACE_S)
        except subprocess.TimeoutExpired:
            self.killed = True
            process.kill()
            process.wait()
