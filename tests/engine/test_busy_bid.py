"""`protocol.busy_bid = "silent"`: a busy robot says nothing where the specification has it
bid -inf. The auctioneer never awards a -inf bid and only reads one as the withdrawal of a
finite bid, which a silent robot still sends; so on the ideal bus the auctions end exactly
as they do under "once" (same winners, same times), with fewer messages. On a lossy bus the
fewer messages draw the bus's random stream differently, so runs differ there (not tested).
"""

from __future__ import annotations

import math
from typing import Any

from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from engine import POLICIES, Mission, reference_scenario
from engine.scenario import Protocol, Scenario
from tests.engine.factories import play_actions, small_scenario

ROBOTS = ["scout-1", "excavator-1", "excavator-2", "hauler-1", "hauler-2"]
ACTION = st.one_of(
    st.tuples(st.sampled_from(["fail", "enable"]), st.sampled_from(ROBOTS)),
    st.tuples(st.just("add"), st.sampled_from(["excavator", "hauler"])),
    st.tuples(st.just("policy"), st.sampled_from(list(POLICIES))),
    st.tuples(st.just("inject"), st.sampled_from(["excavate", "transport"])),
)


def _play(busy_bid: str, seed: int, policy: str, actions: list[tuple[float, str, str]]) -> Mission:
    scenario = small_scenario(
        sites=3,
        minerals=6,
        team={"scouts": 1, "excavators": 3, "haulers": 3},
        protocol={"busy_bid": busy_bid},
    )
    m = Mission(scenario, seed, policy)
    play_actions(m, actions)
    m.run()
    return m


def _outcomes(m: Mission) -> list[Any]:
    """What the auctions decided and what the robots did, without the bids themselves."""
    auctions = [
        (
            a.id,
            a.status,
            a.closed_at,
            a.allocated_to,
            [(w.t, w.winner, w.outcome) for w in a.awards],
        )
        for a in m.auctions
    ]
    work = [
        (e.t, e.kind, e.data.get("robot"), e.data.get("task_id"))
        for e in m.events
        if e.kind in ("task_started", "task_ended", "mineral_delivered", "mission_ended")
    ]
    return [m.status, m.metrics()["makespan_s"], auctions, work]


@given(
    seed=st.integers(0, 10_000),
    policy=st.sampled_from(list(POLICIES)),
    actions=st.lists(st.tuples(st.floats(1.0, 600.0), ACTION), max_size=4),
)
@settings(max_examples=15, deadline=None, suppress_health_check=[HealthCheck.too_slow])
def test_silent_busy_robots_change_the_messages_not_the_allocations(seed, policy, actions):
    plan = [(t, kind, arg) for t, (kind, arg) in sorted(actions, key=lambda a: a[0])]
    spec, silent = _play("once", seed, policy, plan), _play("silent", seed, policy, plan)
    assert _outcomes(silent) == _outcomes(spec)
    assert silent.metrics()["messages"] <= spec.metrics()["messages"]
    for a in silent.auctions:  # a -inf is only ever the withdrawal of one's own finite bid
        finite: set[str] = set()
        for b in a.bids:
            if math.isfinite(b.utility):
                finite.add(b.bidder)
            else:
                assert b.bidder in finite, (a.id, b)


def test_silence_saves_the_refusals_of_a_busy_team() -> None:
    spec, silent = _play("once", 3, "fcfs", []), _play("silent", 3, "fcfs", [])
    refusals = sum(1 for a in spec.auctions for b in a.bids if b.utility == -math.inf)
    assert refusals > 0
    assert spec.metrics()["bids"] - silent.metrics()["bids"] == refusals


def protocol(scenario: Scenario, busy_bid: str) -> Protocol:
    return Protocol.model_validate({**scenario.protocol.model_dump(), "busy_bid": busy_bid})


def _withdrawals(m: Mission) -> list[tuple[str, str, float]]:
    """-inf bids that take back the same robot's finite bid in the same auction."""
    out = []
    for a in m.auctions:
        finite: set[str] = set()
        for b in a.bids:
            if math.isfinite(b.utility):
                finite.add(b.bidder)
            elif b.bidder in finite:
                out.append((a.id, b.bidder, b.t))
    return out


def test_a_silent_robot_still_withdraws_its_finite_bids() -> None:
    """Policy 4 bids expected arrival times and takes one back when it runs out of room
    (the reference mission, seed 2, has 8 such): those -inf bids steer who wins, and silence
    keeps them."""
    ref = reference_scenario()
    spec, silent = (
        Mission(ref.model_copy(update={"protocol": protocol(ref, b)}), 2, "lookahead")
        for b in ("once", "silent")
    )
    spec.run()
    silent.run()
    assert len(_withdrawals(spec)) > 0
    assert _withdrawals(silent) == _withdrawals(spec)
    assert _outcomes(silent) == _outcomes(spec)
