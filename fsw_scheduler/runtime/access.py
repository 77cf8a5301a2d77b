"""Secure deployment without Zenoh: roles, their access control, profiles.

In the ``star`` topology the scheduler listens on one TLS endpoint and
every other component connects to it as a Zenoh client; in the ``router``
topology a Zenoh router listens and every component, the scheduler and
its redundant twins included, connects to it. Each component holds a
certificate signed by the deployment's CA whose common name (CN) names
its role; Zenoh's access control, default deny, is then written in terms
of those names. The hub's policy is what protects the spacecraft, because
every message crosses one of its links; each component's policy mirrors
it, so that a misconfigured component cannot even send what the hub
would refuse.

How Zenoh applies the rules (checked against ``zenoh/src/net/routing/
interceptor/access_control.rs`` and on the bus, see
``tests/bus/test_security.py``): every message crossing a link is matched
against the rules of the subjects the link's remote end belongs to;
``ingress`` is what a node accepts, ``egress`` what it sends; a message is
allowed when a rule key expression *includes* its key (so a subscriber on
``fsw/sat1/scheduler/**`` needs a rule on that expression or a wider one).
Besides ``put``, a node's own entities travel as messages too: its
subscriber, queryable and liveliness token are declarations that must be
allowed to leave it, and query replies are ``reply`` messages. The table
below therefore gives, per role, what it sends to the hub and what the
hub sends to it.

The profile template is package data (``profiles/<name>.json5``);
:func:`render_profile` fills it per role and :func:`certs_script` writes
the script that makes the certificates. The start-up check
(:func:`assess_settings`, :func:`local_gaps`) judges a configuration's
settings. Pure: no Zenoh, no clock, no file written. What reads a live
``zenoh.Config`` or writes the files is in
:mod:`fsw_scheduler.bus.security`, which re-exports every name here.
"""

from __future__ import annotations

import ipaddress
import json
import shlex
import string
import textwrap
from dataclasses import dataclass, field
from importlib import resources
from pathlib import Path
from typing import TYPE_CHECKING, Any

from ..errors import ConfigError
from ..model.limits import id_issue
from ..wire import messages, topics

if TYPE_CHECKING:
    from collections.abc import Callable, Iterable, Mapping

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
    "assess_settings",
    "certs_script",
    "is_loopback",
    "local_gaps",
    "render_profile",
    "roles_of",
]

#: Profiles shipped in ``fsw_scheduler/profiles``.
PROFILES = ("secure",)

#: ``star``: the scheduler listens and every other role connects to it.
#: ``router``: a Zenoh router listens and every role, the scheduler (or
#: its redundant twins) included, connects to it.
TOPOLOGIES = ("star", "router")

#: What every authorised component may read: the scheduler's outputs
#: (subscribe, query, and watch its liveliness token).
SCHEDULER_OUTPUTS = "scheduler/**"

#: Keys the scheduler subscribes to. Its subscriber declarations go to
#: every role, so that a put a role may not make is still sent and is
#: refused by the scheduler's ingress rules rather than never leaving.
SCHEDULER_INPUTS = (topics.GOALS, topics.CLOCK, topics.TELEMETRY)

DEFAULT_PORT = 7447


@dataclass(frozen=True)
class Role:
    """One kind of component on the bus.

    Attributes
    ----------
    name
        Role name; also the default certificate common name and the stem
        of its configuration and certificate files.
    summary
        One line for the README and the configuration's header.
    puts
        Key expressions (relative to ``fsw/<sc>/``) it may publish on.
    reads
        Key expressions it may subscribe to.
    answers
        Key expressions it answers the scheduler's queries on (declares
        a queryable and replies; the hub sends it the queries).
    """

    name: str
    summary: str
    puts: tuple[str, ...] = ()
    reads: tuple[str, ...] = (SCHEDULER_OUTPUTS,)
    answers: tuple[str, ...] = ()


ROLES: dict[str, Role] = {
    role.name: role
    for role in (
        Role(
            "scheduler",
            "The scheduler ('fsw-scheduler run'): listens for every other "
            "role and is the only one that publishes on scheduler/**.",
            puts=(SCHEDULER_OUTPUTS,),
            reads=SCHEDULER_INPUTS,
        ),
        Role(
            "goals",
            "Ground or on-board autonomy: publishes goals on "
            "scheduler/goals; reads plans and status.",
            puts=(topics.GOALS,),
        ),
        Role(
            "executor",
            "The activity executor: reads dispatches, publishes execution "
            "reports on telemetry/activities/<task>, answers a starting "
            "scheduler's scheduler/fences/<id> with the highest term it "
            "has seen.",
            puts=(topics.ACTIVITY_REPORTS + "/**",),
            # A scheduler with a restored or lost folder learns from the
            # receivers the term already in use, and never reuses it. A
            # forged answer can only raise the next term, by at most
            # wire.terms.MAX_TERM_JUMP.
            answers=(topics.FENCES + "/**",),
        ),
        Role(
            "clock",
            "The bus clock source: publishes clock.",
            puts=(topics.CLOCK,),
        ),
        Role(
            "telemetry",
            "A telemetry source: publishes measured levels on "
            "telemetry/resources/<name> and forecasts on "
            "telemetry/resources/<name>/forecast.",
            puts=(topics.RESOURCE_LEVELS + "/**",),
        ),
        Role(
            "monitor",
            "A read-only monitor or recorder: reads everything the "
            "scheduler publishes, publishes nothing.",
            reads=("**",),
        ),
    )
}

#: The hub of the router topology (not a component: no role of its own).
ROUTER = Role(
    "router",
    "The Zenoh router of the router topology: every role, the scheduler "
    "included, connects to it, and its policy is the one that protects "
    "the spacecraft.",
    reads=(),
)


def roles_of(topology: str = "star") -> list[str]:
    """The roles that get a configuration and a certificate."""
    if topology not in TOPOLOGIES:
        raise ConfigError(
            f"unknown topology {topology!r}; topologies: "
            f"{', '.join(TOPOLOGIES)}"
        )
    return [*ROLES, *(["router"] if topology == "router" else [])]


#: Messages a role sends to the scheduler, besides its puts.
_TO_SCHEDULER_READS = ("declare_subscriber",)
_TO_SCHEDULER_QUERIES = (
    "query",
    "declare_liveliness_subscriber",
    "liveliness_query",
)
#: Messages the scheduler sends to every role.
_FROM_SCHEDULER_OUTPUTS = (
    "put",
    "reply",
    "declare_queryable",
    "liveliness_token",
)


@dataclass(frozen=True)
class _Grant:
    """Messages on keys, sent by ``sender`` to ``receiver``."""

    sender: str
    receiver: str
    messages: tuple[str, ...]
    keys: tuple[str, ...]
    label: str


def _grants(role: Role, hub: str = "scheduler") -> list[_Grant]:
    """What flows between ``role`` and the ``hub`` it connects to.

    The hub is the scheduler (star) or a router that forwards between the
    scheduler and the roles (router): a role's grants are the same.
    """
    if role.name == "scheduler" and hub == "router":
        return _scheduler_via_router()
    out = []
    if role.puts:
        out.append(_Grant(role.name, hub, ("put",), role.puts, "put"))
    out += [
        _Grant(role.name, hub, _TO_SCHEDULER_READS, role.reads, "read"),
        _Grant(
            role.name,
            hub,
            _TO_SCHEDULER_QUERIES,
            (SCHEDULER_OUTPUTS,),
            "query",
        ),
        _Grant(
            hub,
            role.name,
            _FROM_SCHEDULER_OUTPUTS,
            (SCHEDULER_OUTPUTS,),
            "outputs",
        ),
        _Grant(
            hub,
            role.name,
            ("declare_subscriber",),
            SCHEDULER_INPUTS,
            "inputs",
        ),
    ]
    if role.answers:
        out += [
            _Grant(
                role.name,
                hub,
                ("declare_queryable", "reply"),
                role.answers,
                "answers",
            ),
            _Grant(hub, role.name, ("query",), role.answers, "asked"),
        ]
    return out


def _scheduler_via_router() -> list[_Grant]:
    """The scheduler behind a router: its outputs go out; the inputs, the
    readers' subscriptions and queries come in. Everything on
    ``scheduler/**`` flows both ways too, so that redundant schedulers see
    each other's liveliness tokens and shared snapshots."""
    everything = ("put", "reply", "declare_queryable", "liveliness_token")
    watch = ("query", "declare_liveliness_subscriber", "liveliness_query")
    return [
        _Grant(
            "scheduler", "router", everything, (SCHEDULER_OUTPUTS,), "outputs"
        ),
        _Grant(
            "scheduler",
            "router",
            ("declare_subscriber",),
            (*SCHEDULER_INPUTS, SCHEDULER_OUTPUTS),
            "read",
        ),
        _Grant("scheduler", "router", watch, (SCHEDULER_OUTPUTS,), "query"),
        _Grant(
            "router",
            "scheduler",
            ("put",),
            (*SCHEDULER_INPUTS, SCHEDULER_OUTPUTS),
            "inputs",
        ),
        _Grant(
            "router",
            "scheduler",
            ("reply", "declare_queryable", "liveliness_token", *watch),
            (SCHEDULER_OUTPUTS,),
            "twins",
        ),
        _Grant(
            "router", "scheduler", ("declare_subscriber",), ("**",), "readers"
        ),
    ]


def _check_names(names: Mapping[str, Iterable[str]]) -> dict[str, list[str]]:
    known = roles_of("router")
    unknown = set(names) - set(known)
    if unknown:
        raise ConfigError(
            f"unknown role(s) {', '.join(sorted(unknown))}; roles are "
            f"{', '.join(known)}"
        )
    result = {role: [role] for role in known}
    for role, given in names.items():
        cns = [cn for cn in given if cn]
        if not cns:
            raise ConfigError(f"role {role}: no certificate common name")
        result[role] = cns
    return result


def access_control(
    role: str,
    spacecraft: str = topics.DEFAULT_SPACECRAFT,
    names: Mapping[str, Iterable[str]] | None = None,
    topology: str = "star",
) -> dict[str, Any]:
    """The ``access_control`` section of one role's Zenoh configuration.

    Parameters
    ----------
    role
        A key of :data:`ROLES`.
    spacecraft
        Second key chunk.
    names
        Certificate common names per role (default: the role's name).
        Several names give one role to several certificates (e.g. ground
        and on-board autonomy both in ``goals``).

    topology
        One of :data:`TOPOLOGIES`.

    Returns
    -------
    dict
        Default deny; for the hub (the scheduler, or the router), one
        subject per role connecting to it; for any other role, one subject
        (the hub).
    """
    if role not in roles_of(topology):
        raise ConfigError(f"unknown role {role!r}")
    # A wildcard in the spacecraft id would widen every rule.
    reason = id_issue(spacecraft)
    if reason is not None:
        raise ConfigError(f"spacecraft: the spacecraft id {reason}")
    cns = _check_names(names or {})
    tree = topics.Topics(spacecraft)
    rules: list[dict[str, Any]] = []
    policies: list[dict[str, Any]] = []
    hub = "scheduler" if topology == "star" else "router"
    peers = [r for r in ROLES.values() if r.name != hub]
    if role != hub:
        peers = [ROLES[role]]
    for peer in peers:
        ids = []
        for grant in _grants(peer, hub):
            incoming = grant.receiver == role
            rule_id = f"{grant.sender}-{grant.label}-to-{grant.receiver}"
            ids.append(rule_id)
            rules.append(
                {
                    "id": rule_id,
                    "messages": list(grant.messages),
                    "flows": ["ingress" if incoming else "egress"],
                    "permission": "allow",
                    "key_exprs": [tree.key(k) for k in grant.keys],
                }
            )
        subject = peer.name if role == hub else hub
        policies.append(
            {"id": f"{peer.name}", "rules": ids, "subjects": [subject]}
        )
    if role == hub:
        subjects = [
            {"id": peer.name, "cert_common_names": cns[peer.name]}
            for peer in peers
        ]
    else:
        subjects = [{"id": hub, "cert_common_names": cns[hub]}]
    return {
        "enabled": True,
        "default_permission": "deny",
        "rules": rules,
        "subjects": subjects,
        "policies": policies,
    }


def _template(profile: str) -> string.Template:
    if profile not in PROFILES:
        raise ConfigError(
            f"unknown profile {profile!r}; profiles: {', '.join(PROFILES)}"
        )
    text = (
        resources.files("fsw_scheduler") / "profiles" / f"{profile}.json5"
    ).read_text()
    return string.Template(text)


def _json5(value: Any, depth: int = 1) -> str:
    """JSON with one rule, subject or policy per line block (readable)."""
    pad = "  " * depth
    if isinstance(value, dict) and any(
        isinstance(v, (dict, list)) and v and isinstance(v[0], dict)
        for v in value.values()
        if isinstance(v, list)
    ):
        items = [
            f"{pad}  {json.dumps(k)}: {_json5(v, depth + 1)},"
            for k, v in value.items()
        ]
        return "{\n" + "\n".join(items) + f"\n{pad}}}"
    if isinstance(value, list) and value and isinstance(value[0], dict):
        items = [f"{pad}  {json.dumps(v)}," for v in value]
        return "[\n" + "\n".join(items) + f"\n{pad}]"
    return json.dumps(value)


def render_profile(
    role: str,
    *,
    profile: str = "secure",
    spacecraft: str = topics.DEFAULT_SPACECRAFT,
    certs: str | Path = "certs",
    endpoint: str = f"tls/localhost:{DEFAULT_PORT}",
    listen: str | None = None,
    names: Mapping[str, Iterable[str]] | None = None,
    topology: str = "star",
) -> str:
    """The Zenoh configuration (JSON5 text) of one role.

    Parameters
    ----------
    role
        A key of :data:`ROLES`.
    profile
        One of :data:`PROFILES`.
    spacecraft
        Second key chunk.
    certs
        Folder holding ``ca.pem`` and ``<role>.pem`` / ``<role>.key``.
    endpoint
        Where the roles connect to the hub (the scheduler, or the router);
        its host must be named in the hub's certificate.
    listen
        Where the hub listens (default: ``endpoint``'s port on every
        interface).
    names
        Certificate common names per role (default: the role's name).
    topology
        One of :data:`TOPOLOGIES`.
    """
    if role not in roles_of(topology):
        raise ConfigError(f"unknown role {role!r}")
    if not endpoint.startswith("tls/"):
        raise ConfigError(f"endpoint {endpoint!r}: must be tls/HOST:PORT")
    if listen is None:
        listen = f"tls/[::]:{_port(endpoint)}"
    folder = Path(certs)
    hub = "scheduler" if topology == "star" else "router"
    is_hub = role == hub
    summary = ROUTER.summary if role == "router" else ROLES[role].summary
    if role == "scheduler" and topology == "router":
        summary += " Here behind the router, with any redundant twin."
    mode = "client"
    if is_hub:
        mode = "peer" if hub == "scheduler" else "router"
    return _template(profile).substitute(
        ROLE=role,
        SPACECRAFT=spacecraft,
        ROLE_HELP="\n// ".join(textwrap.wrap(summary, 72)),
        MODE=json.dumps(mode),
        LISTEN=json.dumps([listen] if is_hub else []),
        CONNECT=json.dumps([] if is_hub else [endpoint]),
        ROOT_CA=json.dumps(str(folder / "ca.pem")),
        CERTIFICATE=json.dumps(str(folder / f"{role}.pem")),
        PRIVATE_KEY=json.dumps(str(folder / f"{role}.key")),
        ACCESS_CONTROL=_json5(
            access_control(role, spacecraft, names, topology)
        ),
    )


def _port(endpoint: str) -> int:
    host_port = endpoint.partition("/")[2].split("#")[0].split("?")[0]
    try:
        return int(host_port.rsplit(":", 1)[1])
    except (IndexError, ValueError):
        raise ConfigError(f"endpoint {endpoint!r}: no port") from None


def _host(endpoint: str) -> str:
    host_port = endpoint.partition("/")[2].split("#")[0].split("?")[0]
    host = host_port.rsplit(":", 1)[0] if ":" in host_port else host_port
    return host.strip("[]")


_CERTS_SCRIPT = """\
#!/bin/sh
# Make the deployment's CA and one certificate per role with openssl.
# Run once on a trusted machine; copy each role its own .pem/.key and ca.pem
# (never ca.key). Existing files are kept: delete them to renew.
set -eu
cd "$(dirname "$0")"
mkdir -p {certs}
cd {certs}
DAYS=${{DAYS:-365}}
if [ ! -f ca.pem ]; then
  openssl req -x509 -newkey ec -pkeyopt ec_paramgen_curve:P-256 -nodes \\
    -keyout ca.key -out ca.pem -days "$DAYS" -subj "/CN={ca_name}" \\
    -addext basicConstraints=critical,CA:TRUE \\
    -addext keyUsage=critical,keyCertSign,cRLSign
  chmod 600 ca.key
fi
make_cert() {{ # file stem, common name, subjectAltName
  [ -f "$1.pem" ] && return 0
  openssl req -newkey ec -pkeyopt ec_paramgen_curve:P-256 -nodes \\
    -keyout "$1.key" -out "$1.csr" -subj "/CN=$2"
  printf '%s\\n' "subjectAltName=$3" "basicConstraints=critical,CA:FALSE" \\
    "keyUsage=critical,digitalSignature" \\
    "extendedKeyUsage=serverAuth,clientAuth" > "$1.ext"
  openssl x509 -req -in "$1.csr" -CA ca.pem -CAkey ca.key -CAcreateserial \\
    -out "$1.pem" -days "$DAYS" -extfile "$1.ext"
  rm -f "$1.csr" "$1.ext"
  chmod 600 "$1.key"
}}
{calls}
echo "certificates in $(pwd)"
"""


def certs_script(
    certs: str | Path,
    endpoint: str,
    names: Mapping[str, Iterable[str]] | None = None,
    ca_name: str = "fsw-scheduler deployment CA",
    topology: str = "star",
) -> str:
    """A shell script making the CA and the role certificates (openssl).

    The hub's certificate (the scheduler's, or the router's) names the
    host of ``endpoint`` (plus ``localhost`` and ``127.0.0.1``), since
    connecting roles check it.
    """
    hub = "scheduler" if topology == "star" else "router"
    cns = _check_names(names or {})
    host = _host(endpoint)
    alt = ["DNS:localhost", "IP:127.0.0.1"]
    try:
        ipaddress.ip_address(host)
        extra = f"IP:{host}"
    except ValueError:
        extra = f"DNS:{host}"
    if extra not in alt:
        alt.insert(0, extra)
    calls = []
    for role in roles_of(topology):
        san = ",".join(alt) if role == hub else f"DNS:{role}"
        calls.append(
            "make_cert "
            + " ".join(shlex.quote(v) for v in (role, cns[role][0], san))
        )
    return _CERTS_SCRIPT.format(
        certs=shlex.quote(str(certs)),
        ca_name=ca_name,
        calls="\n".join(calls),
    )


# -- the start-up check -------------------------------------------------------


@dataclass
class _Findings:
    exposed: list[str] = field(default_factory=list)


def _endpoints(value: Any, mode: str) -> list[str]:
    if isinstance(value, dict):  # Zenoh's per-mode defaults
        value = value.get(mode, [])
    return [str(v) for v in value or []]


def is_loopback(endpoint: str) -> bool:
    """True if ``endpoint`` only reaches this machine."""
    protocol = endpoint.partition("/")[0]
    if protocol in ("unixsock-stream", "unixpipe", "vsock"):
        return True
    host = _host(endpoint)
    if host == "localhost":
        return True
    try:
        return ipaddress.ip_address(host).is_loopback
    except ValueError:
        return False


def assess_settings(
    get: Callable[[str], Any], *, acknowledged: bool = False
) -> messages.SecurityInfo:
    """How the settings of a Zenoh configuration protect the scheduler.

    The bus is *exposed* when an endpoint reaches beyond loopback or
    multicast scouting is on (Zenoh's default, which also makes a peer
    listen on every interface). An exposed bus needs TLS on every endpoint
    with mutual authentication and access control with default deny;
    each missing piece is one warning.

    Parameters
    ----------
    get
        The value of one key of the configuration the node will open its
        session with (``mode``, ``listen/endpoints``, ...), decoded from
        its JSON, or None when unset (a key Zenoh does not know too);
        :func:`fsw_scheduler.bus.security.assess` reads them from a live
        ``zenoh.Config``.
    acknowledged
        The operator accepted running open (``run --insecure``).
    """
    mode = get("mode") or "peer"
    listen = _endpoints(get("listen/endpoints"), mode)
    connect = _endpoints(get("connect/endpoints"), mode)
    multicast = get("scouting/multicast/enabled")
    if multicast is None:
        multicast = True  # Zenoh's default
    found = _Findings()
    for endpoint in [*listen, *connect]:
        if not is_loopback(endpoint):
            found.exposed.append(endpoint)
    if multicast:
        found.exposed.append("multicast scouting")
    tls = bool(listen or connect) and all(
        e.partition("/")[0] in ("tls", "quic") for e in [*listen, *connect]
    )
    tls_settings = get("transport/link/tls") or {}
    mutual = bool(
        tls
        and tls_settings.get("enable_mtls")
        and tls_settings.get("root_ca_certificate")
    )
    acl = get("access_control") or {}
    acl_on = bool(acl.get("enabled")) and (
        acl.get("default_permission", "deny") == "deny"
    )
    warnings: list[str] = []
    if found.exposed:
        where = ", ".join(found.exposed)
        plain = [e for e in [*listen, *connect] if not e.startswith("tls/")]
        if not tls:
            warnings.append(
                f"the bus is reachable beyond this machine ({where}) "
                "without TLS"
                + (f" (plain endpoints: {', '.join(plain)})" if plain else "")
                + ": traffic can be read and forged"
            )
        elif not mutual:
            warnings.append(
                "TLS without mutual authentication (enable_mtls and "
                "root_ca_certificate): peers are not authenticated"
            )
        if not acl_on:
            warnings.append(
                f"the bus is reachable beyond this machine ({where}) "
                "without access control (access_control enabled, default "
                "deny): any peer can send goals, reports, levels and clock"
            )
    return messages.SecurityInfo(
        exposed=bool(found.exposed),
        tls=tls,
        mutual_tls=mutual,
        access_control=acl_on,
        acknowledged=acknowledged and bool(warnings),
        warnings=tuple(warnings),
    )


def local_gaps(info: messages.SecurityInfo) -> tuple[str, ...]:
    """What a loopback-only bus lacks to be secure (empty when it has TLS
    with mutual authentication and access control, or is exposed: then
    :func:`assess` warns already).

    Every process of the computer can reach a loopback bus: a strict
    deployment (``run --require-secure``, like SROS 2's ``Enforce``)
    refuses it too, unless the operator trusts the computer
    (``--trust-loopback``).
    """
    if info.exposed:
        return ()
    gaps = []
    if not info.mutual_tls:
        gaps.append(
            "the bus is loopback only but without mutual TLS: every "
            "process on this computer can read it"
        )
    if not info.access_control:
        gaps.append(
            "the bus is loopback only but without access control: every "
            "process on this computer can send goals, reports, levels "
            "and clock"
        )
    return tuple(gaps)
