"""Commands that talk to a running scheduler: send, what-if, status, plan.

The habit of ``ros2 topic pub`` / ``ros2 topic echo``: ``send`` checks a
goal, report or level as strictly as the node will (nothing malformed
leaves this computer), publishes it once a scheduler is there to take it
and, with ``--wait``, prints the node's verdict; ``status`` and ``plan``
ask the node's queryables, and ``--follow`` prints each new one as JSON
lines until Ctrl-C. The Zenoh flags are those of ``run``.
"""

from __future__ import annotations

import contextlib
import json
import sys
from typing import TYPE_CHECKING, Any

from ...bus.session import add_zenoh_arguments
from ...errors import InputError
from .commands import (
    EXIT_NO_PLAN,
    EXIT_OK,
    add_spacecraft_flag,
    check_spacecraft,
    open_bus,
    positive_float,
    read_bytes,
)
from .stopping import stop_on_signals

if TYPE_CHECKING:
    import argparse
    from collections.abc import Iterator

    from ...bus.client import SchedulerClient
    from .files_flags import Add

#: Seconds ``send`` waits for the node's settings (a node too old to
#: answer them costs this much, once).
_CONFIG_WAIT_S = 2.0
#: The same wait for a document already refused: a node that is there
#: answers in milliseconds; without one, the refusal comes this late.
_COMPLETE_S = 1.0

KINDS = {
    "goal": "goal",
    "report": "activity_report",
    "level": "resource_level",
    "forecast": "resource_forecast",
    "clock": "clock",
}


def add_talk_commands(add: Add) -> None:
    """The ``send``, ``what-if``, ``status`` and ``plan`` commands and
    their flags."""
    send = add(
        "send",
        _cmd_send,
        "send a goal, report, level, forecast or clock to a running scheduler",
        """\
        Check a document as the scheduler will (unknown fields, keys
        written twice, types, ranges and, asked from the scheduler's
        settings, its resources: every mistake is named at once, exit 2,
        nothing is sent), wait for a scheduler of the spacecraft to be
        reachable, and publish it on its key; without --wait, one line
        says what was published where (-q: nothing). With --wait, print
        the verdict: goal_accepted (exit 0) or
        goal_rejected with every reason (exit 1) for a goal (re-sent
        unchanged until answered, which is safe: a goal id is answered
        once); for a report, a level or a clock, the node's status after
        it, or input_rejected with the reasons (exit 1).

        examples:
          fsw-scheduler send goal goal.json --wait
          fsw-scheduler send report \\
              '{"task": "Ping", "state": "completed", "at": 12}'
          fsw-scheduler send level \\
              '{"resource": "battery", "level": 18, "at": 12}'
          fsw-scheduler send forecast \\
              '{"resource": "power", "at": 40, "steps": [[40, 60], [75, 35]]}'
          fsw-scheduler send clock '{"now": 12}' -e tcp/10.0.0.1:7447 -m client
        """,
    )
    send.add_argument("kind", choices=sorted(KINDS), help="what FILE holds")
    send.add_argument(
        "file",
        metavar="FILE",
        help="the JSON document: a path, - for stdin, or the JSON itself",
    )
    send.add_argument(
        "--wait",
        action="store_true",
        help="wait for the scheduler's verdict and print it",
    )
    _common(send)
    what_if = add(
        "what-if",
        _cmd_what_if,
        "ask what a goal would do, without sending it (changes nothing)",
        """\
        Check a goal as the scheduler will (every mistake is named, exit
        2, nothing is asked), then ask the running scheduler what sending
        it now would do: the verdict, the plan it would produce (plan_id
        null), what it would move and leave out, and why. Printed as one
        JSON line; exit 0 if the goal would be accepted, 1 if it would be
        rejected, if the scheduler is busy with a solve (verdict busy),
        or if no scheduler answered. The scheduler's plan, plan_id and
        goal ledger stay as they were.

        examples:
          fsw-scheduler what-if goal.json
          fsw-scheduler what-if goal.json --timeout 60 -e tcp/10.0.0.1:7447
        """,
    )
    what_if.add_argument(
        "file",
        metavar="FILE",
        help="the goal: a path, - for stdin, or the JSON itself",
    )
    _common(what_if, default_timeout=30.0)
    for name, what in (("status", "status"), ("plan", "current plan")):
        query = add(
            name,
            _cmd_query,
            f"print the scheduler's {what} (JSON); --follow for each new one",
            f"""\
            Ask the running scheduler for its {what} (its queryable) and
            print it as one JSON line; with --follow, also print each one
            it publishes next, a line each, until Ctrl-C.

            examples:
              fsw-scheduler {name}
              fsw-scheduler {name} --follow --spacecraft sat2 \\
                  -e tcp/10.0.0.1:7447
            """,
        )
        query.set_defaults(what=name)
        query.add_argument(
            "--follow",
            action="store_true",
            help="keep printing each new one (Ctrl-C stops)",
        )
        _common(query)


def _common(
    parser: argparse.ArgumentParser, default_timeout: float = 10.0
) -> None:
    add_spacecraft_flag(parser)
    parser.add_argument(
        "--timeout",
        type=positive_float,
        default=default_timeout,
        metavar="S",
        help="seconds to wait for the scheduler (default: %(default)s)",
    )
    add_zenoh_arguments(parser)


def _document(text: str) -> bytes:
    """FILE as bytes: inline JSON when it looks like an object."""
    stripped = text.lstrip()
    if stripped.startswith("{"):
        return stripped.encode()
    return read_bytes(text)


def _checked(kind: str, payload: bytes) -> Any:
    """The document decoded as the scheduler decodes it (InputError)."""
    from ...wire import messages

    return messages.decode_input(KINDS[kind], payload)


@contextlib.contextmanager
def _client(args: argparse.Namespace) -> Iterator[SchedulerClient]:
    """A client of the spacecraft's scheduler on the bus the flags name."""
    from ...bus.client import SchedulerClient
    from ...bus.session import zenoh_config

    with (
        open_bus(zenoh_config(args)) as session,
        SchedulerClient(
            session, args.spacecraft, timeout=args.timeout
        ) as client,
    ):
        yield client


def _cmd_send(args: argparse.Namespace) -> int:
    from ...wire import messages

    check_spacecraft(args.spacecraft)
    payload = _document(args.file)
    try:
        message = _checked(args.kind, payload)
    except InputError as error:
        _complete(args, payload, error)
        raise
    with _client(args) as client:
        try:
            client.find_scheduler(args.timeout)
        except LookupError as error:
            print(f"fsw-scheduler: {error}: nothing sent", file=sys.stderr)
            return EXIT_NO_PLAN
        except TimeoutError:
            print(
                f"fsw-scheduler: no scheduler of {args.spacecraft} reachable "
                f"within {args.timeout:g} s: nothing sent",
                file=sys.stderr,
            )
            return EXIT_NO_PLAN
        _check_with_the_node(client, args, message, payload)
        if args.kind == "goal":
            doc = json.loads(payload)
            if not args.wait:
                client.publish_goal(payload)
                _published(args, f"goal {doc['goal_id']!r}", client, None)
                return EXIT_OK
            answers = client.send_goals([doc], timeout=args.timeout)
            verdicts = answers[doc["goal_id"]]
            if not verdicts:
                print(
                    f"fsw-scheduler: no verdict on {doc['goal_id']!r} within "
                    f"{args.timeout:g} s",
                    file=sys.stderr,
                )
                return EXIT_NO_PLAN
            status = client.wait_status(
                lambda s: s.goal_id == doc["goal_id"] and s.event in verdicts
            )
            print(messages.encode(status).decode())
            return EXIT_OK if verdicts == {"goal_accepted"} else EXIT_NO_PLAN
        key = {
            "report": lambda m: client.topics.activity_report(m.task),
            "level": lambda m: client.topics.resource_level(m.resource),
            "forecast": lambda m: client.topics.resource_forecast(m.resource),
            "clock": lambda m: client.topics.key("clock"),
        }[args.kind](message)
        if not args.wait:
            client.put(key, payload)
            _published(args, args.kind, client, key)
            return EXIT_OK
        # A query travels behind the inputs sent before it, so its answer
        # has seen them: one before and one after the input, and the count
        # of rejected inputs between them is the verdict. The rejection's
        # own status is published, and may arrive after the answer.
        sent = False
        try:
            earlier = client.query_status(args.timeout)
            before = len(client.statuses)
            client.put(key, payload)
            sent = True
            status = client.query_status(args.timeout)
        except TimeoutError:
            print(
                f"fsw-scheduler: no status within {args.timeout:g} s"
                + ("" if sent else ": nothing sent"),
                file=sys.stderr,
            )
            return EXIT_NO_PLAN
        rejected = (
            status.counters.inputs_rejected > earlier.counters.inputs_rejected
        )
        shown = status
        if rejected:
            with contextlib.suppress(TimeoutError):
                shown = client.wait_status(
                    lambda s: s.event == "input_rejected",
                    args.timeout,
                    since=before,
                )
        print(messages.encode(shown).decode())
        return EXIT_NO_PLAN if rejected else EXIT_OK


def _complete(
    args: argparse.Namespace, payload: bytes, error: InputError
) -> None:
    """Raise ``error`` with the mistakes only the node's resources show.

    A goal refused for its shape may also name a resource the node does
    not have: asked for its settings (briefly: nothing will be sent), a
    reachable node makes the report complete in one pass. Without one,
    returns and the shape's mistakes stand.
    """
    if args.kind != "goal":
        return
    from ...bus.client import SchedulerClient
    from ...bus.session import zenoh_config
    from ...wire import messages

    try:
        with (
            open_bus(zenoh_config(args)) as session,
            SchedulerClient(session, args.spacecraft) as client,
        ):
            info = client.query_config(min(args.timeout, _COMPLETE_S))
    except Exception:  # no bus: the shape's mistakes are the answer
        return
    if info is None or info.problem is None:
        return
    try:
        messages.decode_input("goal", payload, info.problem.resources)
    except InputError as complete:
        if len(complete.issues) > len(error.issues):
            raise complete from None


def _check_with_the_node(
    client: SchedulerClient,
    args: argparse.Namespace,
    message: Any,
    payload: bytes,
) -> None:
    """Check what depends on the node's problem before sending.

    The node's ``scheduler/config`` names its resources: a goal is checked
    against them in the same pass as its shape (every mistake at once), a
    level must be of one of its consumables. A node that does not answer
    leaves those checks to itself.

    Raises
    ------
    InputError
        Nothing is sent (exit 2), every mistake named.
    """
    from ...errors import FieldIssue
    from ...wire import messages

    if args.kind not in ("goal", "level"):
        return
    info = client.query_config(min(args.timeout, _CONFIG_WAIT_S))
    if info is None or info.problem is None:
        return
    resources = info.problem.resources
    if args.kind == "goal":
        messages.decode_input("goal", payload, resources)
    elif message.resource not in resources.consumable:
        known = ", ".join(resources.consumable) or "none"
        raise InputError(
            [
                FieldIssue(
                    "resource",
                    f"{message.resource!r} is not a consumable of the "
                    f"scheduler of {args.spacecraft} (consumables: {known})"
                    ": nothing sent",
                )
            ],
            "resource_level",
        )


def _published(
    args: argparse.Namespace,
    what: str,
    client: SchedulerClient,
    key: str | None,
) -> None:
    """Say what was published, where (``-q``: nothing)."""
    if getattr(args, "quiet", False):
        return
    where = key or client.topics.key("scheduler/goals")
    print(
        f"published {what} on {where}; --wait for the scheduler's verdict",
        flush=True,
    )


def _cmd_what_if(args: argparse.Namespace) -> int:
    from ...wire import messages

    check_spacecraft(args.spacecraft)
    payload = _document(args.file)
    _checked("goal", payload)
    with _client(args) as client:
        try:
            client.wait_scheduler(args.timeout)
        except TimeoutError:
            print(
                f"fsw-scheduler: no scheduler of {args.spacecraft} reachable "
                f"within {args.timeout:g} s: nothing asked",
                file=sys.stderr,
            )
            return EXIT_NO_PLAN
        answer = client.what_if(payload, args.timeout)
    if answer is None:
        print(
            f"fsw-scheduler: no what-if answer within {args.timeout:g} s",
            file=sys.stderr,
        )
        return EXIT_NO_PLAN
    print(messages.encode(answer).decode(), flush=True)
    return EXIT_OK if answer.verdict == "goal_accepted" else EXIT_NO_PLAN


def _cmd_query(args: argparse.Namespace) -> int:
    import threading

    from ...wire import messages

    check_spacecraft(args.spacecraft)
    with _client(args) as client:
        try:
            client.find_scheduler(args.timeout)
        except LookupError as error:
            print(f"fsw-scheduler: {error}", file=sys.stderr)
            return EXIT_NO_PLAN
        except TimeoutError:
            pass  # said below, as no answer
        try:
            answer: Any = (
                client.query_status(args.timeout)
                if args.what == "status"
                else client.query_plan(args.timeout)
            )
        except TimeoutError:
            answer = None
        if answer is None:
            print(
                f"fsw-scheduler: no {args.what} from a scheduler of "
                f"{args.spacecraft} within {args.timeout:g} s",
                file=sys.stderr,
            )
            return EXIT_NO_PLAN
        print(messages.encode(answer).decode(), flush=True)
        if not args.follow:
            return EXIT_OK
        stop = threading.Event()
        stop_on_signals(stop)
        items: list[Any] = (
            client.statuses if args.what == "status" else client.plans
        )
        shown = len(items)
        while not stop.is_set():
            fresh = client.wait_new(items, shown, 0.2)
            shown += len(fresh)
            for item in fresh:
                print(messages.encode(item).decode(), flush=True)
    return EXIT_OK
