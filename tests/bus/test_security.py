"""Tests of the secure deployment profile, on a real TLS bus (loopback).

Certificates are made at test time: a throw-away CA with one certificate
per role, and a second CA whose certificate claims the ``goals`` name.
The scheduler node listens with its profile on an ephemeral loopback port;
each role connects with its own profile, as a deployment would.

Negative cases never sleep: after a forged message, the same session asks
the scheduler for its status. That query travels on the same link behind
the forged message and is answered by the node's loop in arrival order, so
by the time the answer arrives a message that got through would have been
processed.
"""

from __future__ import annotations

import contextlib
import datetime
import ipaddress
import json
import queue
import shutil
import subprocess
from typing import TYPE_CHECKING

import msgspec
import pytest
import zenoh
from cryptography import x509
from cryptography.hazmat.primitives import hashes, serialization
from cryptography.hazmat.primitives.asymmetric import ec
from cryptography.x509.oid import ExtendedKeyUsageOID, NameOID

from fsw_scheduler.bus.node import SchedulerNode
from fsw_scheduler.bus.probe import probe
from fsw_scheduler.bus.security import (
    ROLES,
    access_control,
    assess,
    policy_publishers,
    render_profile,
    roles_of,
)
from fsw_scheduler.bus.session import (
    listening_endpoints,
    loopback_config,
    wait_matching,
)
from fsw_scheduler.cli import main
from fsw_scheduler.journal.annotate import schema_lookup
from fsw_scheduler.journal.reader import iter_messages
from fsw_scheduler.journal.replay import read_node_info, verify
from fsw_scheduler.journal.writer import Recorder
from fsw_scheduler.testing import (
    SchedulerClient,
    harness_config,
    paper_problem,
)
from fsw_scheduler.wire import messages
from fsw_scheduler.wire import topics as keys

from ..factories import CLI, ROOT, ping_goal

if TYPE_CHECKING:
    from collections.abc import Iterator
    from pathlib import Path

SC = keys.Topics("sat1")
WAIT_S = 20.0

# -- certificates ------------------------------------------------------------


def _name(cn: str) -> x509.Name:
    return x509.Name([x509.NameAttribute(NameOID.COMMON_NAME, cn)])


def _write(
    folder: Path,
    stem: str,
    key: ec.EllipticCurvePrivateKey | None,
    cert: x509.Certificate,
) -> None:
    folder.mkdir(parents=True, exist_ok=True)
    (folder / f"{stem}.pem").write_bytes(
        cert.public_bytes(serialization.Encoding.PEM)
    )
    if key is not None:
        (folder / f"{stem}.key").write_bytes(
            key.private_bytes(
                serialization.Encoding.PEM,
                serialization.PrivateFormat.PKCS8,
                serialization.NoEncryption(),
            )
        )


class _CA:
    """A throw-away certificate authority."""

    def __init__(self, name: str) -> None:
        now = datetime.datetime.now(datetime.timezone.utc)
        self.key = ec.generate_private_key(ec.SECP256R1())
        self.cert = (
            x509.CertificateBuilder()
            .subject_name(_name(name))
            .issuer_name(_name(name))
            .public_key(self.key.public_key())
            .serial_number(x509.random_serial_number())
            .not_valid_before(now - datetime.timedelta(hours=1))
            .not_valid_after(now + datetime.timedelta(days=1))
            .add_extension(
                x509.BasicConstraints(ca=True, path_length=None), True
            )
            .add_extension(
                x509.KeyUsage(
                    digital_signature=False,
                    content_commitment=False,
                    key_encipherment=False,
                    data_encipherment=False,
                    key_agreement=False,
                    key_cert_sign=True,
                    crl_sign=True,
                    encipher_only=False,
                    decipher_only=False,
                ),
                True,
            )
            .sign(self.key, hashes.SHA256())
        )

    def issue(
        self, cn: str
    ) -> tuple[ec.EllipticCurvePrivateKey, x509.Certificate]:
        """A leaf certificate for ``cn``, valid for localhost."""
        now = datetime.datetime.now(datetime.timezone.utc)
        key = ec.generate_private_key(ec.SECP256R1())
        cert = (
            x509.CertificateBuilder()
            .subject_name(_name(cn))
            .issuer_name(self.cert.subject)
            .public_key(key.public_key())
            .serial_number(x509.random_serial_number())
            .not_valid_before(now - datetime.timedelta(hours=1))
            .not_valid_after(now + datetime.timedelta(days=1))
            .add_extension(
                x509.SubjectAlternativeName(
                    [
                        x509.DNSName("localhost"),
                        x509.IPAddress(ipaddress.ip_address("127.0.0.1")),
                    ]
                ),
                False,
            )
            .add_extension(
                x509.BasicConstraints(ca=False, path_length=None), True
            )
            .add_extension(
                x509.ExtendedKeyUsage(
                    [
                        ExtendedKeyUsageOID.SERVER_AUTH,
                        ExtendedKeyUsageOID.CLIENT_AUTH,
                    ]
                ),
                False,
            )
            .sign(self.key, hashes.SHA256())
        )
        return key, cert


@pytest.fixture(scope="session")
def pki(tmp_path_factory: pytest.TempPathFactory) -> dict[str, Path]:
    """``good``: CA and one certificate per role; ``rogue``: another CA
    and a certificate that claims the ``goals`` name."""
    root = tmp_path_factory.mktemp("pki")
    good, rogue = root / "good", root / "rogue"
    ca = _CA("test deployment CA")
    _write(good, "ca", None, ca.cert)
    for role in roles_of("router"):
        _write(good, role, *ca.issue(role))
    other = _CA("another CA")
    _write(rogue, "ca", None, other.cert)
    _write(rogue, "goals", *other.issue("goals"))
    return {"good": good, "rogue": rogue}


# -- the bus -----------------------------------------------------------------


def role_config(
    role: str,
    certs: Path,
    endpoint: str,
    *,
    own_acl: bool = True,
    topology: str = "star",
) -> zenoh.Config:
    """The profile of ``role`` connecting to ``endpoint``.

    ``own_acl=False`` is an attacker holding that role's certificate who
    has switched off its own (mirrored) access control.
    """
    config = zenoh.Config.from_json5(
        render_profile(role, certs=certs, endpoint=endpoint, topology=topology)
    )
    if not own_acl:
        config.insert_json5("access_control/enabled", "false")
    return config


class SecureBus:
    """A scheduler node on its secure profile, and ways to reach it.

    ``acl=False`` switches the hub's access control off (TLS stays): the
    control case showing what the policy prevents. ``topology="router"``
    puts a Zenoh router in the middle, the scheduler being its client.
    """

    def __init__(
        self,
        certs: Path,
        *,
        acl: bool = True,
        journal: Path | None = None,
        topology: str = "star",
    ) -> None:
        self.certs = certs
        self.topology = topology
        self._sessions: list[zenoh.Session] = []
        hub = "scheduler" if topology == "star" else "router"
        config = zenoh.Config.from_json5(
            render_profile(
                hub,
                certs=certs,
                endpoint="tls/localhost:0",
                listen="tls/localhost:0",
                topology=topology,
            )
        )
        # Read-only and local: how the test learns the port the OS chose.
        config.insert_json5("adminspace/enabled", "true")
        config.insert_json5("adminspace/permissions/read", "true")
        if not acl:
            config.insert_json5("access_control/enabled", "false")
        self.hub = zenoh.open(config)
        self.endpoint = listening_endpoints(self.hub)[0]
        if topology == "router":
            config = role_config(
                "scheduler", certs, self.endpoint, topology=topology
            )
            self.session = zenoh.open(config)
        else:
            self.session = self.hub
        self.security = assess(config)
        self.journal = journal
        self.node = SchedulerNode(
            self.session,
            paper_problem(),
            harness_config(),
            security=self.security,
            publishers=policy_publishers(config),
            journal=(
                Recorder(journal, schemas=schema_lookup("sat1"))
                if journal is not None
                else None
            ),
        ).start()
        self.clock: SchedulerClient
        self.monitor: SchedulerClient

    def open(self, role: str, *, own_acl: bool = True) -> zenoh.Session:
        """A session of ``role`` (closed with the bus)."""
        session = zenoh.open(
            role_config(
                role,
                self.certs,
                self.endpoint,
                own_acl=own_acl,
                topology=self.topology,
            )
        )
        self._sessions.append(session)
        return session

    def client(self, role: str, *, own_acl: bool = True) -> SchedulerClient:
        """A :class:`SchedulerClient` on a new session of ``role``."""
        return SchedulerClient(
            self.open(role, own_acl=own_acl), timeout=WAIT_S
        )

    def close(self) -> None:
        """Close every session and the node."""
        for session in self._sessions:
            session.close()
        self.node.close()
        self.session.close()
        if self.hub is not self.session:
            self.hub.close()


def start(secure: SecureBus) -> SecureBus:
    """Tick the bus to 0 and wait for the first plan (seen by a monitor)."""
    secure.clock = secure.client("clock")
    secure.clock.wait_scheduler()
    secure.monitor = secure.client("monitor")
    wait_matching(secure.session, SC.key(keys.PLAN), WAIT_S)
    secure.clock.clock(0)
    secure.monitor.wait_plan(lambda p: p.plan_id == 1)
    return secure


@pytest.fixture
def bus(pki: dict[str, Path]) -> Iterator[SecureBus]:
    """A started scheduler at t=0 with its first plan, on TLS + ACL."""
    secure = SecureBus(pki["good"])
    try:
        yield start(secure)
    finally:
        secure.close()


def status_via(session: zenoh.Session) -> messages.Status:
    """The node's status, asked on ``session``'s own link.

    The query reaches the node behind everything ``session`` sent before,
    so the answer reflects any of it that got through.
    """
    for reply in session.get(SC.key(keys.STATUS), timeout=WAIT_S):
        if reply.ok is not None:
            return msgspec.json.decode(
                reply.ok.payload.to_bytes(), type=messages.Status
            )
    raise TimeoutError("no status reply")


# -- the profile -------------------------------------------------------------

#: Who may put what (relative keys), as the issue states it.
PUTS = {
    "goals": ["scheduler/goals"],
    "executor": ["telemetry/activities/**"],
    "clock": ["clock"],
    "telemetry": ["telemetry/resources/**"],
}


def test_scheduler_policy_grants_each_input_to_one_role() -> None:
    """Tests that the scheduler accepts each input key from its role only."""
    acl = access_control("scheduler", "sat1")
    assert (acl["enabled"], acl["default_permission"]) == (True, "deny")
    rules = {r["id"]: r for r in acl["rules"]}
    subjects = {s["id"]: s["cert_common_names"] for s in acl["subjects"]}
    assert subjects == {r: [r] for r in ROLES if r != "scheduler"}
    puts: dict[str, list[str]] = {}
    for policy in acl["policies"]:
        (subject,) = policy["subjects"]
        for rule in (rules[i] for i in policy["rules"]):
            assert rule["permission"] == "allow"
            if "put" in rule["messages"] and rule["flows"] == ["ingress"]:
                puts.setdefault(subject, []).extend(rule["key_exprs"])
    assert puts == {role: [SC.key(k) for k in ks] for role, ks in PUTS.items()}


def test_forecasts_are_the_telemetry_roles() -> None:
    """Tests that with the secure profile the telemetry role, and only it,
    may put a forecast the scheduler reads."""
    acl = access_control("scheduler", "sat1")
    rules = {r["id"]: r for r in acl["rules"]}
    forecast = zenoh.KeyExpr(SC.resource_forecast("battery"))
    allowed = set()
    for policy in acl["policies"]:
        (subject,) = policy["subjects"]
        for rule in (rules[i] for i in policy["rules"]):
            ingress = "put" in rule["messages"] and rule["flows"] == [
                "ingress"
            ]
            if ingress and any(
                forecast.intersects(zenoh.KeyExpr(key))
                for key in rule["key_exprs"]
            ):
                allowed.add(subject)
    assert allowed == {"telemetry"}


def test_role_policies_mirror_the_scheduler() -> None:
    """Tests that each role only sends what the scheduler accepts of it."""
    scheduler = access_control("scheduler", "sat1", {"goals": ["ground"]})
    assert {"id": "goals", "cert_common_names": ["ground"]} in (
        scheduler["subjects"]
    )
    for role in ROLES:
        if role == "scheduler":
            continue
        acl = access_control(role, "sat1")
        assert acl["subjects"] == [
            {"id": "scheduler", "cert_common_names": ["scheduler"]}
        ]
        mine = {
            (r["id"], tuple(r["messages"]), tuple(r["key_exprs"])): r["flows"]
            for r in acl["rules"]
        }
        theirs = {
            (r["id"], tuple(r["messages"]), tuple(r["key_exprs"])): r["flows"]
            for r in scheduler["rules"]
            if r["id"].startswith(f"{role}-") or r["id"].endswith(f"-{role}")
        }
        assert set(mine) == set(theirs)
        for rule, flows in mine.items():
            flip = {"ingress": "egress", "egress": "ingress"}
            assert theirs[rule] == [flip[f] for f in flows]


@pytest.mark.parametrize("role", list(ROLES))
def test_profiles_load_and_pass_the_check(role: str, tmp_path: Path) -> None:
    """Tests that each role's file loads in Zenoh and counts as secure."""
    text = render_profile(
        role, certs=tmp_path, endpoint="tls/10.0.0.2:7447", spacecraft="sc9"
    )
    config = zenoh.Config.from_json5(text)
    assert json.loads(config.get_json("transport/link/protocols")) == ["tls"]
    tls = json.loads(config.get_json("transport/link/tls"))
    assert tls["enable_mtls"] is True
    assert tls["connect_certificate"] == str(tmp_path / f"{role}.pem")
    info = assess(config)
    assert info.exposed
    assert (info.tls, info.mutual_tls, info.access_control) == (
        True,
        True,
        True,
    )
    assert info.warnings == ()
    assert "fsw/sc9/" in text and "fsw/sat1/" not in text


def test_check_flags_an_open_bus() -> None:
    """Tests that a reachable bus without TLS or ACL gets warnings."""
    default = assess(zenoh.Config())
    assert default.exposed and not default.tls and not default.access_control
    assert len(default.warnings) == 2
    assert "without TLS" in default.warnings[0]
    assert "without access control" in default.warnings[1]
    assert assess(loopback_config()).warnings == ()
    acl_only = loopback_config(listen="tcp/0.0.0.0:7447")
    acl_only.insert_json5(
        "access_control", json.dumps(access_control("scheduler"))
    )
    (only,) = assess(acl_only, acknowledged=True).warnings
    assert "tcp/0.0.0.0:7447" in only and "without TLS" in only
    assert assess(acl_only, acknowledged=True).acknowledged


def test_every_deployment_name_is_still_importable_from_the_bus() -> None:
    """Tests that bus.security gives every name of the pure deployment
    module, as the same objects, and that assess() reads a live
    configuration into the pure judgement."""
    from fsw_scheduler.bus import security
    from fsw_scheduler.runtime import access

    for name in access.__all__:
        if name != "assess_settings":
            assert getattr(security, name) is getattr(access, name), name
            assert name in security.__all__
    config = loopback_config(listen="tcp/0.0.0.0:7447")

    def get(key: str) -> object:
        try:
            return json.loads(config.get_json(key))
        except Exception:
            return None

    assert assess(config) == access.assess_settings(get)
    assert assess(config).warnings


def test_config_command_writes_every_role(tmp_path: Path) -> None:
    """Tests 'config --profile secure' and its certificate names."""
    out = tmp_path / "deploy"
    code = main(
        [
            "config",
            "--profile",
            "secure",
            "--out",
            str(out),
            "--spacecraft",
            "sat7",
            "--endpoint",
            "tls/10.1.2.3:7447",
            "--cn",
            "goals=ground,autonomy",
        ]
    )
    assert code == 0
    assert sorted(p.name for p in out.iterdir()) == sorted(
        [f"{r}.json5" for r in ROLES] + ["make-certs.sh"]
    )
    scheduler = zenoh.Config.from_file(out / "scheduler.json5")
    acl = json.loads(scheduler.get_json("access_control"))
    names = {s["id"]: s["cert_common_names"] for s in acl["subjects"]}
    assert names["goals"] == ["ground", "autonomy"]
    assert json.loads(scheduler.get_json("listen/endpoints")) == [
        "tls/[::]:7447"
    ]
    goals = zenoh.Config.from_file(out / "goals.json5")
    assert json.loads(goals.get_json("connect/endpoints")) == [
        "tls/10.1.2.3:7447"
    ]
    assert json.loads(goals.get_json("transport/link/tls"))[
        "root_ca_certificate"
    ] == str((out / "certs" / "ca.pem").resolve())
    assert main(["config", "--out", str(out), "--cn", "pilot=x"]) == 2
    assert main(["config", "--out", str(out), "--spacecraft", "*"]) == 2
    assert main(["config", "--out", str(out), "--endpoint", "tcp/h:1"]) == 2


@pytest.mark.skipif(shutil.which("openssl") is None, reason="no openssl")
def test_make_certs_script_gives_working_certificates(tmp_path: Path) -> None:
    """Tests that make-certs.sh's certificates open an authenticated link."""
    out = tmp_path / "deploy"
    assert main(["config", "--out", str(out)]) == 0
    subprocess.run(
        ["sh", str(out / "make-certs.sh")],
        check=True,
        capture_output=True,
        timeout=120,
    )
    certs = out / "certs"
    cert = x509.load_pem_x509_certificate(
        (certs / "scheduler.pem").read_bytes()
    )
    assert cert.subject.get_attributes_for_oid(NameOID.COMMON_NAME)[
        0
    ].value == ("scheduler")
    secure = SecureBus(certs)
    try:
        session = secure.open("goals")
        (link,) = session.info.links()
        assert link.auth_identifier == "scheduler"
        assert [lk.auth_identifier for lk in secure.session.info.links()] == [
            "goals"
        ]
    finally:
        secure.close()


# -- on the bus --------------------------------------------------------------


def test_authorised_roles_drive_the_scheduler(bus: SecureBus) -> None:
    """Tests goals, dispatch, reports, levels, queries and liveliness."""
    goals = bus.client("goals")
    goals.wait_scheduler()
    executor = bus.client("executor")
    telemetry = bus.client("telemetry")
    # A recorder with the monitor's certificate takes the whole tree.
    recorded: queue.Queue[str] = queue.Queue()
    recorder = bus.open("monitor").declare_subscriber(
        SC.everything, lambda s: recorded.put(str(s.key_expr))
    )
    wait_matching(bus.session, SC.key(keys.STATUS), WAIT_S)
    wait_matching(bus.session, SC.dispatch("DownlinkSat2Sat"), WAIT_S)
    goals.publish_goal(ping_goal("beacon", "Beacon"))
    accepted = goals.wait_status(
        lambda s: s.event == "goal_accepted" and s.goal_id == "beacon"
    )
    assert accepted.state == "ok"
    assert recorded.get(timeout=WAIT_S).startswith(SC.key("scheduler/"))
    recorder.undeclare()
    bus.clock.clock(1)
    dispatch = executor.wait_dispatch("DownlinkSat2Sat")
    assert dispatch.start == 1
    executor.report("DownlinkSat2Sat", "running", 1)
    executor.wait_status(
        lambda s: s.changed.get("DownlinkSat2Sat") == "running"
    )
    seen = bus.node.engine.inputs_seen
    telemetry.level("battery", 18.0, 1)
    status_via(telemetry.client)
    assert bus.node.engine.inputs_seen == seen + 1
    plan = bus.monitor.query_plan()
    assert plan is not None and "beacon" in plan.goals
    alive = [
        r.ok
        for r in bus.monitor.client.liveliness().get(
            SC.key(keys.ALIVE), timeout=WAIT_S
        )
    ]
    assert [str(s.key_expr) for s in alive if s is not None] == [
        SC.key(keys.ALIVE)
    ]
    changes: queue.Queue[zenoh.SampleKind] = queue.Queue()
    watch = bus.monitor.client.liveliness().declare_subscriber(
        SC.key(keys.ALIVE), lambda s: changes.put(s.kind), history=True
    )
    assert changes.get(timeout=WAIT_S) == zenoh.SampleKind.PUT
    watch.undeclare()


@pytest.mark.parametrize("topology", ["star", "router"])
def test_the_executor_answers_a_starting_scheduler_its_fence(
    pki: dict[str, Path], topology: str
) -> None:
    """Tests that on the secure profile the executor role answers
    ``scheduler/fences/<id>`` with the term it follows (a scheduler with a
    lost folder learns the term in use from it), and that a role without
    that grant (the monitor, whose fence follows the same term) cannot
    answer there."""

    with contextlib.closing(
        start(SecureBus(pki["good"], topology=topology))
    ) as bus:
        _fence_answered(bus)


def _fence_answered(bus: SecureBus) -> None:
    from fsw_scheduler.bus.standby import fence_terms

    executor = bus.client("executor")
    executor.wait_scheduler()
    wait_matching(bus.session, SC.dispatch("DownlinkSat2Sat"), WAIT_S)
    bus.clock.clock(1)
    executor.wait_dispatch("DownlinkSat2Sat")
    assert executor.fence.term == 1 and bus.monitor.fence.term == 1
    zid = str(executor.client.info.zid())
    answers = fence_terms(bus.session, SC, WAIT_S)
    assert answers == [(SC.key(f"{keys.FENCES}/{zid}"), 1)], answers


FORGERIES = {
    # kind: (key, payload)
    "goal": (SC.key(keys.GOALS), ping_goal("forged", "Forged")),
    "report": (
        SC.activity_report("SetPositionX"),
        {"task": "SetPositionX", "state": "failed", "at": 0},
    ),
    "level": (
        SC.resource_level("battery"),
        {"resource": "battery", "level": 0.0, "at": 0},
    ),
    "clock": (SC.key(keys.CLOCK), {"now": 40}),
}

#: A role holding a certificate that may not publish the forged kind.
IMPOSTORS = [
    ("goal", "executor"),
    ("goal", "monitor"),
    ("report", "goals"),
    ("report", "telemetry"),
    ("level", "clock"),
    ("level", "executor"),
    ("clock", "telemetry"),
    ("clock", "goals"),
]


@pytest.mark.parametrize(("kind", "role"), IMPOSTORS)
def test_another_roles_certificate_changes_nothing(
    bus: SecureBus, kind: str, role: str
) -> None:
    """Tests that a forged input never reaches the engine."""
    key, payload = FORGERIES[kind]
    # The impostor has switched its own access control off: only the
    # scheduler's policy stands between it and the engine.
    forger = bus.open(role, own_acl=False)
    # The scheduler's subscriber is known to the impostor, so Zenoh does
    # send the put: the scheduler's ingress rules are what refuse it.
    wait_matching(forger, key, WAIT_S)
    before = status_via(forger)
    seen = bus.node.engine.inputs_seen
    forger.put(key, json.dumps(payload).encode())
    after = status_via(forger)
    assert bus.node.engine.inputs_seen == seen
    assert after.counters == before.counters
    assert (after.plan_id, after.now, after.state, after.activities) == (
        before.plan_id,
        before.now,
        before.state,
        before.activities,
    )
    # An authorised input sent afterwards does get through.
    goals = bus.client("goals")
    goals.publish_goal(ping_goal("honest", "Honest"))
    goals.wait_status(lambda s: s.goal_id == "honest")
    assert all(s.goal_id != "forged" for s in bus.monitor.statuses)
    assert all("forged" not in p.goals for p in bus.monitor.plans)


def test_own_policy_keeps_a_role_from_sending(bus: SecureBus) -> None:
    """Tests that a role's own profile does not send what it may not."""
    executor = bus.open("executor")
    wait_matching(executor, SC.key(keys.GOALS), WAIT_S)
    seen = bus.node.engine.inputs_seen
    executor.put(SC.key(keys.GOALS), json.dumps(ping_goal("x")).encode())
    status_via(executor)
    assert bus.node.engine.inputs_seen == seen


def test_no_session_without_the_right_certificate(
    bus: SecureBus, pki: dict[str, Path]
) -> None:
    """Tests that no certificate, another CA, or plain TCP get no session."""
    transports = len(bus.session.info.transports())
    no_cert = role_config("goals", pki["good"], bus.endpoint)
    no_cert.insert_json5("transport/link/tls/connect_certificate", "null")
    no_cert.insert_json5("transport/link/tls/connect_private_key", "null")
    # A certificate from another CA that claims the goals name; this peer
    # itself trusts the right CA, so only the scheduler can refuse it.
    rogue = role_config("goals", pki["good"], bus.endpoint)
    for suffix in ("certificate", "private_key"):
        ext = "pem" if suffix == "certificate" else "key"
        rogue.insert_json5(
            f"transport/link/tls/connect_{suffix}",
            json.dumps(str(pki["rogue"] / f"goals.{ext}")),
        )
    plain = zenoh.Config()
    plain.insert_json5("mode", '"client"')
    plain.insert_json5(
        "connect/endpoints",
        json.dumps(["tcp/" + bus.endpoint.partition("/")[2]]),
    )
    for config in (no_cert, rogue, plain):
        with pytest.raises(zenoh.ZError):
            zenoh.open(config)
    assert len(bus.session.info.transports()) == transports


def test_listener_refuses_a_tls_client_without_certificate(
    bus: SecureBus, pki: dict[str, Path]
) -> None:
    """Tests at the TLS level that the scheduler demands a certificate."""
    import socket
    import ssl

    host, _, port = bus.endpoint.partition("/")[2].rpartition(":")
    context = ssl.create_default_context(cafile=str(pki["good"] / "ca.pem"))
    with socket.create_connection((host, int(port)), timeout=WAIT_S) as raw:
        try:
            with context.wrap_socket(raw, server_hostname=host) as tls:
                tls.sendall(b"\0" * 16)
                assert tls.recv(1) == b""
        except (ssl.SSLError, ConnectionError):
            pass  # refused during or right after the handshake


def _forge_dispatch(secure: SecureBus) -> list[str]:
    """An attacker with the goals certificate puts a dispatch; the tasks
    the executor was dispatched, once a later goal's verdict arrived."""
    executor = secure.client("executor")
    wait_matching(secure.session, SC.dispatch("Forged"), WAIT_S)
    attacker = secure.open("goals", own_acl=False)
    wait_matching(attacker, SC.key(keys.GOALS), WAIT_S)
    attacker.put(
        SC.dispatch("Forged"),
        json.dumps(
            {"task": "Forged", "plan_id": 1, "start": 0, "end": 1, "uses": {}}
        ).encode(),
    )
    # Sent after the forgery on the same link: when its verdict reaches the
    # executor, a forwarded forgery would have arrived before it.
    attacker.put(SC.key(keys.GOALS), json.dumps(ping_goal("later")).encode())
    executor.wait_status(lambda s: s.goal_id == "later")
    return [d.task for d in executor.dispatches]


def test_nobody_else_can_publish_a_dispatch(bus: SecureBus) -> None:
    """Tests that a forged dispatch never reaches the executor."""
    assert "Forged" not in _forge_dispatch(bus)


def test_without_the_policy_a_dispatch_can_be_forged(
    pki: dict[str, Path],
) -> None:
    """Tests the control case: TLS alone lets an authenticated peer forge."""
    secure = SecureBus(pki["good"], acl=False)
    try:
        start(secure)
        assert "Forged" in _forge_dispatch(secure)
    finally:
        secure.close()


@pytest.mark.parametrize(("kind", "role"), [("goal", "monitor")])
def test_without_the_policy_inputs_can_be_forged(
    pki: dict[str, Path], kind: str, role: str
) -> None:
    """Tests the control case of the impostor test: without the policy,
    the same forgery reaches the engine (so the test can see one)."""
    secure = SecureBus(pki["good"], acl=False)
    try:
        start(secure)
        key, payload = FORGERIES[kind]
        forger = secure.open(role, own_acl=False)
        wait_matching(forger, key, WAIT_S)
        seen = secure.node.engine.inputs_seen
        forger.put(key, json.dumps(payload).encode())
        status_via(forger)
        assert secure.node.engine.inputs_seen == seen + 1
    finally:
        secure.close()


# -- refusing to run open by accident ---------------------------------------


def _run_cli(*args: str) -> subprocess.CompletedProcess:
    return subprocess.run(
        [*CLI, *args],
        capture_output=True,
        text=True,
        timeout=60,
    )


def test_require_secure_refuses_an_open_bus() -> None:
    """Tests that 'run --require-secure' exits 2 and says why."""
    result = _run_cli(
        "run",
        "--horizon",
        "10",
        "--require-secure",
        "--listen",
        "tcp/0.0.0.0:7447",
        "--no-multicast-scouting",
    )
    assert result.returncode == 2, result.stderr
    assert "without TLS" in result.stderr
    assert "without access control" in result.stderr
    assert "--require-secure: not starting" in result.stderr


def test_require_secure_refuses_a_plain_loopback_bus_unless_trusted() -> None:
    """Tests that 'run --require-secure' refuses a loopback-only bus with
    neither TLS nor access control (every local process reaches it), and
    that --trust-loopback accepts it as a single trusted computer."""
    common = (
        "run",
        "--horizon",
        "10",
        "--require-secure",
        "--listen",
        "tcp/127.0.0.1:0",
        "--no-multicast-scouting",
    )
    refused = _run_cli(*common)
    assert refused.returncode == 2, refused.stderr
    assert "loopback only but without mutual TLS" in refused.stderr
    assert "loopback only but without access control" in refused.stderr
    process = subprocess.Popen(
        [*CLI, *common, "--trust-loopback"],
        stderr=subprocess.PIPE,
        text=True,
    )
    try:
        assert process.stderr is not None
        seen = []
        for line in process.stderr:
            seen.append(line)
            assert "not starting" not in line, line
            if "scheduler up on" in line:
                break
        assert seen and "scheduler up on" in seen[-1], "".join(seen)
    finally:
        process.terminate()
        process.wait(30)
        if process.stderr is not None:
            process.stderr.close()


def test_open_bus_warns_at_start() -> None:
    """Tests the start-up warning, and that --insecure acknowledges it.

    The endpoint is a documentation address (RFC 5737) that is not on this
    machine: the warning comes before the session opens, and then opening
    fails without sending anything.
    """
    endpoint = "tcp/192.0.2.1:7447"
    common = ("run", "--horizon", "10", "--no-multicast-scouting")
    warned = _run_cli(*common, "--listen", endpoint)
    assert "INSECURE" in warned.stderr and endpoint in warned.stderr
    assert "pass --insecure to acknowledge" in warned.stderr
    acknowledged = _run_cli(*common, "--listen", endpoint, "--insecure")
    assert "INSECURE" not in acknowledged.stderr
    assert "running open (--insecure)" in acknowledged.stderr


def test_node_info_records_the_check(tmp_path: Path) -> None:
    """Tests that scheduler/config in the journal carries the check."""
    open_bus = loopback_config(listen="tcp/0.0.0.0:7447")
    info = assess(open_bus, acknowledged=True)
    journal = tmp_path / "journal.mcap"
    with zenoh.open(loopback_config()) as session:
        node = SchedulerNode(
            session,
            paper_problem(),
            harness_config(),
            journal=Recorder(journal, schemas=schema_lookup("sat1")),
            security=info,
        )
        node.start()
        node.close()
    recorded, _ = read_node_info(list(iter_messages(journal)))
    assert recorded.security == info
    assert recorded.security.acknowledged
    assert recorded.security.warnings


# -- traceability ------------------------------------------------------------


def put_signed(session: zenoh.Session, key: str, message: dict) -> None:
    """Publish with source info, as a component that wants to be traced."""
    session.put(
        key,
        json.dumps(message).encode(),
        source_info=zenoh.SourceInfo(session.id, 1),
    )


def test_verdicts_name_their_source(
    pki: dict[str, Path], tmp_path: Path
) -> None:
    """Tests source on verdicts and in the journal, and replay --verify."""
    journal = tmp_path / "journal.mcap"
    secure = SecureBus(pki["good"], journal=journal)
    try:
        start(secure)
        goals = secure.client("goals")
        goals.wait_scheduler()
        executor = secure.client("executor")
        telemetry = secure.client("telemetry")
        wait_matching(secure.session, SC.key(keys.STATUS), WAIT_S)
        put_signed(goals.client, SC.key(keys.GOALS), ping_goal("signed", "S"))
        accepted = goals.wait_status(lambda s: s.goal_id == "signed")
        assert accepted.event == "goal_accepted"
        assert accepted.source == messages.Source(
            zid=str(goals.client.zid()),
            eid=goals.client.id.eid,
            sn=1,
            identity="goals",
            basis="link",
        )
        # Without source info the policy still names the only connected
        # certificate that may publish goals.
        goals.publish_goal(ping_goal("plain", "SetPositionX"))
        rejected = goals.wait_status(lambda s: s.goal_id == "plain")
        assert rejected.event == "goal_rejected"
        assert rejected.source == messages.Source(
            identity="goals", basis="policy"
        )
        put_signed(
            executor.client,
            SC.activity_report("SetPositionX"),
            {"task": "SetPositionX", "state": "completed", "at": 0},
        )
        done = executor.wait_status(lambda s: s.event == "activity")
        assert done.source is not None
        assert (done.source.identity, done.source.zid) == (
            "executor",
            str(executor.client.zid()),
        )
        telemetry.level("battery", 0.0, 0)
        drift = telemetry.wait_status(lambda s: s.event == "drift")
        assert drift.source == messages.Source(
            identity="telemetry", basis="policy"
        )
        heartbeat = status_via(goals.client)
        assert heartbeat.source is None
        # The drift replan is adopted before the journal closes.
        goals.wait_status(
            lambda s: (
                s.event == "plan" and (s.plan_id or 0) > (drift.plan_id or 0)
            )
        )
    finally:
        secure.close()
    recorded = list(iter_messages(journal))
    sources = [
        msgspec.json.decode(m.payload, type=messages.InputSource)
        for m in recorded
        if m.topic == SC.key(keys.SOURCES)
    ]
    by_key = {s.key: s.source.identity for s in sources}
    assert by_key[SC.key(keys.GOALS)] == "goals"
    assert by_key[SC.key(keys.CLOCK)] == "clock"
    assert by_key[SC.activity_report("SetPositionX")] == "executor"
    assert by_key[SC.resource_level("battery")] == "telemetry"
    inputs = [m.topic for m in recorded]
    for idx, topic in enumerate(inputs):
        if topic == SC.key(keys.SOURCES):
            assert inputs[idx - 1] == sources.pop(0).key
    report = verify(journal)
    assert report.identical, report.summary()


def test_probe_tells_refused_from_reached(bus: SecureBus) -> None:
    """Tests the probe against the scheduler's policy and a role's own."""
    # The monitor with its own policy switched off: only the scheduler's
    # policy refuses.
    monitor = bus.open("monitor", own_acl=False)
    assert [r.reached for r in probe(monitor, SC)] == [False] * 3
    goals = bus.open("goals")
    results = {r.kind: r.reached for r in probe(goals, SC)}
    assert results == {"goal": True, "report": False, "level": False}
    status = status_via(goals)
    assert status.plan_id == 1 and status.state == "ok"
    assert status.counters.goals_rejected == 1
    assert status.counters.goals_accepted == 0


def test_probe_command(bus: SecureBus, tmp_path: Path) -> None:
    """Tests 'fsw-scheduler probe' exit codes with a written profile."""
    out = tmp_path / "deploy"
    assert (
        main(
            [
                "config",
                "--out",
                str(out),
                "--certs",
                str(bus.certs),
                "--endpoint",
                bus.endpoint,
            ]
        )
        == 0
    )
    monitor = ["probe", "--config", str(out / "monitor.json5")]
    assert main(monitor) == 0
    assert main([*monitor, "--cfg", "access_control/enabled:false"]) == 0
    executor = ["probe", "--config", str(out / "executor.json5")]
    assert main([*executor, "--kinds", "goal,level"]) == 0
    assert main([*executor, "--kinds", "report"]) == 1


def test_run_command_on_the_secure_profile(
    pki: dict[str, Path], tmp_path: Path
) -> None:
    """Tests 'run --require-secure' with the written profile, end to end:
    it starts, takes a goal from the goals role and names its source."""
    import signal
    import socket

    problem = ROOT / "fsw_scheduler" / "data"
    for _attempt in range(3):
        with socket.socket() as probe_port:
            probe_port.bind(("127.0.0.1", 0))
            port = probe_port.getsockname()[1]
        out = tmp_path / f"deploy-{port}"
        endpoint = f"tls/localhost:{port}"
        assert (
            main(
                [
                    "config",
                    "--out",
                    str(out),
                    "--certs",
                    str(pki["good"]),
                    "--endpoint",
                    endpoint,
                    "--listen",
                    endpoint,
                ]
            )
            == 0
        )
        process = subprocess.Popen(
            [
                *CLI,
                "run",
                "--problem",
                str(problem / "paper_table1.json"),
                "--clock",
                "bus",
                "--config",
                str(out / "scheduler.json5"),
                "--require-secure",
            ],
            stdout=subprocess.DEVNULL,
            stderr=subprocess.PIPE,
            text=True,
        )
        assert process.stderr is not None
        log = []
        for line in process.stderr:
            log.append(line)
            if "scheduler up on" in line:
                break
        if process.poll() is None:
            break
    else:
        pytest.fail("run did not start:\n" + "".join(log))
    try:
        assert not any("INSECURE" in line for line in log), log
        config = zenoh.Config.from_file(out / "clock.json5")
        with (
            zenoh.open(config) as clock_session,
            zenoh.open(
                zenoh.Config.from_file(out / "goals.json5")
            ) as goals_session,
        ):
            clock = SchedulerClient(clock_session, timeout=WAIT_S)
            goals = SchedulerClient(goals_session, timeout=WAIT_S)
            clock.wait_scheduler()
            goals.wait_scheduler()
            clock.tick(0)
            put_signed(goals_session, SC.key(keys.GOALS), ping_goal("cli"))
            verdict = goals.wait_status(lambda s: s.goal_id == "cli")
            assert verdict.event == "goal_accepted"
            assert verdict.source is not None
            assert (verdict.source.identity, verdict.source.basis) == (
                "goals",
                "link",
            )
            clock.close()
            goals.close()
        process.send_signal(signal.SIGTERM)
        assert process.wait(20) == 0
    finally:
        if process.poll() is None:
            process.kill()
            process.wait(10)
        process.stderr.close()


def test_missing_certificates_are_said_in_one_line(tmp_path: Path) -> None:
    """Tests that 'run' on a profile without its certificates says so."""
    out = tmp_path / "deploy"
    assert main(["config", "--out", str(out)]) == 0
    result = _run_cli(
        "run",
        "--horizon",
        "10",
        "--config",
        str(out / "scheduler.json5"),
        "--listen",
        "tls/localhost:0",
    )
    assert result.returncode == 1
    assert "cannot open the Zenoh session" in result.stderr
    assert "Traceback" not in result.stderr


# -- the router topology -----------------------------------------------------


@pytest.fixture
def routed(pki: dict[str, Path]) -> Iterator[SecureBus]:
    """A started scheduler behind a Zenoh router, on TLS + ACL."""
    secure = SecureBus(pki["good"], topology="router")
    try:
        yield start(secure)
    finally:
        secure.close()


def test_router_topology_serves_the_roles(routed: SecureBus) -> None:
    """Tests goals, dispatch and verdicts through the router."""
    goals = routed.client("goals")
    goals.wait_scheduler()
    executor = routed.client("executor")
    wait_matching(routed.session, SC.dispatch("DownlinkSat2Sat"), WAIT_S)
    put_signed(goals.client, SC.key(keys.GOALS), ping_goal("via-router"))
    verdict = goals.wait_status(lambda s: s.goal_id == "via-router")
    assert verdict.event == "goal_accepted"
    # The scheduler's only link is the router's: that is all it can name.
    assert verdict.source is not None
    assert (verdict.source.identity, verdict.source.basis) == (
        "router",
        "policy",
    )
    assert verdict.source.zid == str(goals.client.zid())
    routed.clock.clock(1)
    assert executor.wait_dispatch("DownlinkSat2Sat").start == 1


@pytest.mark.parametrize(
    ("kind", "role"), [("goal", "monitor"), ("clock", "goals")]
)
def test_router_refuses_another_roles_input(
    routed: SecureBus, kind: str, role: str
) -> None:
    """Tests that the router's policy keeps forged inputs from the engine."""
    key, payload = FORGERIES[kind]
    forger = routed.open(role, own_acl=False)
    wait_matching(forger, key, WAIT_S)
    before = status_via(forger)
    seen = routed.node.engine.inputs_seen
    forger.put(key, json.dumps(payload).encode())
    after = status_via(forger)
    assert routed.node.engine.inputs_seen == seen
    assert after.counters == before.counters
    assert after.now == before.now


def test_router_refuses_a_forged_dispatch(routed: SecureBus) -> None:
    """Tests that a dispatch forged through the router never arrives."""
    assert "Forged" not in _forge_dispatch(routed)


def test_twin_schedulers_see_each_other_through_the_router(
    routed: SecureBus,
) -> None:
    """Tests what redundant schedulers need: each other's liveliness
    tokens and shared snapshots, with the scheduler certificate."""
    twin_a = routed.open("scheduler")
    twin_b = routed.open("scheduler")
    nodes = SC.key(keys.NODES + "/**")
    token = twin_a.liveliness().declare_token(SC.key(keys.NODES + "/1/2/a"))
    seen: queue.Queue[str] = queue.Queue()
    watch = twin_b.liveliness().declare_subscriber(
        nodes, lambda s: seen.put(str(s.key_expr)), history=True
    )
    assert seen.get(timeout=WAIT_S) == SC.key(keys.NODES + "/1/2/a")
    snapshots: queue.Queue[bytes] = queue.Queue()
    follow = twin_b.declare_subscriber(
        SC.key(keys.SNAPSHOT), lambda s: snapshots.put(s.payload.to_bytes())
    )
    wait_matching(twin_a, SC.key(keys.SNAPSHOT), WAIT_S)
    twin_a.put(SC.key(keys.SNAPSHOT), b"{}")
    assert snapshots.get(timeout=WAIT_S) == b"{}"
    for entity in (follow, watch, token):
        entity.undeclare()


def test_router_topology_profiles(tmp_path: Path) -> None:
    """Tests the router topology's files: modes, endpoints, the check."""
    out = tmp_path / "deploy"
    args = ["config", "--out", str(out), "--topology", "router"]
    assert main([*args, "--endpoint", "tls/10.0.0.9:7447"]) == 0
    assert (out / "router.json5").exists()
    for role in roles_of("router"):
        config = zenoh.Config.from_file(out / f"{role}.json5")
        mode = json.loads(config.get_json("mode"))
        assert mode == ("router" if role == "router" else "client")
        info = assess(config)
        assert info.exposed and info.warnings == (), role
    router = json.loads(
        zenoh.Config.from_file(out / "router.json5").get_json("access_control")
    )
    assert {s["id"] for s in router["subjects"]} == set(ROLES)
    script = (out / "make-certs.sh").read_text()
    assert "make_cert router router IP:10.0.0.9" in script


class _Run:
    """``fsw-scheduler run`` in a subprocess, its log read by a thread."""

    def __init__(self, *args: str) -> None:
        import threading

        self.process = subprocess.Popen(
            [*CLI, "run", *args],
            stdout=subprocess.DEVNULL,
            stderr=subprocess.PIPE,
            text=True,
        )
        self.lines: queue.Queue[str | None] = queue.Queue()
        self.log: list[str] = []
        self._reader = threading.Thread(target=self._read, daemon=True)
        self._reader.start()

    def _read(self) -> None:
        assert self.process.stderr is not None
        for line in self.process.stderr:
            self.log.append(line)
            self.lines.put(line)
        self.lines.put(None)

    def wait_for(self, *words: str, timeout: float = 60.0) -> str:
        """The first of ``words`` the log shows (fails if the run ends)."""
        import time

        deadline = time.monotonic() + timeout
        while True:
            line = self.lines.get(timeout=max(deadline - time.monotonic(), 0))
            assert line is not None, "".join(self.log)
            for word in words:
                if word in line:
                    return word

    def stop(self) -> None:
        """Kill the process if it still runs (cleanup)."""
        if self.process.poll() is None:
            self.process.kill()
            self.process.wait(10)
        self._reader.join(10)
        if self.process.stderr is not None:
            self.process.stderr.close()


def test_redundant_schedulers_behind_the_secure_router(
    pki: dict[str, Path], tmp_path: Path
) -> None:
    """Tests two 'run' twins through the TLS router: one commands, a goal
    gets one verdict, and the other takes over when it is killed."""
    import threading

    router_config = zenoh.Config.from_json5(
        render_profile(
            "router",
            certs=pki["good"],
            endpoint="tls/localhost:0",
            listen="tls/localhost:0",
            topology="router",
        )
    )
    router_config.insert_json5("adminspace/enabled", "true")
    router_config.insert_json5("adminspace/permissions/read", "true")
    router = zenoh.open(router_config)
    runs: dict[str, _Run] = {}
    sessions: list[zenoh.Session] = []
    try:
        endpoint = listening_endpoints(router)[0]
        out = tmp_path / "deploy"
        assert (
            main(
                [
                    "config",
                    "--out",
                    str(out),
                    "--certs",
                    str(pki["good"]),
                    "--endpoint",
                    endpoint,
                    "--topology",
                    "router",
                ]
            )
            == 0
        )
        problem = ROOT / "fsw_scheduler"
        for name in ("twin-a", "twin-b"):
            runs[name] = _Run(
                "--problem",
                str(problem / "data" / "paper_table1.json"),
                "--clock",
                "bus",
                "--config",
                str(out / "scheduler.json5"),
                "--require-secure",
                "--node-id",
                name,
            )
        decisions: dict[str, str] = {}
        threads = [
            threading.Thread(
                target=lambda n=name: decisions.__setitem__(
                    n, runs[n].wait_for("scheduler up on", "standing by")
                )
            )
            for name in runs
        ]
        for thread in threads:
            thread.start()
        for thread in threads:
            thread.join(90)
        assert sorted(decisions.values()) == [
            "scheduler up on",
            "standing by",
        ], decisions

        def role(name: str) -> SchedulerClient:
            session = zenoh.open(zenoh.Config.from_file(out / f"{name}.json5"))
            sessions.append(session)
            return SchedulerClient(session, timeout=WAIT_S)

        monitor, clock, goals = role("monitor"), role("clock"), role("goals")
        clock.wait_scheduler(60)
        goals.wait_scheduler(60)
        clock.clock(0)
        monitor.wait_plan(lambda p: p.plan_id == 1, 60)
        goals.publish_goal(ping_goal("once", "Beacon"))
        verdict = goals.wait_status(lambda s: s.goal_id == "once", 60)
        assert verdict.event == "goal_accepted"
        commander = verdict.node_id
        assert commander in runs
        assert [s.event for s in goals.statuses if s.goal_id == "once"] == [
            "goal_accepted"
        ]
        runs[commander].process.kill()
        took_over = monitor.wait_status(lambda s: s.event == "took_over", 60)
        assert took_over.node_id != commander
    finally:
        for session in sessions:
            session.close()
        for run in runs.values():
            run.stop()
        router.close()
