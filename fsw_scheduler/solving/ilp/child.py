"""CBC's child process: it dies with its parent, and an orphan is swept.

On Linux the kernel kills CBC when the thread that started it goes
(``PR_SET_PDEATHSIG``), so a node killed with SIGKILL leaves no CBC
running on. The signal is set by util-linux ``setpriv --pdeathsig
KILL``, which then execs CBC, so the process is spawned without a
``preexec_fn``: Python then uses ``vfork``, where a ``preexec_fn`` forces
a full ``fork`` of the interpreter, and runs no Python code in the
child. That code was not only slow: a child forked while another thread
held a lock could hang before its exec (1 run in 400 of a trivial model,
cut by the deadline as "no solution"). Without ``setpriv`` the
``preexec_fn`` is the fallback. The signal cannot reach a CBC whose
parent died in the instant before ``setpriv`` set it;
:func:`sweep_stale_dirs` kills such orphans when the next process starts
(they read their model from a stale directory).
"""

from __future__ import annotations

import contextlib
import ctypes
import functools
import os
import shutil
import signal
import subprocess
import sys
import tempfile
from pathlib import Path
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from collections.abc import Callable


def dir_prefix() -> str:
    """Temporary directories carry the pid that made them."""
    return f"fsw-cbc-{os.getpid()}-"


def sweep_stale_dirs(root: str | None = None) -> list[str]:
    """Remove CBC directories left by processes that no longer run.

    A process killed with SIGKILL cannot remove its temporary directory;
    the next one started cleans up after it. Only directories whose pid
    is gone are touched.

    Returns
    -------
    list of str
        The directories removed.
    """
    base = Path(root or tempfile.gettempdir())
    removed = []
    for path in base.glob("fsw-cbc-*-*"):
        pid = path.name.split("-")[2]
        if not pid.isdigit() or _running(int(pid)):
            continue
        _kill_orphans(str(path) + os.sep)
        shutil.rmtree(path, ignore_errors=True)
        removed.append(str(path))
    return removed


def _kill_orphans(prefix: str) -> None:
    """Kill the processes with an argument under ``prefix`` (Linux).

    A CBC outlives its parent only if the parent died just as it was
    started, before the parent-death signal was set; its model file is
    then in the dead parent's directory.
    """
    proc = Path("/proc")
    if not proc.is_dir():
        return
    for entry in proc.iterdir():
        if not entry.name.isdigit():
            continue
        try:
            args = (entry / "cmdline").read_bytes().split(b"\0")
        except OSError:  # gone, or not ours to read
            continue
        if any(arg.startswith(os.fsencode(prefix)) for arg in args):
            with contextlib.suppress(OSError):
                os.kill(int(entry.name), signal.SIGKILL)


def _running(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except OSError:  # exists, owned by someone else
        return True
    return True


@functools.cache
def _prctl() -> Callable[..., int] | None:
    """libc's ``prctl`` (Linux), None elsewhere."""
    if not sys.platform.startswith("linux"):
        return None
    try:
        return ctypes.CDLL(None, use_errno=True).prctl
    except (OSError, AttributeError):
        return None


def _die_with_parent() -> Callable[[], None] | None:
    """A ``preexec_fn`` asking the kernel to kill CBC with its parent.

    The signal comes when the thread that started CBC ends, which for a
    solve is never before CBC does, or when the process dies, SIGKILL
    included.
    """
    prctl = _prctl()
    if prctl is None:
        return None
    parent = os.getpid()

    def preexec() -> None:
        # Runs in the child between fork and exec: a system call and a
        # comparison, nothing that could need a lock held by a thread.
        prctl(_PR_SET_PDEATHSIG, signal.SIGKILL)
        if os.getppid() != parent:  # the parent died before the prctl
            os._exit(1)

    return preexec


_PR_SET_PDEATHSIG = 1


@functools.cache
def _setpriv() -> str | None:
    """util-linux ``setpriv``, when it can set the parent-death signal.

    Asked once per process (``setpriv --help``, a few milliseconds).
    """
    if not sys.platform.startswith("linux"):
        return None
    found = shutil.which("setpriv")
    if found is None:
        return None
    try:
        usage = subprocess.run(
            [found, "--help"],
            capture_output=True,
            text=True,
            timeout=5,
            check=False,
        ).stdout
    except (OSError, subprocess.SubprocessError):
        return None
    return found if "--pdeathsig" in usage else None


def guarded(args: list[str]) -> tuple[list[str], Callable[[], None] | None]:
    """(command, preexec_fn) that start ``args`` to die with this process.

    ``setpriv`` where the system has it, else a ``preexec_fn`` (Linux), else
    nothing (the deadline and :class:`~.cbc.Cancel` still end CBC).
    """
    setpriv = _setpriv()
    if setpriv is not None:
        return [setpriv, "--pdeathsig", "KILL", "--", *args], None
    return args, _die_with_parent()
