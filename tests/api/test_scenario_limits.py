"""Scenarios that pass a schema but cannot run, and this server's size limits: refused with a
422 naming the field, by missions and sweeps alike, before anything is built or stored."""

from __future__ import annotations

from collections.abc import Iterator
from pathlib import Path
from typing import Any

import httpx
import pytest

from tests.api.conftest import LiveServer, make_settings


@pytest.fixture
def small(tmp_path: Path) -> Iterator[LiveServer]:
    server = LiveServer(make_settings(tmp_path, max_robots=40, max_grid_cells=2000)).start()
    yield server
    server.stop()


def _refused(api: httpx.Client, path: str, body: dict[str, Any], field: str) -> str:
    res = api.post(path, json=body)
    assert res.status_code == 422, res.text
    message: str = res.json()["message"]
    assert f"body.{field}" in message, message
    return message


@pytest.mark.parametrize("path", ["/api/missions", "/api/sweeps"])
@pytest.mark.parametrize(
    ("scenario", "field"),
    [
        ({"crater_radius": [0.0001, 0.0004]}, "scenario.crater_radius"),  # was a plain 500
        ({"crater_radius": [900, 5000]}, "scenario.crater_radius"),
        ({"protocol": {"heartbeat_s": 1e-300, "failure_timeout_s": 1e-299}}, "scenario.protocol"),
        ({"speeds": {"hauler": 1e-310}}, "scenario.speeds.hauler"),
        ({"max_time_s": 1e-300}, "scenario.max_time_s"),
        ({"craters": [{"x": 1e300, "y": 0, "r": 1}]}, "scenario.craters.0.x"),
        ({"start_spread": 100}, "scenario"),  # valid fields, but no site fits: no world
    ],
)
def test_scenarios_that_cannot_run_are_422(
    server: LiveServer, path: str, scenario: dict[str, Any], field: str
) -> None:
    extra = {"planner": "straight"} if path == "/api/missions" else {"seeds": "0"}
    with server.client() as api:
        _refused(api, path, {"scenario": scenario, **extra}, field)
        assert api.get("/api/missions").json()["total"] == 0
        assert api.get("/api/sweeps").json()["total"] == 0


def test_sweeps_keep_the_missions_robot_and_grid_limits(small: LiveServer) -> None:
    with small.client() as api:
        team = {"scouts": 2000, "excavators": 2000, "haulers": 2000}  # 6,000 robots
        for path in ("/api/missions", "/api/sweeps"):
            message = _refused(api, path, {"scenario": {"team": team}}, "scenario.team")
            assert "6000 robots" in message and "REGOLITH_MAX_ROBOTS" in message
            big = {"width": 500, "height": 500}  # 142² cells at the reference scan radius
            message = _refused(api, path, {"scenario": big}, "scenario.width")
            assert "REGOLITH_MAX_GRID_CELLS" in message
        # within the limits alone, over them once scaled: the scale is what is refused
        message = _refused(api, "/api/sweeps", {"scale": 4, "seeds": "0"}, "scale")
        assert "48 robots (at scale 4)" in message and "REGOLITH_MAX_ROBOTS" in message
        message = _refused(
            api, "/api/sweeps", {"scale": 3, "seeds": "0", "scenario": {"width": 200}}, "scale"
        )
        assert "REGOLITH_MAX_GRID_CELLS" in message
        assert api.get("/api/sweeps").json()["total"] == 0
        assert api.get("/api/missions").json()["total"] == 0
