"""A field mission end to end: mission control and twelve agent processes on 127.0.0.1, the
reference mission at 100× to completion; one hauler SIGKILLed while it carries a mineral to
the plant, a new excavator process started mid-mission, a scout killed and started again.
Checked on what mission control recorded: the mineral fell where the hauler was last heard of,
was carried by another, every mineral is accounted for, and the scout's second life numbered
its auctions apart from its first."""

from __future__ import annotations

import os
import time
from collections.abc import Iterator
from typing import Any

import pytest

from engine.scenario import reference_scenario
from field.fleet import Fleet
from tests.field.pace import paced
from tests.field.serial import one_field_mission_at_a_time
from tests.progress import Progress

SPEED = 100.0
#: What a field mission's progress is (tests/progress.py: a loaded machine slows it, so the
#: test waits while any of these moves, not for a fixed time; ~35 s when the machine is idle).
WORK = ("delivered", "sites_found", "scanned", "ground", "aboard")


@pytest.fixture
def fleet() -> Iterator[Fleet]:
    with one_field_mission_at_a_time():
        yield from _fleet()


def _fleet() -> Iterator[Fleet]:
    f = Fleet(reference_scenario(), 0, "nearest", paced(SPEED))
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


@pytest.mark.slow
@pytest.mark.fleet
def test_field_mission_survives_a_sigkill_and_a_new_excavator(fleet: Fleet) -> None:
    fleet.up()
    pids = {p.name: p.popen.pid for p in fleet.history}
    assert len(pids) == 12 and len(set(pids.values())) == 12 and os.getpid() not in pids.values()
    watch = Progress("the field mission to finish")
    killed: dict[str, Any] | None = None
    added = None
    reborn: float | None = None  # when scout-1's second life began
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
        if added is None and now >= 300:  # sites are still being found until ~1300 s
            added = fleet.add("excavator")
        if reborn is None and now >= 150 and _auctioned(fleet, "scout-1"):
            # its first life auctioned a site: its second counts its auctions from 1 again
            fleet.kill("scout-1")
            fleet.spawn("scout-1")
            reborn = fleet.now()
        time.sleep(0.02)

    status = fleet.world.status()
    assert status["delivered"] == status["minerals_total"] == 64
    assert status["sites_found"] == status["sites_total"] == 10
    assert status["ground"] == 0 and status["sites_remaining"] == 0 and status["aboard"] == 0
    assert killed is not None and added == "excavator-5"
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
    assert sum(k == "delivered" for k, _ in events) == 64
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
