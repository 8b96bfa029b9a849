"""A field run's moment from its stored rows (app/services/field_playback.py), on hand-built
rows: robots where their poses around `t` put them, sites, ground and auctions as the events
and records up to `t` say, in the simulated playback's shape."""

from __future__ import annotations

import base64
import math
import random
from collections.abc import Sequence
from typing import Any

import numpy as np
import pytest

from app.services.field_playback import (
    HOLD_GAP_S,
    PoseRow,
    Stored,
    auctions_at,
    moment,
    pose_at,
    robots_at,
)
from engine import Mission
from engine.scenario import reference_scenario
from field.agent import POSE_INTERVAL_S

WORLD: dict[str, Any] = {
    "width": 100.0,
    "height": 100.0,
    "grid": {"cols": 10, "rows": 10, "cell_w": 10.0, "cell_h": 10.0},
    "sites": [
        {"id": "site-1", "x": 20.0, "y": 20.0, "minerals": 3},
        {"id": "site-2", "x": 80.0, "y": 70.0, "minerals": 2},
    ],
}
MISSION = {"status": "running", "policy": "nearest", "scenario": "hand", "seed": 7}


def pose(robot: str, t: float, x: float, y: float, heading: float = 0.0, **kw: Any) -> PoseRow:
    return PoseRow(robot, t, x, y, heading, kw.get("state", "travelling"), kw.get("load", 0))


def event(seq: int, t: float, kind: str, **data: Any) -> dict[str, Any]:
    return {"seq": seq, "t": t, "kind": kind, "data": data}


def stored_at(t: float, poses: list[PoseRow], events: Sequence[dict[str, Any]] = ()) -> Stored:
    """What `read_stored` would read up to `t` from these rows."""
    after: dict[str, PoseRow] = {}
    for p in sorted(poses, key=lambda p: p.t):
        if t < p.t <= t + HOLD_GAP_S:
            after.setdefault(p.robot, p)
    upto = [e for e in events if e["t"] <= t]
    return Stored(
        sorted((p for p in poses if p.t <= t), key=lambda p: p.t),
        after,
        upto,
        1 + max((e["seq"] for e in upto), default=-1),
        0,
        [],
    )


def test_the_gap_is_counted_in_reports() -> None:
    assert HOLD_GAP_S == 4 * POSE_INTERVAL_S


def test_interpolation_between_two_poses_and_hold_after_the_last() -> None:
    rng = random.Random()
    a = pose("hauler-1", 10.0, rng.uniform(0, 100), rng.uniform(0, 100), 3.0)
    b = pose("hauler-1", 15.0, rng.uniform(0, 100), rng.uniform(0, 100), -3.0)
    for f in (0.0, 0.25, 0.5, 1.0, rng.random()):
        t = 10.0 + 5.0 * f
        x, y, h = pose_at(a, b, t)
        assert x == pytest.approx(a.x + f * (b.x - a.x))
        assert y == pytest.approx(a.y + f * (b.y - a.y))
        # the short way round: from 3.0 to -3.0 through pi, not through 0
        assert abs(h - 3.0) <= f * (2 * math.pi - 6.0) + 1e-9
    assert pose_at(b, None, 99.0) == (b.x, b.y, b.heading)  # none after: the last one
    far = pose("hauler-1", 10.0 + HOLD_GAP_S + 1, 0.0, 0.0)
    assert pose_at(a, far, 12.0) == (a.x, a.y, a.heading)  # not reporting meanwhile: held


def test_robots_absent_before_their_first_pose_failed_when_events_say() -> None:
    poses = [
        pose("scout-1", 1.0, 10.0, 10.0),
        pose("scout-1", 6.0, 15.0, 10.0),
        pose("hauler-1", 2.0, 50.0, 50.0, state="carrying", load=1),
        pose("hauler-1", 7.0, 50.0, 60.0, state="carrying", load=1),
        pose("hauler-1", 12.0, 50.0, 70.0),
        pose("excavator-2", 30.0, 70.0, 70.0),
    ]
    events = [event(0, 8.0, "robot_failed", robot="hauler-1")]
    at = {r["name"]: r for r in robots_at(stored_at(4.0, poses, events), 4.0)}
    assert list(at) == ["scout-1", "hauler-1"]  # excavator-2 has not started yet
    assert (at["scout-1"]["x"], at["scout-1"]["y"]) == pytest.approx((13.0, 10.0))
    assert (at["hauler-1"]["x"], at["hauler-1"]["y"]) == pytest.approx((50.0, 54.0))
    assert at["hauler-1"]["state"] == "carrying" and at["hauler-1"]["load"] == 1
    assert at["hauler-1"]["alive"] and at["hauler-1"]["distance"] == pytest.approx(4.0)
    assert at["scout-1"]["type"] == "scout" and at["scout-1"]["path"] == []
    # failed at 8: shown failed, where it last reported (7), not slid on to its next pose
    later = {r["name"]: r for r in robots_at(stored_at(9.0, poses, events), 9.0)}
    down = later["hauler-1"]
    assert (down["state"], down["alive"], down["enabled"]) == ("failed", False, False)
    assert (down["x"], down["y"]) == (50.0, 60.0)
    enabled = [*events, event(1, 10.0, "robot_enabled", robot="hauler-1")]
    back = {r["name"]: r for r in robots_at(stored_at(12.0, poses, enabled), 12.0)}
    assert back["hauler-1"]["alive"] and back["hauler-1"]["state"] == "travelling"
    assert list(back) == ["scout-1", "hauler-1"]


def test_a_moment_in_the_simulated_playbacks_shape() -> None:
    """Same keys as a simulated mission's snapshot; sites, ground, counters from events."""
    poses = [pose("scout-1", 0.0, 5.0, 5.0), pose("scout-1", 5.0, 35.0, 5.0)]
    events = [
        event(0, 1.0, "site_found", site="site-1", by="scout-1", x=20.0, y=20.0),
        event(1, 2.0, "task_started", robot="excavator-1", task_id="e1", task_type="excavate"),
        event(2, 3.0, "dug", robot="excavator-1", site="site-1", remaining=2),
        event(3, 4.0, "delivered", robot="hauler-1", delivered=1),
        event(4, 4.5, "mineral_dropped", robot="hauler-2", x=30.0, y=31.0, mineral="ground-1"),
        event(5, 4.8, "policy_changed", old="nearest", new="fcfs"),
        event(7, 9.0, "mineral_recovered", robot="hauler-3", x=30.0, y=31.0, mineral="ground-1"),
    ]
    out = moment(stored_at(5.0, poses, events), 5.0, MISSION, WORLD)
    m = Mission(reference_scenario(), 0, "nearest")
    try:
        want = m.snapshot()
    finally:
        m.close()
    s = out["state"]
    assert set(s) == set(want) and set(s["counters"]) == set(want["counters"])
    assert set(s["robots"][0]) == set(want["robots"][0])
    assert set(s["sites"][0]) == set(want["sites"][0])
    assert (s["policy"], s["status"], s["seed"]) == ("fcfs", "running", 7)
    one, two = s["sites"]
    assert (one["found"], one["found_at"], one["remaining"], one["excavator"]) == (
        True,
        1.0,
        2,
        "excavator-1",
    )
    assert (two["found"], two["remaining"], two["total"]) == (False, 2, 2)
    assert s["dropped"] == [{"x": 30.0, "y": 31.0}]
    c = s["counters"]
    assert (c["sites_found"], c["sites_total"], c["minerals_delivered"]) == (1, 2, 1)
    assert c["minerals_total"] == 5
    assert [d["seq"] for d in out["deliveries"]] == [3] and out["events"] == 6
    # the scout drove from (5, 5) to (35, 5): cells 0..3 of the first row
    bits = np.unpackbits(
        np.frombuffer(base64.b64decode(s["scanned"]), dtype=np.uint8), bitorder="little"
    )
    assert np.flatnonzero(bits).tolist() == [0, 1, 2, 3] and s["scanned_count"] == 4
    assert s["cells_total"] == 100
    later = moment(stored_at(10.0, poses, events), 10.0, MISSION, WORLD)["state"]
    assert later["dropped"] == []


def test_auctions_as_they_stood() -> None:
    rec = {
        "id": "scout-1/1",
        "kind": "scout_excavator",
        "auctioneer": "scout-1",
        "task_type": "excavate",
        "task_id": "e1",
        "location": [20.0, 20.0],
        "status": "closed",
        "opened_at": 10.0,
        "closed_at": 14.0,
        "allocated_to": "excavator-2",
        "reannouncements": 0,
        "reauction_of": None,
        "policy": "nearest",
        "bids": [
            {"t": 10.5, "bidder": "excavator-1", "utility": -3.0, "round": 0},
            {"t": 11.0, "bidder": "excavator-2", "utility": -2.0, "round": 0},
        ],
        "awards": [
            {"t": 11.5, "winner": "excavator-2", "outcome": "declined"},
            {"t": 13.0, "winner": "excavator-2", "outcome": "accepted"},
        ],
    }
    assert auctions_at([rec], 9.0) == []
    (mid,) = auctions_at([rec], 13.5)
    assert (mid["status"], mid["closed_at"], mid["allocated_to"]) == ("open", None, None)
    assert len(mid["bids"]) == 2 and [w["outcome"] for w in mid["awards"]] == [
        "declined",
        "pending",
    ]
    assert mid["declines"] == 1
    (end,) = auctions_at([rec], 20.0)
    assert end == {**rec, "declines": 1}
