"""Secure deployment on the bus: profile files, a live configuration's check.

The deployment itself (roles, their access control, the profile text,
the certificate script, the start-up judgement) is pure and lives in
:mod:`fsw_scheduler.runtime.access`; every name of it is importable from
here too. What is left here needs Zenoh or writes files:
:func:`write_profile` writes every role's configuration and the
certificate script to a folder, :func:`assess` reads the settings of a
live ``zenoh.Config``, and :func:`policy_publishers` matches keys against
its access-control policy with Zenoh's own key expressions.
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import TYPE_CHECKING, Any

from ..runtime.access import (
    DEFAULT_PORT,
    PROFILES,
    ROLES,
    ROUTER,
    SCHEDULER_INPUTS,
    SCHEDULER_OUTPUTS,
    TOPOLOGIES,
    Role,
    access_control,
    assess_settings,
    certs_script,
    is_loopback,
    local_gaps,
    render_profile,
    roles_of,
)
from ..wire import topics

if TYPE_CHECKING:
    from collections.abc import Callable, Iterable, Mapping

    import zenoh

    from ..wire import messages

__all__ = [
    "DEFAULT_PORT",
    "PROFILES",
    "ROLES",
    "ROUTER",
    "SCHEDULER_INPUTS",
    "SCHEDULER_OUTPUTS",
    "TOPOLOGIES",
    "Role",
    "access_control",
    "assess",
    "certs_script",
    "is_loopback",
    "local_gaps",
    "policy_publishers",
    "render_profile",
    "roles_of",
    "write_profile",
]


def write_profile(
    out: str | Path,
    *,
    profile: str = "secure",
    spacecraft: str = topics.DEFAULT_SPACECRAFT,
    certs: str | Path | None = None,
    endpoint: str = f"tls/localhost:{DEFAULT_PORT}",
    listen: str | None = None,
    names: Mapping[str, Iterable[str]] | None = None,
    topology: str = "star",
) -> list[Path]:
    """Write ``<role>.json5`` for every role and ``make-certs.sh`` to ``out``.

    Returns
    -------
    list of Path
        The files written.
    """
    folder = Path(out)
    folder.mkdir(parents=True, exist_ok=True)
    certs_dir = Path(certs) if certs is not None else folder / "certs"
    certs_abs = certs_dir.resolve()
    written = []
    for role in roles_of(topology):
        path = folder / f"{role}.json5"
        path.write_text(
            render_profile(
                role,
                profile=profile,
                spacecraft=spacecraft,
                certs=certs_abs,
                endpoint=endpoint,
                listen=listen,
                names=names,
                topology=topology,
            )
        )
        written.append(path)
    script = folder / "make-certs.sh"
    script.write_text(
        certs_script(certs_abs, endpoint, names, topology=topology)
    )
    script.chmod(0o755)
    written.append(script)
    return written


# -- the start-up check -------------------------------------------------------


def _get(config: zenoh.Config, key: str) -> Any:
    try:
        return json.loads(config.get_json(key))
    except Exception:  # an unknown key: treat as unset
        return None


def assess(
    config: zenoh.Config, *, acknowledged: bool = False
) -> messages.SecurityInfo:
    """How a Zenoh configuration protects the scheduler.

    Reads from ``config`` what
    :func:`~fsw_scheduler.runtime.access.assess_settings` judges: the
    mode, the endpoints, multicast scouting, TLS and access control.

    Parameters
    ----------
    config
        The configuration the node will open its session with.
    acknowledged
        The operator accepted running open (``run --insecure``).
    """
    return assess_settings(
        lambda key: _get(config, key), acknowledged=acknowledged
    )


def policy_publishers(
    config: zenoh.Config,
) -> Callable[[str], frozenset[str] | None] | None:
    """Who the access-control policy lets publish on a key, by name.

    Parameters
    ----------
    config
        The node's Zenoh configuration.

    Returns
    -------
    callable or None
        None without a default-deny policy. Otherwise a function from a
        key to the certificate common names allowed to ``put`` on it
        (ingress), or None for a key that a subject without names (a
        wildcard) may publish on. Deny rules are not subtracted: the
        answer may name too many, never too few.
    """
    import zenoh

    acl = _get(config, "access_control") or {}
    if not acl.get("enabled") or acl.get("default_permission") != "deny":
        return None
    rules = {r["id"]: r for r in acl.get("rules") or []}
    subjects = {s["id"]: s for s in acl.get("subjects") or []}
    grants: list[tuple[list[zenoh.KeyExpr], frozenset[str] | None]] = []
    for policy in acl.get("policies") or []:
        names: set[str] | None = set()
        for subject_id in policy.get("subjects") or []:
            cns = subjects.get(subject_id, {}).get("cert_common_names")
            if not cns:
                names = None
                break
            names.update(cns)  # type: ignore[union-attr]
        for rule_id in policy.get("rules") or []:
            rule = rules.get(rule_id, {})
            flows = rule.get("flows") or ["ingress", "egress"]
            if (
                "put" in (rule.get("messages") or [])
                and "ingress" in flows
                and rule.get("permission") == "allow"
            ):
                grants.append(
                    (
                        [zenoh.KeyExpr(k) for k in rule["key_exprs"]],
                        None if names is None else frozenset(names),
                    )
                )

    def publishers(key: str) -> frozenset[str] | None:
        target = zenoh.KeyExpr(key)
        found: set[str] = set()
        for exprs, names in grants:
            if any(expr.includes(target) for expr in exprs):
                if names is None:
                    return None
                found |= names
        return frozenset(found)

    return publishers
