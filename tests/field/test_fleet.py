"""A field mission end to end: mission control and twelve agent processes on 127.0.0.1, the
compact mission (tests/field/compact.py: the reference team on half the ground) at 100× to
completion; one hauler SIGKILLed while it carries a mineral to the plant, a new excavator
process started mid-mission, a scout killed and started again;
then, with the hauler still dead, the mission clock (docs/field.md, "The mission clock").
Checked on what mission control recorded: the mineral fell where the hauler was last heard of,
was carried by another, every mineral is accounted for, and the scout's second life numbered
its auctions apart from its first.

The clock: mission control pauses the mission and no robot acts — no delivery, no heartbeat,
the world's time standing — for a stretch of wall time in which several deliveries would have
been made; after the resume the mission goes on. Then the speed is halved and every live
agent's heartbeats advance at the new rate, in step with the world's clock. (One mission for
both: each is a whole field mission of CI time, and together they also check that a
pause and a new pace reach the agents of a fleet that lost one and gained two.)

Waits are on progress (tests/progress.py), never on a fixed deadline: the stretches watched
are measured in mission time at the speed the test runs at (tests/field/pace.py)."""

from __future__ import annotations

import os
import time
from collections.abc import Iterator
from typing import Any

import pytest

from field.fleet import Fleet
from tests.field.compact import compact_scenario
from tests.field.pace import paced
from tests.field.serial import one_field_mission_at_a_time
from tests.progress import Progress

SPEED = 100.0
#: What a field mission's progress is (tests/progress.py: a loaded machine slows it, so the
#: test waits while any of these moves, not for a fixed time; ~35 s when the machine is idle).
WORK = ("delivered", "sites_found", "scanned", "ground", "aboard")
PAUSE_SIM_S = 400.0
"""Mission time the pause is watched for, at the speed it would have run: ~10 deliveries."""
GRACE_S = 5.0
"""Wall time an agent that missed the pause command may take to hear of it (an answer of the
world, or its status poll: `field.clock.FOLLOW_POLL_S`, `field.agent.PRESENCE_POLL_S`)."""
RATE_SIM_S = 300.0
"""Mission time over which each agent's heartbeat rate is measured."""


@pytest.fixture
def fleet() -> Iterator[Fleet]:
    with one_field_mission_at_a_time():
        yield from _fleet()


def _fleet() -> Iterator[Fleet]:
    f = Fleet(compact_scenario(), 0, "nearest", paced(SPEED))
    try:
        yield f
    finally:
        f.close()  # every agent's process group, also when the test fails
        for p in f.history:
            assert p.popen.poll() is not None, f"{p.name} outlived its fleet"


def _carrying(fleet: Fleet, robot: str) -> dict[str, Any] | None:
    """The auction of the transport `robot` is carrying a mineral for, if its latest heartbeat
    (under 5 s old, when it set off for the plant: the trip takes far longer, so the kill
    cannot race the delivery) says it has one on board."""
    rec = fleet.intake
    with rec.lock:
        hb = rec.heartbeats.get(robot)
        if hb is None or hb.load == 0 or not hb.tasks or fleet.now() - hb.t > 5.0:
            return None
        won = [
            a
            for a in rec.auctions.values()
            if a["allocated_to"] == robot
            and a["status"] == "closed"
            and a["task_id"] == hb.tasks[0]
        ]
    return won[-1] if won else None


def _auctioned(fleet: Fleet, robot: str) -> bool:
    with fleet.intake.lock:
        return any(a["auctioneer"] == robot for a in fleet.intake.auctions.values())


def _work(fleet: Fleet) -> list[object]:
    status = fleet.world.status()
    return [status[k] for k in WORK]


def _run_until(fleet: Fleet, done: Any, what: str) -> None:
    watch = Progress(what)
    while not done():
        assert not fleet.world.clock.paused
        watch.check(_work(fleet), lambda: fleet.world.status())
        time.sleep(0.05)


def _beats(fleet: Fleet) -> dict[str, float]:
    """The latest heartbeat time of each agent whose process is alive."""
    alive = {name for name, p in fleet.procs.items() if p.alive}
    with fleet.intake.lock:
        return {n: hb.t for n, hb in fleet.intake.heartbeats.items() if n in alive}


def _pause_holds_every_agent(fleet: Fleet) -> None:
    """Paused, nothing moves for as long as ~10 deliveries would take; resumed, it goes on."""
    delivered = lambda: fleet.world.status()["delivered"]  # noqa: E731
    t_paused = fleet.set_clock(paused=True)
    d0 = delivered()
    with fleet.intake.lock:
        n_events = len(fleet.intake.events)
    start = time.monotonic()
    stretch = max(PAUSE_SIM_S / fleet.speed, GRACE_S + 3.0)
    settled: dict[str, float] | None = None
    while time.monotonic() - start < stretch:
        assert fleet.now() == t_paused, "the world's clock moved while paused"
        assert delivered() == d0, "a delivery while paused"
        if settled is None and time.monotonic() - start >= GRACE_S:
            settled = _beats(fleet)  # every agent heard of the pause by now
        elif settled is not None:
            assert _beats(fleet) == settled, "an agent's heartbeat while paused"
        time.sleep(0.05)
    with fleet.intake.lock:
        said = fleet.intake.events[n_events:]
    assert not [e for e in said if e.get("event") in ("delivered", "mineral_delivered")], said
    assert fleet.world.status()["t"] == t_paused
    fleet.set_clock(paused=False)
    _run_until(fleet, lambda: delivered() >= d0 + 3, "deliveries after the resume")


def _a_new_speed_reaches_every_agent(fleet: Fleet) -> None:
    """At half the speed every live agent's heartbeats advance at the new rate, in step with
    the world's clock; then the speed is set back."""
    speed = fleet.speed
    new = speed / 2
    t_changed = fleet.set_clock(speed=new)
    first = _beats(fleet)
    since = {n: (time.monotonic(), t) for n, t in first.items()}
    rates: dict[str, float] = {}
    drift: dict[str, float] = {}
    watch = Progress("every agent's heartbeats at the new speed")
    while len(rates) < len(first):
        watch.check(sorted(_beats(fleet).items()))
        now_wall, now_world = time.monotonic(), fleet.now()
        for name, t in _beats(fleet).items():
            if name not in since or name in rates or t < t_changed + 20.0:
                continue  # (heartbeats sent before it heard of the change: 10 s apart)
            if since[name][1] < t_changed + 20.0:
                since[name] = (now_wall, t)  # measured from its first beat at the new pace
            elif t - since[name][1] >= RATE_SIM_S:
                rates[name] = (t - since[name][1]) / (now_wall - since[name][0])
                drift[name] = now_world - t
        time.sleep(0.02)
    assert abs(fleet.world.clock.speed - new) < 1e-9 and fleet.speed == new
    slow = {n: r for n, r in rates.items() if not 0.6 * new <= r <= 1.3 * new}
    assert not slow, f"heartbeat rates (mission s per wall s) off {new:g}x: {slow}"
    # one still on the old pace would be RATE_SIM_S / 2 ahead of the world by now
    apart = {n: d for n, d in drift.items() if abs(d) > 0.2 * RATE_SIM_S}
    assert not apart, f"agents' mission time apart from the world's: {apart}"
    fleet.set_clock(speed=speed)


@pytest.mark.slow
@pytest.mark.fleet
def test_field_mission_survives_a_sigkill_and_a_new_excavator_and_keeps_its_clock(
    fleet: Fleet,
) -> None:
    fleet.up()
    pids = {p.name: p.popen.pid for p in fleet.history}
    assert len(pids) == 12 and len(set(pids.values())) == 12 and os.getpid() not in pids.values()
    watch = Progress("the field mission to finish")
    killed: dict[str, Any] | None = None
    added = None
    reborn: float | None = None  # when scout-1's second life began
    clocked = False  # the pause and the new speed are checked
    while not fleet.world.terrain.finished.triggered:
        status = fleet.world.status()
        watch.check([status[k] for k in WORK], lambda: f"not finished: {fleet.world.status()}")
        now = fleet.now()
        if killed is None and now >= 400:
            held = _carrying(fleet, "hauler-2")
            if held is not None:
                fleet.kill("hauler-2")  # SIGKILL: nothing said, peers find out by its silence
                killed = held
                assert fleet.world.status()["ground"] >= 1  # its mineral fell where it was
        if added is None and now >= 150:  # sites are still being found until ~700 s
            added = fleet.add("excavator")
        if reborn is None and now >= 150 and _auctioned(fleet, "scout-1"):
            # its first life auctioned a site: its second counts its auctions from 1 again
            fleet.kill("scout-1")
            fleet.spawn("scout-1")
            reborn = fleet.now()
        if not clocked and killed is not None and status["delivered"] >= 4:
            clocked = True
            _pause_holds_every_agent(fleet)
            _a_new_speed_reaches_every_agent(fleet)
            watch = Progress("the field mission to finish")  # (paused: nothing moved)
        time.sleep(0.02)

    status = fleet.world.status()
    compact = compact_scenario()
    assert status["delivered"] == status["minerals_total"] == compact.minerals
    assert status["sites_found"] == status["sites_total"] == compact.sites
    assert status["ground"] == 0 and status["sites_remaining"] == 0 and status["aboard"] == 0
    assert killed is not None and added == "excavator-5" and clocked
    assert fleet.world.status()["clock"]["version"] == 4  # pause, resume, two speeds
    time.sleep(0.3)  # the last records in flight
    # the mineral on board fell to the ground and another hauler took it to the plant
    with fleet.intake.lock:
        events = [(e["event"], e["data"]) for e in fleet.intake.events]
    dropped = [d for k, d in events if k == "mineral_dropped" and d["robot"] == "hauler-2"]
    assert len(dropped) == 1, dropped
    picked = [
        d for k, d in events if k == "mineral_recovered" and d["mineral"] == dropped[0]["mineral"]
    ]
    assert len(picked) == 1 and picked[0]["robot"] != "hauler-2", picked
    assert sum(k == "delivered" for k, _ in events) == compact.minerals
    auctions = list(fleet.intake.auctions.values())
    # the killed hauler's task was auctioned again, and someone else carried it
    again = [a for a in auctions if a["reauction_of"] == killed["id"]]
    assert again, f"{killed['task_id']} held by hauler-2 was never re-auctioned"
    assert all(a["allocated_to"] != "hauler-2" for a in again)
    assert any(a["status"] == "closed" and a["allocated_to"] for a in again), again
    # the excavator that joined mid-mission won work
    won = {a["allocated_to"] for a in auctions if a["task_type"] == "excavate"}
    assert "excavator-5" in won, f"excavation winners: {won}"
    # each auction is one: the scout's two lives never share an auction's id
    closes = [d["auction_id"] for k, d in events if k == "auction_closed"]
    assert len(closes) == len(set(closes)), sorted(c for c in closes if closes.count(c) > 1)
    assert reborn is not None
    second = [a for a in auctions if a["auctioneer"] == "scout-1" and a["opened_at"] > reborn]
    assert all(a["id"].endswith("@2") for a in second), [a["id"] for a in second]
    first = [a for a in auctions if a["auctioneer"] == "scout-1" and a["opened_at"] < reborn]
    assert first and not any("@" in a["id"] for a in first)
    # what mission control heard was valid: nothing malformed on the wire
    assert fleet.intake.malformed == 0 and fleet.intake.messages > 1000
