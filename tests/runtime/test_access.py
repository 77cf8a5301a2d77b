"""Tests of the secure deployment's pure part: roles, profiles, the check."""

from __future__ import annotations

import subprocess
import sys
from typing import Any

import pytest

from fsw_scheduler.runtime.access import (
    access_control,
    assess_settings,
    is_loopback,
    local_gaps,
)

#: The settings of a secure loopback node, as Zenoh's lookup returns them.
SECURE = {
    "mode": "peer",
    "listen/endpoints": ["tls/127.0.0.1:7447"],
    "connect/endpoints": [],
    "scouting/multicast/enabled": False,
    "transport/link/tls": {
        "enable_mtls": True,
        "root_ca_certificate": "certs/ca.pem",
    },
    "access_control": access_control("scheduler"),
}


def settings(**changes: Any) -> dict[str, Any]:
    """:data:`SECURE` with keys given as ``listen_endpoints=...``."""
    out = dict(SECURE)
    for name, value in changes.items():
        out[name.replace("_endpoints", "/endpoints")] = value
    return out


def test_loads_without_zenoh() -> None:
    """Tests that importing the deployment's pure part loads no Zenoh."""
    code = (
        "import sys, fsw_scheduler.runtime.access; "
        "sys.exit('zenoh' in sys.modules)"
    )
    subprocess.run([sys.executable, "-c", code], check=True)


def test_secure_loopback_settings_pass() -> None:
    """Tests that mutual TLS and a default-deny policy on loopback give no
    warning and no gap."""
    info = assess_settings(SECURE.get)
    assert not info.exposed
    assert (info.tls, info.mutual_tls, info.access_control) == (
        True,
        True,
        True,
    )
    assert info.warnings == () and local_gaps(info) == ()


def test_unset_multicast_counts_as_on() -> None:
    """Tests that multicast scouting unset (Zenoh's default: on) exposes
    the bus, and that an exposed bus has no loopback gaps."""
    given = settings()
    del given["scouting/multicast/enabled"]
    info = assess_settings(given.get)
    assert info.exposed and info.warnings == ()
    assert local_gaps(info) == ()


@pytest.mark.parametrize(
    ("changes", "warned"),
    [
        (
            {"listen_endpoints": ["tcp/0.0.0.0:7447"]},
            ["without TLS (plain endpoints: tcp/0.0.0.0:7447)"],
        ),
        (
            {
                "listen_endpoints": ["tls/10.0.0.2:7447"],
                "transport/link/tls": {"enable_mtls": False},
            },
            ["TLS without mutual authentication"],
        ),
        (
            {
                "listen_endpoints": ["tls/10.0.0.2:7447"],
                "access_control": {"enabled": True, "default_permission": ""},
            },
            ["(tls/10.0.0.2:7447) without access control"],
        ),
        (
            {"listen_endpoints": ["tcp/10.0.0.2:7447"], "access_control": {}},
            ["without TLS", "without access control"],
        ),
    ],
)
def test_exposed_settings_warn_once_per_missing_piece(
    changes: dict[str, Any], warned: list[str]
) -> None:
    """Tests that an exposed bus gets one warning per missing piece, and
    that the operator's acknowledgement is kept only with a warning."""
    info = assess_settings(settings(**changes).get, acknowledged=True)
    assert info.exposed and info.acknowledged
    assert len(info.warnings) == len(warned)
    for warning, part in zip(info.warnings, warned, strict=True):
        assert part in warning
    assert not assess_settings(SECURE.get, acknowledged=True).acknowledged


def test_endpoints_per_mode() -> None:
    """Tests that Zenoh's per-mode endpoint defaults are read for the
    node's own mode."""
    per_mode = {"peer": ["tcp/10.0.0.2:7447"], "client": []}
    exposed = assess_settings(settings(listen_endpoints=per_mode).get)
    assert exposed.exposed and not exposed.tls
    given = settings(listen_endpoints=per_mode, mode="client")
    given["connect/endpoints"] = {"client": ["tls/localhost:7447"]}
    assert not assess_settings(given.get).exposed


def test_loopback_gaps() -> None:
    """Tests that a loopback bus without mutual TLS or access control is
    named by each gap, for ``run --require-secure``."""
    info = assess_settings(
        settings(
            listen_endpoints=["tcp/127.0.0.1:7447"], access_control={}
        ).get
    )
    assert not info.exposed and info.warnings == ()
    gaps = local_gaps(info)
    assert len(gaps) == 2
    assert "without mutual TLS" in gaps[0]
    assert "without access control" in gaps[1]


@pytest.mark.parametrize(
    ("endpoint", "loopback"),
    [
        ("tcp/127.0.0.1:7447", True),
        ("tls/localhost:7447", True),
        ("tcp/[::1]:7447", True),
        ("unixsock-stream//tmp/zenoh.sock", True),
        ("tcp/0.0.0.0:7447", False),
        ("tcp/[::]:7447", False),
        ("tls/10.0.0.2:7447#iface=eth0", False),
        ("tcp/scheduler.local:7447", False),
    ],
)
def test_is_loopback(endpoint: str, loopback: bool) -> None:
    """Tests which endpoints count as reaching this machine only."""
    assert is_loopback(endpoint) is loopback
