"""Tests of the sources of inputs and verdicts (no bus: links are fed)."""

from __future__ import annotations

from types import SimpleNamespace

import zenoh

from fsw_scheduler.bus.provenance import MAX_PENDING_GOALS, Provenance
from fsw_scheduler.engine.events import GoalArrived, InputRejected
from fsw_scheduler.model.goal import Goal
from fsw_scheduler.wire import messages

GOALS = "fsw/sat1/scheduler/goals"
ALLOWED = {GOALS: frozenset({"ground", "autonomy"})}


def provenance(links: dict[str, str | None]) -> Provenance:
    """A Provenance whose session has these links (zid -> name)."""
    tracker = Provenance(lambda key: ALLOWED.get(key, frozenset()))
    for zid, name in links.items():
        tracker._on_link(
            SimpleNamespace(
                kind=zenoh.SampleKind.PUT,
                link=SimpleNamespace(zid=zid, auth_identifier=name),
            )
        )
    return tracker


def test_a_claimed_session_with_an_allowed_link_is_named() -> None:
    """Tests basis 'link': the claim and the policy agree."""
    tracker = provenance({"aa": "ground", "bb": "executor"})
    assert tracker.resolve(GOALS, ("aa", 3, 7)) == messages.Source(
        "aa", 3, 7, "ground", "link"
    )


def test_a_claim_the_policy_contradicts_falls_back_to_the_policy() -> None:
    """Tests that claiming another role's session does not borrow its name."""
    tracker = provenance({"aa": "ground", "bb": "executor"})
    source = tracker.resolve(GOALS, ("bb", 1, 1))
    assert (source.zid, source.identity, source.basis) == (
        "bb",
        "ground",
        "policy",
    )


def test_without_a_claim_the_policy_names_the_candidates() -> None:
    """Tests basis 'policy' with two connected goal certificates."""
    tracker = provenance({"aa": "ground", "cc": "autonomy", "bb": "exec"})
    assert tracker.resolve(GOALS, None) == messages.Source(
        identity="autonomy|ground", basis="policy"
    )
    tracker._on_link(
        SimpleNamespace(
            kind=zenoh.SampleKind.DELETE,
            link=SimpleNamespace(zid="cc", auth_identifier="autonomy"),
        )
    )
    assert tracker.resolve(GOALS, None).identity == "ground"


def test_without_a_policy_only_links_name_senders() -> None:
    """Tests that with no access control only a direct link names one."""
    tracker = Provenance(None)
    tracker._on_link(
        SimpleNamespace(
            kind=zenoh.SampleKind.PUT,
            link=SimpleNamespace(zid="aa", auth_identifier=None),
        )
    )
    assert tracker.resolve(GOALS, ("aa", 1, 1)) == messages.Source("aa", 1, 1)
    assert tracker.resolve(GOALS, None) == messages.Source()


def _annotated(
    tracker: Provenance, status: messages.Status
) -> messages.Status:
    """``tracker.annotate(status)``, which stays a status."""
    annotated = tracker.annotate(status)
    assert isinstance(annotated, messages.Status)
    return annotated


def test_verdicts_get_the_source_of_their_input() -> None:
    """Tests annotate: now, later for a goal, never for other statuses."""
    tracker = provenance({"aa": "ground"})
    source = tracker.resolve(GOALS, ("aa", 1, 1))
    tracker.begin(GoalArrived(Goal(goal_id="g1", tasks=())), source)
    plan = messages.Status(state="ok", plan_id=1, event="plan")
    assert tracker.annotate(plan) is plan
    tracker.end()
    accepted = messages.Status(
        state="ok", plan_id=2, event="goal_accepted", goal_id="g1"
    )
    assert _annotated(tracker, accepted).source == source
    assert _annotated(tracker, accepted).source is None
    tracker.begin(InputRejected("k", "activity_report", ()), source)
    rejected = messages.Status(state="ok", plan_id=2, event="input_rejected")
    assert _annotated(tracker, rejected).source == source
    tracker.end()
    assert _annotated(tracker, rejected).source is None


def test_pending_goals_are_bounded() -> None:
    """Tests that goals never judged are forgotten, oldest first."""
    tracker = provenance({})
    for idx in range(MAX_PENDING_GOALS + 5):
        tracker.begin(
            GoalArrived(Goal(goal_id=f"g{idx}", tasks=())), messages.Source()
        )
    assert len(tracker._goals) == MAX_PENDING_GOALS
    assert "g0" not in tracker._goals
