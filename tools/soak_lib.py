"""What the soak scripts share: loading a sibling script, a router, RSS.

The scripts of ``tools/`` have no ``.py`` suffix, so they are loaded by
path (:func:`load_script`); tests load them the same way.
"""

from __future__ import annotations

import importlib.machinery
import importlib.util
import sys
from pathlib import Path
from typing import TYPE_CHECKING

import zenoh

from fsw_scheduler.bus.session import listening_endpoints, loopback_config

if TYPE_CHECKING:
    from types import ModuleType

TOOLS = Path(__file__).resolve().parent


def load_script(name: str, module: str | None = None) -> ModuleType:
    """The script ``tools/<name>`` loaded as the module ``module``."""
    module = module or name
    loader = importlib.machinery.SourceFileLoader(module, str(TOOLS / name))
    spec = importlib.util.spec_from_loader(module, loader)
    assert spec is not None
    loaded = importlib.util.module_from_spec(spec)
    # dataclasses look their module up in sys.modules.
    sys.modules[module] = loaded
    loader.exec_module(loaded)
    return loaded


def start_router() -> tuple[zenoh.Session, int]:
    """A Zenoh router on loopback, as between the computers of a craft."""
    config = loopback_config(listen="tcp/127.0.0.1:0")
    config.insert_json5("mode", '"router"')
    router = zenoh.open(config)
    (endpoint,) = listening_endpoints(router)
    return router, int(endpoint.rsplit(":", 1)[1])


def _status_mb(pid: int, field: str) -> float:
    for line in Path(f"/proc/{pid}/status").read_text().splitlines():
        if line.startswith(field + ":"):
            return int(line.split()[1]) / 1024
    return 0.0


def rss_mb(pid: int) -> float:
    """The resident memory of process ``pid`` now, in MB (Linux)."""
    return _status_mb(pid, "VmRSS")


def peak_mb(pid: int) -> float:
    """The peak resident memory of process ``pid``, in MB (Linux)."""
    return _status_mb(pid, "VmHWM")
