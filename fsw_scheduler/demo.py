"""The paper demo, at the path the README has always shown.

The demo lives in :mod:`fsw_scheduler.app.demo`; this module keeps
``from fsw_scheduler.demo import run_demo`` working.
"""

from .app.demo import run_demo as run_demo

__all__ = ["run_demo"]
