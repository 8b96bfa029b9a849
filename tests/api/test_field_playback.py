"""`GET …/state?t=` of a field run, answered from its stored poses and events (no replay).

The first test stores poses beside a stand-in field mission (an engine stored as a field run,
as in test_field_mark.py) on both databases; the second runs a real field mission (twelve
agent processes over Zenoh, marked `fleet`) and checks that what its robots reported is what
playback serves, while it runs and after it is stopped.
"""

from __future__ import annotations

import itertools
import random
from pathlib import Path
from typing import Any

import httpx
import pytest
from sqlalchemy import text

from app.db.session import make_engine
from engine.scenario import reference_scenario
from field.agent import POSE_INTERVAL_S
from tests.api.conftest import LiveServer, make_settings
from tests.api.test_field_mark import stand_in_field  # noqa: F401 - a fixture
from tests.field.pace import paced
from tests.field.serial import one_field_mission_at_a_time
from tests.progress import wait_progress

Row = tuple[str, float, float, float, float, str, int]
_team = reference_scenario().team
TEAM = _team.scouts + _team.excavators + _team.haulers  # robots with a body: they report


def _db_rows(settings: Any, sql: str, **params: Any) -> list[Any]:
    engine = make_engine(settings.database_url)
    try:
        with engine.begin() as db:
            return list(db.execute(text(sql), params))
    finally:
        engine.dispose()


def _store_poses(settings: Any, mid: int, rows: list[Row]) -> None:
    engine = make_engine(settings.database_url)
    try:
        with engine.begin() as db:
            db.execute(
                text(
                    "insert into poses (mission_id, robot, t, x, y, heading, state, load) "
                    "values (:m, :robot, :t, :x, :y, :h, :state, :load)"
                ),
                [
                    dict(zip(("robot", "t", "x", "y", "h", "state", "load"), r, strict=True), m=mid)
                    for r in rows
                ],
            )
    finally:
        engine.dispose()


def _robots(api: httpx.Client, mid: int, t: float) -> dict[str, dict[str, Any]]:
    r = api.get(f"/api/missions/{mid}/state", params={"t": t})
    assert r.status_code == 200, r.text
    return {x["name"]: x for x in r.json()["state"]["robots"]}


def test_stored_poses_are_served_interpolated(tmp_path: Path, stand_in_field: None) -> None:  # noqa: F811
    """Between two stored poses a robot is on the straight line between them, at its last
    after the last; absent before its first; errors as for any mission."""
    rng = random.Random()
    server = LiveServer(make_settings(tmp_path)).start()
    try:
        with server.client() as api:
            body = {"seed": rng.randrange(100), "speed": 50, "field": True}
            r = api.post("/api/missions", json=body)
            assert r.status_code == 201, r.text
            mid = r.json()["id"]
            base = f"/api/missions/{mid}"
            wait_progress(
                lambda: api.get(base).json()["sim_time"] > 60,
                lambda: api.get(base).json()["sim_time"],
                "the stand-in mission to run a minute",
            )
            api.post(f"{base}/stop").raise_for_status()
            end = api.get(base).json()["sim_time"]
            x0, y0 = rng.uniform(0, 90), rng.uniform(0, 90)
            rows: list[Row] = [
                ("hauler-1", 10.0, x0, y0, 0.0, "travelling", 0),
                ("hauler-1", 15.0, x0 + 5, y0 + 10, 0.5, "carrying", 1),
                ("scout-2", 30.0, 1.0, 2.0, 1.0, "scanning", 0),
            ]
            _store_poses(server.settings, mid, rows)

            assert _robots(api, mid, 5.0) == {}
            at = _robots(api, mid, 12.5)
            assert list(at) == ["hauler-1"]
            h = at["hauler-1"]
            assert (h["x"], h["y"], h["heading"]) == pytest.approx((x0 + 2.5, y0 + 5, 0.25))
            assert (h["state"], h["load"], h["alive"]) == ("travelling", 0, True)
            later = _robots(api, mid, min(end, 40.0))
            assert (later["hauler-1"]["x"], later["hauler-1"]["y"]) == (x0 + 5, y0 + 10)
            assert later["hauler-1"]["state"] == "carrying"
            assert (later["scout-2"]["x"], later["scout-2"]["y"]) == (1.0, 2.0)

            past = api.get(f"{base}/state", params={"t": end + 10})
            assert past.status_code == 422 and "t" in past.json()["message"], past.text
            assert api.get("/api/missions/999999/state", params={"t": 1}).status_code == 404
    finally:
        server.stop()


@pytest.mark.fleet
@pytest.mark.sqlite_only
def test_a_real_field_runs_poses_are_stored_and_served(tmp_path: Path) -> None:
    """Every robot (not the operator's console) reports its pose every 5 s of mission time;
    they are stored, and playback shows each robot at its stored pose at that pose's time,
    while the mission runs and once it is stopped."""
    with one_field_mission_at_a_time():
        server = LiveServer(make_settings(tmp_path)).start()
        try:
            with server.client() as api:
                _real_run(server, api)
        finally:
            server.stop()


def _real_run(server: LiveServer, api: httpx.Client) -> None:
    body = {"seed": 0, "policy": "nearest", "speed": paced(100.0), "field": True}
    r = api.post("/api/missions", json=body)
    assert r.status_code == 201, r.text
    mid = r.json()["id"]
    base = f"/api/missions/{mid}"

    def stored() -> list[Any]:
        return _db_rows(
            server.settings,
            "select robot, t, x, y, heading, state, load from poses where mission_id = :m "
            "order by t",
            m=mid,
        )

    def clock() -> int:
        return int(api.get(base).json()["sim_time"])

    def reported() -> bool:
        poses = stored()
        return len({p[0] for p in poses}) == TEAM and poses[-1][1] > poses[0][1] + 200

    wait_progress(reported, clock, "every robot's poses to be stored")
    # live: scrubbed from what is stored up to now
    live = stored()
    some = live[len(live) // 2]
    now = _robots(api, mid, some[1])
    assert (now[some[0]]["x"], now[some[0]]["y"]) == pytest.approx((some[2], some[3]))
    api.post(f"{base}/stop").raise_for_status()

    poses = stored()
    robots = {p[0] for p in poses}
    assert "operator" not in robots and len(robots) == TEAM, robots
    for name in robots:  # every 5 s of its own mission clock, to the simulated instant
        ts = [p[1] for p in poses if p[0] == name]
        gaps = [b - a for a, b in itertools.pairwise(ts)]
        assert gaps and all(g == pytest.approx(POSE_INTERVAL_S) for g in gaps), (name, gaps)
    rng = random.Random()
    for p in rng.sample(poses, 5):
        at = _robots(api, mid, p[1])
        shown = at[p[0]]
        assert (shown["x"], shown["y"], shown["heading"]) == pytest.approx(p[2:5])
        assert (shown["state"], shown["load"]) == (p[5], p[6])
        assert set(at) == {q[0] for q in poses if q[1] <= p[1]}
