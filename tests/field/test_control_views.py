"""What `FieldMission` makes of what mission control hears, without agent processes: a
stand-in fleet whose intake (the real `field.intake.Intake`) is fed by hand.

- An auction record changes in a report of its own, often just after the event naming it;
  the live runner must stream the change, not only the record as it stood at the event.
- Each robot's distance travelled is summed from its heartbeats, along the announced route.
- The robots still running at the end are not stored as failed (their processes end with it).
"""

from __future__ import annotations

import math
from types import SimpleNamespace
from typing import Any

import pytest

from app.live.streaming import note_auction, note_event
from engine.messages import Heartbeat
from engine.scenario import Scenario
from field import control
from field.intake import Intake
from field.odometer import Odometer, along


class StandInFleet:
    """`WorldHandle`'s surface that `FieldMission` reads, and no processes."""

    def __init__(self, scenario: Scenario, seed: int, policy: str, speed: float, **_: Any) -> None:
        self.intake = Intake(link=None)  # type: ignore[arg-type]  # (fed by hand)
        finished = SimpleNamespace(triggered=False)
        terrain = SimpleNamespace(finished=finished, finished_at=None)
        self.world = SimpleNamespace(world=None, terrain=terrain, policy=policy, starts={})
        self.procs: dict[str, Any] = {}
        self.t = 10.0

    def catch_up(self) -> bool:
        return True

    def close(self, stop: bool = True) -> None:
        for proc in self.procs.values():  # every agent ends with the mission
            proc.code = proc.code if proc.code is not None else -15

    def now(self) -> float:
        return self.t


@pytest.fixture
def mission() -> control.FieldMission:
    fleet = StandInFleet(Scenario(), 0, "nearest", 50.0)
    return control.FieldMission(Scenario(), 0, "nearest", 50.0, handle=fleet)  # type: ignore[arg-type]


def record(status: str) -> dict[str, Any]:
    return {"id": "scout-1/1", "status": status, "bids": [], "awards": []}


def test_a_record_changed_after_its_event_is_streamed(mission: control.FieldMission) -> None:
    lm = SimpleNamespace(hub=SimpleNamespace(viewers={"a viewer"}), dirty_auctions=set(), outbox=[])
    mission.subscribe(lambda ev: note_event(lm, ev))  # type: ignore[arg-type]
    mission.watch_auctions(lambda aid: note_auction(lm, aid))  # type: ignore[arg-type]
    rec = mission.fleet.intake
    rec.auctions["scout-1/1"] = record("open")
    rec.events.append({"t": 1.0, "event": "auction_opened", "data": {"auction_id": "scout-1/1"}})
    mission.advance(10.0)
    assert lm.dirty_auctions == {"scout-1/1"}
    lm.dirty_auctions.clear()
    # the close: its event comes first, the record a moment later
    rec.events.append({"t": 2.0, "event": "auction_closed", "data": {"auction_id": "scout-1/1"}})
    mission.advance(10.0)
    assert lm.dirty_auctions == {"scout-1/1"}  # (streamed as it stands: still open)
    lm.dirty_auctions.clear()
    mission.advance(10.0)
    assert lm.dirty_auctions == set()  # nothing new heard, nothing to stream
    rec.auctions["scout-1/1"] = record("closed")
    mission.advance(10.0)
    assert lm.dirty_auctions == {"scout-1/1"}  # the closed record goes out too
    assert mission.auctions[0].status == "closed"


def beat(x: float, y: float, path: list[tuple[float, float]], t: float = 0.0) -> Heartbeat:
    return Heartbeat(sender="hauler-1", rtype="hauler", t=t, x=x, y=y, state="moving", path=path)


def test_distance_follows_the_announced_route() -> None:
    odo = Odometer()
    route = [(0.0, 0.0), (10.0, 0.0), (10.0, 10.0)]
    first = beat(0.0, 0.0, route)
    odo.heard([("hauler-1", first)])
    assert odo.metres["hauler-1"] == 0.0
    odo.heard([("hauler-1", first)])  # the same heartbeat again adds nothing
    # round the corner: 10 m along x, then 4 m along y (the chord would say 10.8 m)
    odo.heard([("hauler-1", beat(10.0, 4.0, [(10.0, 4.0), (10.0, 10.0)], t=14.0))])
    assert odo.metres["hauler-1"] == pytest.approx(14.0)
    # off the route (a new plan): the straight line
    odo.heard([("hauler-1", beat(13.0, 8.0, [], t=20.0))])
    assert odo.metres["hauler-1"] == pytest.approx(14.0 + 5.0)
    assert odo.metrics() == {
        "distance": {"scout": 0.0, "excavator": 0.0, "hauler": pytest.approx(19.0)},
        "distance_total": pytest.approx(19.0),
    }
    assert along(route, (5.0, 3.0)) is None  # 3 m off the route
    assert math.isclose(along(route, (5.0, 0.5)) or 0.0, 5.0)


def test_the_mission_reports_heard_distances(mission: control.FieldMission) -> None:
    rec = mission.fleet.intake
    rec.heartbeats["hauler-1"] = beat(0.0, 0.0, [(0.0, 0.0), (6.0, 8.0)])
    mission.advance(10.0)
    rec.heartbeats["hauler-1"] = beat(6.0, 8.0, [], t=10.0)
    mission.advance(10.0)
    m = mission.odometer.metrics()
    assert m["distance"] == {"scout": 0.0, "excavator": 0.0, "hauler": pytest.approx(10.0)}


class Proc:
    """An agent process: `code` None while it runs."""

    def __init__(self, code: int | None) -> None:
        self.code = code

    @property
    def alive(self) -> bool:
        return self.code is None


def test_robots_running_at_the_end_are_not_stored_as_failed(
    mission: control.FieldMission,
) -> None:
    fleet = mission.fleet
    fleet.procs = {"hauler-1": Proc(None), "hauler-2": Proc(-9)}  # hauler-2: SIGKILLed before
    for name in fleet.procs:
        fleet.intake.heartbeats[name] = beat(1.0, 2.0, [])
    assert {r["name"]: r["state"] for r in mission.robot_list()} == {
        "hauler-1": "moving",
        "hauler-2": "failed",
    }
    mission.close()  # the mission ended: every process is gone now
    assert not any(p.alive for p in fleet.procs.values())
    assert {r["name"]: r["state"] for r in mission.robot_list()} == {
        "hauler-1": "moving",
        "hauler-2": "failed",
    }
