"""Tests of the CBC child process: its lifetime, spawn and cleanup."""

from __future__ import annotations

import functools
import os
import random
import signal
import subprocess
import sys
import textwrap
import time
from pathlib import Path
from typing import TYPE_CHECKING

import pytest

from fsw_scheduler.analysis.check import check_plan
from fsw_scheduler.model.plan import SolveStatus
from fsw_scheduler.model.problem import decode_problem
from fsw_scheduler.solving import incumbent
from fsw_scheduler.solving.ilp import cbc, cbclog, child, progress
from fsw_scheduler.solving.ilp.cbc import CbcRun
from fsw_scheduler.solving.ilp.child import sweep_stale_dirs
from fsw_scheduler.solving.ilp.model import solve_ilp
from fsw_scheduler.solving.ilp.program import EQ, Program
from fsw_scheduler.solving.ilp.progress import WatchedCbcRun, line_buffered
from fsw_scheduler.solving.solve import solve

from ..factories import ROOT, bench_lib, make_doc, make_task, problem_from

if TYPE_CHECKING:
    from collections.abc import Callable

linux = pytest.mark.skipif(
    not Path("/proc/self/stat").exists(), reason="reads /proc (Linux)"
)

#: A market split problem (Cornuejols and Dawande): equalities of random
#: weights over binaries, which branch and bound takes minutes to refute.
#: The parent below runs CBC on it under a 60 s limit.
_PARENT = textwrap.dedent(
    """
    import random, sys
    from fsw_scheduler.solving.ilp import cbc, child
    from fsw_scheduler.solving.ilp.program import EQ, Program
    if sys.argv[1] == "preexec":
        child._setpriv = lambda: None
    rng = random.Random(7)
    program = Program()
    cols = [program.add_column(0, 1, integer=True) for _ in range(40)]
    for _ in range(5):
        weights = {c: rng.randint(0, 99) for c in cols}
        program.add_row(weights, EQ, sum(weights.values()) // 2)
    program.set_objective({c: 1 for c in cols})
    cbc.CbcRun(time_limit=60).solve(program)
    """
)


def _state(pid: int) -> str | None:
    """(comm, state) of ``pid`` as one string, None once it is gone."""
    try:
        stat = Path(f"/proc/{pid}/stat").read_text()
    except OSError:
        return None
    comm = stat[stat.index("(") + 1 : stat.rindex(")")]
    return f"{comm} {stat[stat.rindex(')') + 2]}"


def _alive(pid: int) -> bool:
    state = _state(pid)
    return state is not None and not state.endswith(" Z")  # zombie: dead


def _children(pid: int) -> list[int]:
    found = []
    for entry in Path("/proc").iterdir():
        if entry.name.isdigit():
            try:
                stat = (entry / "stat").read_text()
            except OSError:
                continue
            if int(stat[stat.rindex(")") + 2 :].split()[1]) == pid:
                found.append(int(entry.name))
    return found


def _has_arg(pid: int, arg: Path) -> bool:
    """Whether ``arg`` is among the arguments /proc shows for ``pid``."""
    cmdline = Path(f"/proc/{pid}/cmdline").read_bytes().split(b"\0")
    return os.fsencode(str(arg)) in cmdline


def _until(condition: Callable[[], object], timeout: float) -> bool:
    """Poll ``condition`` every 10 ms for up to ``timeout`` seconds."""
    end = time.monotonic() + timeout
    while time.monotonic() < end:
        if condition():
            return True
        time.sleep(0.01)
    return bool(condition())


@linux
@pytest.mark.parametrize("guard", ["setpriv", "preexec"])
def test_cbc_dies_when_its_parent_is_killed(guard: str) -> None:
    """Tests that SIGKILL of the solving process also ends its CBC."""
    if guard == "setpriv" and child._setpriv() is None:
        pytest.skip("no setpriv with --pdeathsig")
    parent = subprocess.Popen(
        [sys.executable, "-c", _PARENT, guard],
        cwd=ROOT,
        stdin=subprocess.DEVNULL,
    )
    try:
        solver: list[int] = []

        def cbc_started() -> bool:
            solver[:] = [
                pid
                for pid in _children(parent.pid)
                if (_state(pid) or "").startswith("cbc ")
            ]
            return bool(solver)

        assert _until(cbc_started, 30), "CBC never started"
        os.kill(parent.pid, signal.SIGKILL)
        parent.wait(10)
        assert _until(lambda: not _alive(solver[0]), 10), _state(solver[0])
    finally:
        parent.kill()
        parent.wait()


@linux
def test_sweep_kills_a_cbc_orphan_of_a_dead_parent(tmp_path: Path) -> None:
    """Tests that a process reading a stale directory is killed with it."""
    # A pid no process can have (a finished child's pid may be reused at
    # once on a busy machine).
    pid_max = Path("/proc/sys/kernel/pid_max")
    dead = int(pid_max.read_text()) + 1 if pid_max.exists() else 2**22 + 1
    stale = tmp_path / f"fsw-cbc-{dead}-abc"
    stale.mkdir()
    model = stale / "model.mps"
    model.write_text("")
    orphan = subprocess.Popen(
        [sys.executable, "-c", "import time; time.sleep(60)", str(model)]
    )
    bystander = subprocess.Popen(
        [sys.executable, "-c", "import time; time.sleep(60)", str(tmp_path)]
    )
    try:
        # An orphan has run for a while when a sweep comes: right after
        # its spawn, its new arguments may not be readable yet (the
        # parent resumes within exec; 20 in 300 on a loaded machine).
        for process, arg in ((orphan, model), (bystander, tmp_path)):
            readable = functools.partial(_has_arg, process.pid, arg)
            assert _until(readable, 10), process.args
        assert sweep_stale_dirs(str(tmp_path)) == [str(stale)]
        assert orphan.wait(10) == -signal.SIGKILL
        assert bystander.poll() is None
        assert not stale.exists()
    finally:
        for process in (orphan, bystander):
            process.kill()
            process.wait()


def test_one_thread_runs_cbc_serial_search() -> None:
    """Tests that CBC's threads option is given only for more than one."""
    assert not any("threads" in o for o in CbcRun(threads=1).options)
    assert "threads 2" in CbcRun(threads=2).options


def test_cbc_is_spawned_without_python_in_the_child() -> None:
    """Tests that with setpriv the child runs no preexec_fn (vfork)."""
    command, preexec = child.guarded(["cbc", "model.mps"])
    if child._setpriv() is None:
        assert command == ["cbc", "model.mps"]
    else:
        assert preexec is None
        assert command[-3:] == ["--", "cbc", "model.mps"]
        assert "--pdeathsig" in command


def test_line_buffering_preloads_libstdbuf_before_others() -> None:
    """Tests that the environment keeps an existing LD_PRELOAD after it."""
    env = line_buffered({"LD_PRELOAD": "/lib/other.so", "A": "1"})
    if env is None:
        pytest.skip("no libstdbuf")
    library, other = env["LD_PRELOAD"].split(":")
    assert library.endswith("libstdbuf.so") and Path(library).is_file()
    assert other == "/lib/other.so"
    assert env["_STDBUF_O"] == "L" and env["A"] == "1"


def test_watched_cbc_log_is_line_buffered(tmp_path: Path) -> None:
    """Tests that CBC in the watched environment writes whole lines."""
    env = WatchedCbcRun()._environment()
    if env is None:
        pytest.skip("no libstdbuf")
    program = Program()
    rng = random.Random(7)
    cols = [program.add_column(0, 1, integer=True) for _ in range(40)]
    for _ in range(5):
        weights: dict[int, float] = {c: rng.randint(0, 99) for c in cols}
        program.add_row(weights, EQ, sum(weights.values()) // 2)
    program.set_objective({c: 1 for c in cols})
    (tmp_path / "m.mps").write_text(program.mps())
    log = tmp_path / "log"
    with open(log, "w") as out:
        process = subprocess.Popen(
            [CbcRun().path, str(tmp_path / "m.mps"), "-sec", "20", "-solve"],
            stdin=subprocess.DEVNULL,
            stdout=out,
            stderr=out,
            env=env,
        )
    try:
        # Fully buffered, the file grows by 4096-byte blocks only.
        def midway_line() -> bool:
            size = log.stat().st_size
            return process.poll() is None and size % 4096 != 0

        assert _until(midway_line, 10)
    finally:
        process.kill()
        process.wait()


LOGS = Path(__file__).parent / "logs"


def test_a_bound_above_a_held_plan_is_not_trusted() -> None:
    """Tests that a CBC log whose root cuts raised the bound above the plan
    CBC held (numerical trouble, from a real 24-task replan) yields the
    root LP before cuts, less one, not CBC's clipped "Lower bound", which
    equalled the plan although a better one exists."""
    said = cbclog.read_log(str(LOGS / "cuts_overshoot.log"))
    assert said.overshot
    assert said.bound == -3697423  # what CBC claims: the plan itself
    assert said.root == -3697587
    # A log whose cuts close the gap to the plan, and no further, is kept.
    close = cbclog.read_log(str(LOGS / "cuts_close.log"))
    assert not close.overshot
    assert close.root == -284500


def test_cuts_that_end_in_infeasible_with_a_plan_in_hand_are_no_proof() -> (
    None
):
    """Tests that a run whose root cuts raised the LP to 6.95e+11 with
    its start at -1,493,791 in hand, and which then said "Problem proven
    infeasible" (objective value 1e+50) after "Search completed - best
    objective -1493791" (a 40-task part over H = 200, the whole model
    narrowed around the start: the part was answered ``optimal`` 94
    above a plan its search finds), shows cuts that cut off valid plans:
    the plan held is the start, not CBC's 1e+50."""
    said = cbclog.read_log(str(LOGS / "cuts_overshoot_infeasible.log"))
    assert said.overshot
    assert said.completed == -1493791  # what must not be read as proved
    assert said.root == -1495542.2


def test_a_restart_that_keeps_the_root_cuts_is_no_proof() -> None:
    """Tests that a CBC log showing a restart on a reduced model that
    kept the root's probing cuts (483 rows of a 414-row model: the
    disjunctive relaxation of ``tools/fuzz`` seed 68044, where CBC then
    proved a wrong optimum, -667,183 against -667,199) is no proof and
    yields the first root LP before cuts, not the restart's; a restart
    from the model's own rows (cuts off) is kept."""
    said = cbclog.read_log(str(LOGS / "restart_with_cuts.log"))
    assert cbclog.restarted_with_cuts(
        (LOGS / "restart_with_cuts.log").read_text()
    )
    assert said.restarted and not said.overshot
    assert said.root == -667483
    kept = LOGS / "restart_without_cuts.log"
    assert "restarting search" in kept.read_text()
    assert not cbclog.restarted_with_cuts(kept.read_text())
    assert not cbclog.read_log(str(kept)).restarted
    # A log without a restart, with cuts, says nothing of it.
    close = (LOGS / "cuts_close.log").read_text()
    assert not cbclog.restarted_with_cuts(close)


def test_a_start_cbc_did_not_take_as_given_is_seen() -> None:
    """Tests that :func:`cbclog.start_refused` tells a MIP start CBC took
    (a time-indexed run) from one that broke a row (CBC kept its
    non-zero columns) and one CBC could not use at all, both from the
    disjunctive relaxation before its load columns were filled."""
    text = {
        name: (LOGS / f"start_{name}.log").read_text()
        for name in ("taken", "broken", "dropped")
    }
    assert not cbclog.start_refused(text["taken"])
    assert cbclog.start_refused(text["broken"])
    assert cbclog.start_refused(text["dropped"])
    # Stopped before its root LP, CBC has not looked at the start yet.
    head = text["dropped"].split("Continuous objective value")[0]
    assert not cbclog.start_refused(head)
    # Killed after its root LP, before a word on the start (a run stopped
    # hard at its deadline): no refusal either.
    killed = text["dropped"].split("Cbc0045I Trying just fixing")[0]
    assert "Continuous objective value" in killed
    assert not cbclog.start_refused(killed + "Cbc0031I 154 added rows\n")
    # Its time ran out while it looked at a valid start (the root LP took
    # most of the run): no refusal of the start's values.
    late = (LOGS / "start_out_of_time.log").read_text()
    assert "mipstart values could not be used" in late
    assert not cbclog.start_refused(late)
    assert cbclog.start_refused(
        late.replace("Cbc0020I Exiting on maximum time", "")
    )
    assert not cbclog.start_refused("Problem MODEL has 3 rows")
    # Its time ran out in the LP over the start's fixed integer columns
    # (CBC's next word is its exit on time): no refusal either.
    cut = (LOGS / "start_fix_out_of_time.log").read_text()
    assert "Trying just fixing integer variables" in cut
    assert not cbclog.start_refused(cut)
    # Its time ran out in that LP and the root's one cut pass found it
    # gone (no simplex iteration after the drop; the large suite's
    # b45-h1440 of seed 241, whose start CBC takes given 20 s): no
    # refusal; the same drop with a search after it is one.
    root = (LOGS / "start_fix_out_of_time_at_root.log").read_text()
    assert "Trying just fixing integer variables" in root
    assert "Cbc0013I At root node" in root
    assert not cbclog.start_refused(root)
    assert cbclog.start_refused(
        root.replace("took 0 iterations", "took 1523 iterations")
    )
    # Stopped by the interrupt at the deadline while CBC looked at the
    # start (no try of it): no refusal.
    stopped = (LOGS / "start_interrupted.log").read_text()
    assert "Exiting on user event" in stopped
    assert not cbclog.start_refused(stopped)
    assert cbclog.start_refused(stopped.replace("Exiting on user event", ""))
    # The same drop with the search going on is one.
    assert cbclog.start_refused(
        cut.replace(
            "Cbc0020I Exiting on maximum time",
            "Cbc0013I At root node, 3 cuts changed objective from 1 to 2",
        )
    )


def test_a_start_with_users_running_together_is_taken(
    caplog: pytest.LogCaptureFixture,
) -> None:
    """Tests that CBC takes a disjunctive warm start in which two users of
    a multiple resource run together (they fit, three do not) as given:
    no warning, and an optimal, valid plan."""
    tasks = [
        make_task(
            name, length=2, schedule_cost=0, uses={"power": 50, "heat": 4}
        )
        for name in ("a", "b", "c")
    ]
    problem = problem_from(
        make_doc(
            tasks, horizon=6, resources={"multiple": {"power": 100, "heat": 9}}
        )
    )
    with caplog.at_level("WARNING", logger="fsw_scheduler.solver"):
        plan = solve_ilp(
            problem,
            formulation="disjunctive",
            warm={"a": 0, "b": 0, "c": 2},
        )
    assert cbc.START_REFUSED not in caplog.text
    assert plan.status is SolveStatus.OPTIMAL
    assert check_plan(problem, plan).ok


def _two_of_three() -> Program:
    """Two of three binaries, the cheapest: a program CBC proves at once."""
    program = Program()
    cols = [program.add_column(0, 1, integer=True) for _ in range(3)]
    program.add_row(dict.fromkeys(cols, 1), EQ, 2)
    program.set_objective({c: k + 1 for k, c in enumerate(cols)})
    return program


def _replaying(monkeypatch: pytest.MonkeyPatch, name: str) -> None:
    """Each CBC run goes as it does, then its log is replaced by the
    recorded log ``name`` (a real run's, written where CBC's own goes)."""
    real = cbc.CbcRun._run

    def run_then_replay(
        self: CbcRun, args: list[str], log: str, deadline: float | None
    ) -> int:
        code = real(self, args, log, deadline)
        Path(log).write_text((LOGS / name).read_text())
        return code

    monkeypatch.setattr(cbc.CbcRun, "_run", run_then_replay)


def test_a_run_whose_cuts_overshoot_reports_the_root_bound(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """Tests that CbcRun reports the root LP bound and no proof when its
    log shows cuts above the plan it holds (the real log of that run,
    written where CBC's own goes)."""
    program = _two_of_three()
    _replaying(monkeypatch, "cuts_overshoot.log")
    result = CbcRun().solve(program)
    assert result.bound == -3697587 - 1 + program.constant
    assert result.status is not cbc.SolveStatus.OPTIMAL
    assert "cuts cut off valid plans" in result.solver_status


def test_a_run_that_restarted_with_its_cuts_claims_no_optimum(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """Tests that CbcRun reports no proof and the first root LP bound when
    its log shows a restart that kept the root's cuts (the real log of
    the relaxation run that proved a wrong optimum), with cuts off as
    in that run (so not run again)."""
    program = _two_of_three()
    _replaying(monkeypatch, "restart_with_cuts.log")
    run = CbcRun()
    run.options.append(cbc.CUTS_OFF)
    result = run.solve(program)
    assert result.restarted
    assert result.status is cbc.SolveStatus.FEASIBLE
    assert result.values is not None
    assert result.bound == -667483 - 1 + program.constant
    assert "restarted with its root cuts: no proof" in result.solver_status


def test_a_run_that_restarted_is_run_again_without_the_restart(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """Tests that a real CBC run that restarted with its root cuts (the
    broad campaign's b15-multiple-6 of seed 217, CBC's seed that
    campaign's) is run again from its plan with CBC's restart off and its
    cuts on, first among the options, and that its answer is the
    optimum (1,415, CP-SAT's) proved by that run."""
    problem = decode_problem(
        (
            Path(__file__).parent / "data" / "restart-b15-multiple-6.json"
        ).read_bytes()
    )
    runs: list[list[str]] = []
    solve_once = CbcRun._solve_once

    def recorded(self: CbcRun, *args: object, **kwargs: object) -> object:
        runs.append(list(self.options))
        return solve_once(self, *args, **kwargs)  # type: ignore[arg-type]

    monkeypatch.setattr(CbcRun, "_solve_once", recorded)
    # From the rules' start plan, as in that campaign: from the plan of
    # the orders drawn around it CBC proves the optimum without a restart.
    monkeypatch.setattr(incumbent, "SMALL_STALE", 0)
    plan = solve(problem, time_limit=60.0, seed=236446864)
    assert plan.stats is not None and plan.objective is not None
    said = plan.stats.solver_status
    assert "restarted with its root cuts" in said, said
    assert said.endswith("again without the restart: Optimal"), said
    assert plan.status is SolveStatus.OPTIMAL
    assert plan.objective.total == 1415
    assert check_plan(problem, plan).ok
    assert runs[-1][0] == cbc.NO_RESTART
    assert runs[-1][1:] == runs[-2] and cbc.CUTS_OFF not in runs[-1]


def test_a_search_cbc_completed_is_read_from_its_log() -> None:
    """Tests that the best objective of a search CBC completed is read
    from a real log whose last LP then stopped on time (a 30-task part
    over H = 300, ``tools/fuzz --large`` seed 1414: its solution file
    held that LP's fractional values under "Optimal"), and that a
    stopped search ("Partial search") gives none."""
    said = cbclog.read_log(str(LOGS / "completed_then_stopped.log"))
    assert said.completed == -1574603
    assert not said.restarted and not said.overshot
    for name in ("start_interrupted.log", "start_out_of_time.log"):
        assert "Partial search" in (LOGS / name).read_text()
        assert cbclog.read_log(str(LOGS / name)).completed is None


def test_a_small_search_completed_is_no_proof_of_the_run() -> None:
    """Tests that a "Search completed" of one of CBC's small searches
    (c15-all-5 of the paper campaign, seed 215: one at 8 nodes before the
    main search's at 58) is not read as the run's: the whole log reads
    the main search's; cut after the small search's line (a run killed
    in its main search), or followed by a "Partial search", it reads
    none."""
    text = (LOGS / "completed_after_a_small_search.log").read_text()
    assert text.count("Search completed") == 2
    assert cbclog.completed(text) == -593428
    small, _, _ = text.partition("Cbc0012I Integer solution of -593428")
    assert "Search completed" in small
    assert cbclog.completed(small) is None
    partial = small + (
        "Cbc0005I Partial search - best objective -593428 (best possible "
        "-593532), took 300 iterations and 60 nodes (0.03 seconds)\n"
        "\nResult - Stopped on time limit\n"
    )
    assert cbclog.completed(partial) is None


def test_a_completed_search_proves_the_start_its_file_lost() -> None:
    """Tests that a run whose search completed at the MIP start's
    objective, its solution file refused, answers the start as optimal
    with the optimum as its bound; that an optimum below the start only
    bounds (the plan CBC found is lost); and that values written below
    the optimum (an LP's) are never taken."""
    program = _two_of_three()  # the optimum 3: the first two columns
    start = [1.0, 1.0, 0.0]
    lost = cbc.CbcResult(SolveStatus.UNKNOWN, None, completed=3.0)
    notes: list[str] = []
    cbc.read_completed(program, lost, start, notes)
    assert lost.status is SolveStatus.OPTIMAL
    assert lost.values == start and lost.bound == 3.0
    assert notes == ["its search completed: the start is optimal"]
    worse = cbc.CbcResult(SolveStatus.UNKNOWN, None, completed=3.0)
    cbc.read_completed(program, worse, [1.0, 0.0, 1.0], [])
    assert worse.status is SolveStatus.UNKNOWN and worse.values is None
    assert worse.bound == 3.0
    below = cbc.CbcResult(SolveStatus.FEASIBLE, [1.0, 0.0, 0.0], completed=3.0)
    cbc.read_completed(program, below, None, [])
    assert below.status is SolveStatus.FEASIBLE
    # CBC's objective of no solution is no optimum.
    none = cbc.CbcResult(SolveStatus.UNKNOWN, None, completed=1e50)
    cbc.read_completed(program, none, start, [])
    assert none.status is SolveStatus.UNKNOWN and none.bound is None


def test_a_run_whose_cuts_cut_off_plans_is_run_again_without_cuts() -> None:
    """Tests that a problem whose first CBC run refuses its own bound
    (root cuts cut off a plan CBC held: the campaign's paper
    c15-multiple-4 of seed 7, ``feasible`` after 0.2 s of 20 s) is run
    again with cuts off and proved, the status saying both runs, and the
    plan the checker's."""
    generator = bench_lib("generator")
    bench = next(
        b for b in generator.campaign(7, "paper") if b.name == "c15-multiple-4"
    )
    problem = bench.problem()
    plan = solve(problem, time_limit=20)
    assert plan.status is SolveStatus.OPTIMAL, plan.stats
    assert plan.stats is not None
    assert "cuts cut off valid plans" in plan.stats.solver_status
    assert "again with cuts off" in plan.stats.solver_status
    assert check_plan(problem, plan).ok


def _market_split() -> Program:
    """The market split program of ``_PARENT`` (minutes to refute)."""
    rng = random.Random(7)
    program = Program()
    cols = [program.add_column(0, 1, integer=True) for _ in range(40)]
    for _ in range(5):
        weights: dict[int, float] = {c: rng.randint(0, 99) for c in cols}
        program.add_row(weights, EQ, sum(weights.values()) // 2)
    program.set_objective(dict.fromkeys(cols, 1.0))
    return program


def test_a_crashed_run_is_retried_in_what_is_left(tmp_path: Path) -> None:
    """Tests that CBC crashing after 2 s of a 4 s limit is run again only
    for what is left: the answer comes within the limit (the retry got
    the first run's whole share again, and a 20 s solve answered after
    20.6 s). The crash is CBC's own signal, raised by a wrapper around
    the real CBC on its first call."""
    marker = tmp_path / "crashed"
    wrapper = tmp_path / "cbc"
    wrapper.write_text(
        textwrap.dedent(
            f"""\
            #!/bin/sh
            if [ ! -e {marker} ]; then
                touch {marker}
                sleep 2
                kill -SEGV $$
            fi
            exec {cbc.cbc_path()} "$@"
            """
        )
    )
    wrapper.chmod(0o755)
    began = time.monotonic()
    result = CbcRun(time_limit=4.0, path=str(wrapper)).solve(_market_split())
    took = time.monotonic() - began
    assert marker.exists()
    assert result.retried
    assert took < 4.0 + 0.5, took


def test_a_model_its_grace_leaves_no_time_for_is_not_started() -> None:
    """Tests that a model so large that its interrupt, early by its kill's
    grace (1.5e-5 s an entry), would come before CBC has read it is not
    started: the run says so at once, where CBC was started and
    interrupted at once (a 42,010-column model given 3.7 s of a 20 s
    solve, the answer 3.7 s early)."""
    program = Program()
    cols = [program.add_column(0, 1, integer=True) for _ in range(2000)]
    for row in range(200):
        program.add_row({c: 1.0 + (c + row) % 7 for c in cols}, EQ, 1000)
    program.set_objective(dict.fromkeys(cols, 1.0))
    assert program.num_entries == 400_000
    began = time.monotonic()
    result = CbcRun(time_limit=4.0).solve(program)
    assert result.status is SolveStatus.UNKNOWN
    assert result.solver_status == "time limit spent before CBC started"
    assert time.monotonic() - began < 4.0


def test_an_interrupted_run_proves_no_infeasibility(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """Tests that a run interrupted at its deadline whose solution file
    says "Integer infeasible" (what CBC writes when the interrupt comes
    in its root, seen on a 13,660-column model with a valid plan known)
    answers ``unknown``, not ``infeasible``: the real CBC runs, then its
    solution file is the one of that run."""
    program = _two_of_three()
    real = cbc.CbcRun._run

    def run_then_interrupted(
        self: CbcRun, args: list[str], log: str, deadline: float | None
    ) -> int:
        code = real(self, args, log, deadline)
        self.interrupted = True
        solution = args[args.index("-solution") + 1]
        Path(solution).write_text(
            "Integer infeasible - objective value -2782169.95915692\n"
        )
        return code

    monkeypatch.setattr(cbc.CbcRun, "_run", run_then_interrupted)
    result = CbcRun().solve(program)
    assert result.interrupted
    assert result.status is SolveStatus.UNKNOWN
    assert "interrupted: no proof" in result.solver_status


def test_a_run_in_its_search_is_interrupted_at_its_deadline() -> None:
    """Tests that a CBC run of more than a second that is in its search
    when the early interrupt is due (the market split program: its root
    takes milliseconds, its search minutes) is interrupted just before
    its deadline, not 0.7 s earlier, and still ends within its limit."""
    run = WatchedCbcRun(time_limit=3.0)
    began = time.monotonic()
    result = run.solve(_market_split())
    took = time.monotonic() - began
    assert result.interrupted
    assert "killed" not in result.solver_status
    # Margin 0.3 s: interrupted at 2.6 s (the early interrupt: 2.0 s).
    assert 2.4 <= took <= 3.0 + progress.KILL_MARGIN_S, took
