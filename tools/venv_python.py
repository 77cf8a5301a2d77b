"""Run a tool with the project's virtual environment, from any Python.

The tools are scripts that import the package and its dependencies; run
as ``tools/soak_partition`` (the first line's ``python3``) they would not
find them. :func:`into_venv`, called before those imports, runs the
script again with ``.venv/bin/python`` when that exists and is not the
interpreter already running it.
"""

from __future__ import annotations

import os
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
VENV_PYTHON = ROOT / ".venv" / "bin" / "python"
#: Set in the environment of the run again, so that it happens once.
ONCE = "FSW_TOOL_NO_REEXEC"


def into_venv(script: str, name: str) -> None:
    """Run ``script`` (the caller's ``__file__``) again with the project's
    virtual environment, with the same arguments, when it runs as the
    main program (``name``, the caller's ``__name__``) and that is not
    the interpreter running it; return at once otherwise (a test that
    loads the script as a module keeps its own process)."""
    if (
        name == "__main__"
        and VENV_PYTHON.exists()
        and Path(sys.prefix).resolve() != (ROOT / ".venv").resolve()
        and not os.environ.get(ONCE)
    ):
        os.environ[ONCE] = "1"
        os.execv(str(VENV_PYTHON), [str(VENV_PYTHON), script, *sys.argv[1:]])
