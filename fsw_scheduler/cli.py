"""The ``fsw-scheduler`` command (``python -m fsw_scheduler.cli`` too).

The command line lives in :mod:`fsw_scheduler.app.cli`; this module keeps
the entry point's path (``[project.scripts]``) and ``build_parser``.
"""

from __future__ import annotations

import sys

from .app.cli.main import main as main
from .app.cli.parser import build_parser as build_parser

if __name__ == "__main__":
    sys.exit(main())
