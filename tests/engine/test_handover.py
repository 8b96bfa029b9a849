"""The hand-over exchange (engine/robots/rendezvous.py, engine/robots/handover.py): the
hauler's side as a state machine, the excavator's answers, the simulated rendezvous, and
missions whose haulers and excavators fail at every step of their hand-overs."""

from __future__ import annotations

from types import SimpleNamespace

import simpy
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from engine import Mission
from engine.robots.handover import Taking
from engine.robots.rendezvous import (
    Arrived,
    Here,
    Left,
    Loading,
    LocalRendezvous,
    Ready,
    Sight,
    Transfer,
    recorded,
)
from tests.engine.factories import small_scenario
from tests.engine.invariants import InvariantWatch

GIVER = Sight("excavator-1", "excavator", True, (0.3, 0.0), (), "t1")


class StubHauler:
    """What `Taking` needs of a hauler, by hand."""

    def __init__(self) -> None:
        self.ctx = SimpleNamespace(env=simpy.Environment())
        self.alive = True
        self.bin = 0
        self.current = None
        self.pos = (0.0, 0.0)
        self.woken = 0
        self.changed = 0

    def wake(self) -> None:
        self.woken += 1

    def tasks_changed(self) -> None:
        self.changed += 1


def _taking() -> tuple[StubHauler, Taking]:
    h = StubHauler()
    return h, Taking(h)  # type: ignore[arg-type]


def test_a_hand_over_goes_apart_waiting_loading_full():
    h, t = _taking()
    assert t.state == "apart"
    loaded = t.wait()
    assert t.state == "waiting"
    assert t.on_handover(GIVER, Loading(12.0), recorded) and t.state == "loading"
    assert t.loading_s == 12.0
    assert t.on_handover(GIVER, Transfer("t1"), recorded)
    assert t.state == "full" and h.bin == 1 and t.loading_s is None
    assert loaded.triggered
    assert h.current is not None and h.current.task_id == "t1"  # a coalition hand-over's task
    assert h.changed == 1  # the board of rounds learns the hauler holds it
    assert h.current.auctioneer == "excavator-1"
    assert not t.on_handover(GIVER, Transfer("t1"), recorded)  # a bin takes one mineral
    assert h.bin == 1


def test_can_receive_only_looks():
    h, t = _taking()
    t.wait()
    for _ in range(3):
        assert t.can_receive(GIVER.pos)
    assert h.bin == 0 and t.state == "waiting"


def test_a_transfer_is_refused_unless_the_hauler_stands_by_beside_the_giver():
    asked: list[int] = []

    def witness() -> bool:
        asked.append(1)
        return True

    h, t = _taking()
    assert not t.on_handover(GIVER, Transfer("t1"), witness)  # apart: it never stood by
    t.wait()
    far = Sight("excavator-1", "excavator", True, (5.0, 0.0))
    assert not t.on_handover(far, Transfer("t1"), witness)
    h.alive = False
    assert not t.on_handover(GIVER, Transfer("t1"), witness)
    h.alive = True
    t.stop()  # it left
    assert not t.on_handover(GIVER, Transfer("t1"), witness)
    assert asked == [] and h.bin == 0  # the witness is asked only for a move that can happen
    t.wait()
    t.on_handover(GIVER, Loading(3.0), witness)
    assert not t.on_handover(GIVER, Transfer("t1"), lambda: False)  # the record refuses
    assert h.bin == 0 and t.loading_s is None and t.state == "waiting"


def test_ready_asks_whether_it_stands_by_and_free_whether_it_holds_no_task():
    h, t = _taking()
    assert not t.on_handover(GIVER, Ready(free=False), recorded)
    t.wait()
    assert t.on_handover(GIVER, Ready(free=False), recorded)
    assert t.on_handover(GIVER, Ready(free=True), recorded)
    h.current = object()  # type: ignore[assignment]
    assert t.on_handover(GIVER, Ready(free=False), recorded)
    assert not t.on_handover(GIVER, Ready(free=True), recorded)


def test_here_wakes_the_hauler_and_a_takers_message_is_not_for_it():
    h, t = _taking()
    assert t.on_handover(GIVER, Here(), recorded) and h.woken == 1
    assert not t.on_handover(GIVER, Arrived("t1"), recorded)
    assert not t.on_handover(GIVER, Left(), recorded)


def test_the_excavator_answers_arrivals_and_its_partner_coming_and_going():
    m = Mission(small_scenario(), 1, "coalition")
    try:
        exc = m.ctx.robots["excavator-1"]
        hauler = Sight("hauler-1", "hauler", True, exc.pos)
        assert not exc.on_handover(hauler, Arrived("nobody-expects-this"), recorded)
        assert exc.on_handover(hauler, Arrived(None), recorded)
        assert exc.partner_here == "hauler-1"
        other = Sight("hauler-2", "hauler", True, exc.pos)
        exc.on_handover(other, Left(), recorded)
        assert exc.partner_here == "hauler-1"  # only the partner's own leaving counts
        exc.on_handover(hauler, Left(), recorded)
        assert exc.partner_here is None
        assert not exc.on_handover(hauler, Transfer("t"), recorded)  # a giver takes nothing
    finally:
        m.close()


def test_a_partner_arriving_as_the_auction_closes_leaves_the_mineral_to_its_winner():
    """Field mode's race (chaos seed 202): the partner comes while a transport auction waits
    for its winner's Ack, and the Ack closes the auction before the excavator acts on the
    arrival. The mineral is the winner's: handed to the partner, two haulers held one task."""
    m = Mission(small_scenario(), 1, "coalition")
    given: list[tuple[str, str, str]] = []  # (excavator, hauler, task) of every hand-over
    raced: list[tuple[str, str, str, int]] = []  # (excavator, partner, winner, hand-overs)
    try:
        for exc in (r for r in m.ctx.robots.values() if r.rtype == "excavator"):

            def on_ack(msg, exc=exc, original=exc.house.on_ack):
                original(msg)  # the winner's Ack: the auction closes when its process runs
                task = exc.waiting_for
                if not raced and msg.accepted and task is not None and exc.house.is_open(task):
                    partner = next(h for h in ("hauler-1", "hauler-2") if h != msg.winner)
                    exc._partner_arrived(partner)  # ...and the partner arrives meanwhile
                    raced.append((exc.name, partner, msg.winner, len(given)))

            def transfer(hauler, site, exc=exc, original=exc.transfer):
                given.append((exc.name, hauler, str(exc.waiting_for)))
                return original(hauler, site)

            exc.house.on_ack = on_ack
            exc.transfer = transfer
        watch = InvariantWatch(m)
        m.run()
        watch.final()
        assert m.status == "completed"
    finally:
        m.close()
    assert raced, "no transport auction was won while its excavator waited"
    name, _partner, winner, before = raced[0]
    then = next(g for g in given[before:] if g[0] == name)
    assert then[1] == winner, (raced, then)


def test_the_local_rendezvous_delivers_by_name_and_sees_only_what_stands_near():
    m = Mission(small_scenario(), 1, "fcfs")
    try:
        rv = LocalRendezvous(m.ctx.robots)
        exc = m.ctx.robots["excavator-1"]
        assert not rv.send(exc, "nobody", Here())
        assert not rv.send(exc, "scout-1", Here())  # a scout takes no part in hand-overs
        seen = rv.look("excavator-1")
        assert seen is not None and seen.name == "excavator-1" and seen.pos == exc.pos
        near = rv.around(exc.pos, "excavator")
        assert [s.name for s in near] == [
            r.name for r in m.ctx.robots.values() if r.rtype == "excavator" and r.pos == exc.pos
        ]
        assert rv.look("nobody") is None
    finally:
        m.close()


# --- missions whose hand-overs are cut short at every step ----------------------------------
def _handover_times(seed: int, policy: str) -> list[tuple[float, str, str]]:
    """Each hand-over of an undisturbed run: (its end, the hauler, the excavator)."""
    m = Mission(small_scenario(), seed, policy)
    try:
        m.run()
        return [
            (e.t, e.data["robot"], e.data["from_robot"]) for e in m.events if e.kind == "pickup"
        ]
    finally:
        m.close()


@given(
    seed=st.integers(0, 2_000),
    policy=st.sampled_from(["fcfs", "coalition", "lookahead", "nearest"]),
    which=st.integers(0, 50),
    before=st.floats(-5.0, 40.0),  # from after the transfer back to the hauler's arrival
    who=st.sampled_from(["hauler", "excavator"]),
    how=st.sampled_from(["abrupt", "graceful", "stall"]),
    stall_s=st.floats(1.0, 120.0),
)
@settings(max_examples=25, deadline=None, suppress_health_check=[HealthCheck.too_slow])
def test_a_mineral_is_in_exactly_one_place_whoever_fails_during_a_hand_over(
    seed, policy, which, before, who, how, stall_s
):
    """A hauler or an excavator fails (abruptly, gracefully, or for a while: stalled) at a
    step of a hand-over: before it arrives, while it stands by, mid-transfer, at the move,
    just after. At every event every mineral is in exactly one place (no loss, no copy),
    and the mission still delivers them all."""
    times = _handover_times(seed, policy)
    if not times:
        return
    end, hauler, exc = times[which % len(times)]
    name = hauler if who == "hauler" else exc
    m = Mission(small_scenario(), seed, policy)
    try:
        watch = InvariantWatch(m)
        m.advance(max(0.0, end - before))
        if not m.done:
            m.disable_robot(name, "abrupt" if how == "stall" else how)
            if how == "stall":
                m.advance(m.now + stall_s)
                if not m.done:
                    m.enable_robot(name)
        m.run()
        watch.final()
        assert m.status == "completed", (name, how, m.metrics())
        assert m.ctx.terrain.delivered == m.ctx.terrain.minerals_total
    finally:
        m.close()
