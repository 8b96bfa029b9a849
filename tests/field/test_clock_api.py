"""Pause, resume and speed of a field mission through the API, against a real server and its
agent processes (docs/field.md, "The mission clock"): a field mission created paused stands
at time 0 until resumed; a pause answers 200 and the mission's time stands (the world
service's clock, which the live view follows); a new speed answers 200, paused or not;
"max" and a speed below 1× are 422s naming `body.speed`; speed 0 pauses."""

from __future__ import annotations

import time
from pathlib import Path
from typing import Any

import httpx
import pytest

from tests.api.conftest import LiveServer, make_settings
from tests.field.serial import one_field_mission_at_a_time
from tests.progress import START_S, wait_progress

STAND_S = 2.0
"""Wall time a paused mission is watched for (a delivery is ~0.7 s at 50×)."""


def _read(api: httpx.Client, mid: int) -> dict[str, Any]:
    res = api.get(f"/api/missions/{mid}")
    assert res.status_code == 200, res.text
    out: dict[str, Any] = res.json()
    return out


def _stands(api: httpx.Client, mid: int) -> float:
    """The mission's time, the same for `STAND_S` of wall time (and its status paused)."""
    first = _read(api, mid)
    assert first["status"] == "paused", first
    start = time.monotonic()
    while time.monotonic() - start < STAND_S:
        now = _read(api, mid)
        assert now["status"] == "paused" and now["sim_time"] == first["sim_time"], now
        time.sleep(0.1)
    return float(first["sim_time"])


def _moves_past(api: httpx.Client, mid: int, t: float) -> None:
    wait_progress(
        lambda: _read(api, mid)["sim_time"] > t,
        lambda: _read(api, mid)["sim_time"],
        f"mission {mid} past t={t:g}",
        stall_s=START_S,  # (its agents may still be starting)
    )


@pytest.mark.slow
@pytest.mark.fleet
def test_a_field_mission_pauses_and_takes_a_new_speed(tmp_path: Path) -> None:
    with one_field_mission_at_a_time():
        live = LiveServer(make_settings(tmp_path)).start()
        try:
            with live.client() as api:
                _paused_and_paced(api)
        finally:
            live.stop()


def _paused_and_paced(api: httpx.Client) -> None:
    body = {"policy": "nearest", "seed": 0, "speed": 50, "field": True, "paused": True}
    made = api.post("/api/missions", json=body)
    assert made.status_code == 201, made.text
    mid = made.json()["id"]
    base = f"/api/missions/{mid}"
    assert made.json()["status"] == "paused" and made.json()["mode"] == "field"
    # created paused: its agents start standing (the world's clock paused as it was built,
    # before any agent started: a fraction of a second of mission time at most)
    assert _stands(api, mid) < 1.0

    res = api.post(f"{base}/resume")
    assert res.status_code == 200 and res.json()["status"] == "running", res.text
    _moves_past(api, mid, 100.0)

    res = api.post(f"{base}/pause")
    assert res.status_code == 200 and res.json()["status"] == "paused", res.text
    t = _stands(api, mid)

    res = api.put(f"{base}/speed", json={"speed": 25})
    assert res.status_code == 200 and res.json()["speed"] == 25, res.text
    assert res.json()["status"] == "paused" and _stands(api, mid) == t  # re-paced, still paused
    for bad in ("max", 0.5):
        res = api.put(f"{base}/speed", json={"speed": bad})
        assert res.status_code == 422 and "body.speed" in res.json()["message"], res.text
    assert _read(api, mid)["speed"] == 25

    res = api.post(f"{base}/resume")
    assert res.status_code == 200 and res.json()["status"] == "running", res.text
    _moves_past(api, mid, t + 50.0)
    res = api.put(f"{base}/speed", json={"speed": 40})  # a new speed while running
    assert res.status_code == 200 and res.json()["speed"] == 40, res.text
    assert res.json()["status"] == "running"

    res = api.put(f"{base}/speed", json={"speed": 0})  # speed 0 is a pause
    assert res.status_code == 200 and res.json()["status"] == "paused", res.text
    _stands(api, mid)
    actions = [a["kind"] for a in api.get(f"{base}/actions").json()]
    assert actions == ["resume", "pause", "speed", "resume", "speed", "pause"], actions
    assert api.post(f"{base}/stop").status_code in (200, 204)
