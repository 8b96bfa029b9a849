"""Resume must work for every recorded history, including commands that share a simulated time.

A live command settles the current instant before it takes effect (engine/mission.py
`_check_running`), exactly as a replay does after advancing to the command's time; so a
history with several commands at one simulated time — before the mission's first step,
while it is paused, or within one stepping slice — replays to the stored log, and a server
restart followed by `POST …/resume` continues it. The finished mission is then compared,
metrics and full event log, with the same history applied to a fresh engine.
"""

from __future__ import annotations

import json
from collections.abc import Callable
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path
from typing import Any

import httpx

from engine import Mission, reference_scenario
from tests.api.conftest import LiveServer, make_settings, run_to_end, wait_for

Json = dict[str, Any]


def _ok(r: httpx.Response, code: int = 200) -> Json:
    assert r.status_code == code, (
        f"{r.request.method} {r.request.url.path}: {r.status_code} {r.text}"
    )
    body: Json = r.json()
    return body


def _free_point(api: httpx.Client, base: str, candidates: list[tuple[float, float]]) -> Json:
    """Inject an excavate task at the first candidate point that is not in a crater."""
    for x, y in candidates:
        r = api.post(f"{base}/tasks", json={"type": "excavate", "location": [x, y]})
        if r.status_code == 201:
            body: Json = r.json()
            return body
        assert r.status_code == 422 and "crater" in r.text, r.text
    raise AssertionError("every candidate point lies in a crater")


def _replayable(api: httpx.Client, base: str) -> list[Json]:
    actions = _ok(api.get(f"{base}/actions"))
    return [{"t": a["t"], "kind": a["kind"], "args": a["args"]} for a in actions if a["replay"]]


def _all_events(api: httpx.Client, base: str) -> list[Json]:
    events: list[Json] = []
    after = -1
    while True:
        page = _ok(api.get(f"{base}/events", params={"after": after, "limit": 1000}))
        events += page["items"]
        if page["next_after"] is None:
            return events
        after = page["next_after"]


def _restart_and_finish(server: LiveServer, mid: int) -> tuple[Json, list[Json], list[Json]]:
    """SIGTERM-equivalent stop, start on the same data folder, resume, run to the end."""
    base = f"/api/missions/{mid}"
    with server.client() as api:
        before = _ok(api.get(base))
    server.restart()
    with server.client() as api:
        interrupted = _ok(api.get(base))
        assert interrupted["status"] == "interrupted", interrupted
        assert interrupted["sim_time"] >= before["sim_time"]
        resumed = api.post(f"{base}/resume")
        assert resumed.status_code == 200, resumed.text  # not 409 "replay differs …"
        assert resumed.json()["status"] == "running"
        record = run_to_end(api, mid)
        assert record["status"] == "completed", record
        assert record["metrics"]["minerals_delivered"] == record["metrics"]["minerals_total"]
        return record, _replayable(api, base), _all_events(api, base)


def _uninterrupted(seed: int, policy: str, actions: list[Json]) -> tuple[Json, list[Json]]:
    """The same history applied to a fresh engine, run to the end without interruption."""
    m = Mission(reference_scenario(), seed, policy)
    try:
        for action in actions:
            m.apply(action)
        metrics = m.run()
        return metrics, [json.loads(json.dumps(e.to_dict())) for e in m.events]
    finally:
        m.close()


def _same_run(record: Json, events: list[Json], alone: Json, alone_events: list[Json]) -> None:
    assert record["metrics"] == alone
    assert [e["seq"] for e in events] == list(range(len(events)))  # no gap or duplicate
    assert len(events) == len(alone_events)
    for stored, fresh in zip(events, alone_events, strict=True):
        assert stored == fresh, f"first difference at event {stored['seq']}"


def _shared_times(actions: list[Json]) -> set[float]:
    times = [a["t"] for a in actions]
    return {t for t in times if times.count(t) > 1}


def test_commands_at_time_zero_and_while_paused_survive_a_restart(tmp_path: Path) -> None:
    seed = 31
    server = LiveServer(make_settings(tmp_path)).start()
    try:
        with server.client() as api:
            body = {"seed": seed, "policy": "fcfs", "speed": 150, "paused": True}
            mid = _ok(api.post("/api/missions", json=body), 201)["id"]
            base = f"/api/missions/{mid}"
            # three commands at t=0, before the mission ever steps
            assert _ok(api.post(f"{base}/robots", json={"type": "hauler"}), 201)["name"]
            assert _ok(api.put(f"{base}/policy", json={"policy": "coalition"}))["sim_time"] == 0
            _free_point(api, base, [(30.0, 70.0), (70.0, 30.0), (20.0, 20.0), (80.0, 80.0)])
            _ok(api.post(f"{base}/resume"))
            wait_for(lambda: _ok(api.get(base))["sim_time"] > 300)
            paused = _ok(api.post(f"{base}/pause"))
            assert paused["status"] == "paused"
            # two commands while paused: the same simulated time
            _ok(api.post(f"{base}/robots/hauler-2/disable", json={"mode": "abrupt"}))
            _ok(api.post(f"{base}/robots", json={"type": "excavator"}), 201)
            actions = _replayable(api, base)
            assert [a["kind"] for a in actions] == [
                "add_robot",
                "set_policy",
                "inject_task",
                "disable_robot",
                "add_robot",
            ]
            assert {a["t"] for a in actions[:3]} == {0.0}
            assert actions[3]["t"] == actions[4]["t"] == paused["sim_time"] > 300

        record, stored_actions, events = _restart_and_finish(server, mid)
    finally:
        server.stop()

    assert stored_actions == actions  # the restart added no replayable action
    alone, alone_events = _uninterrupted(seed, "fcfs", stored_actions)
    _same_run(record, events, alone, alone_events)


def test_commands_within_one_stepping_slice_survive_a_restart(tmp_path: Path) -> None:
    """Two commands sent at once to a mission running at high speed land at the same
    simulated time (the stepper stays off while operator requests are in flight); then
    restart while it runs."""
    seed = 32
    server = LiveServer(make_settings(tmp_path)).start()
    try:
        with server.client() as api, server.client() as api2:
            body = {"seed": seed, "policy": "nearest", "speed": 300}
            mid = _ok(api.post("/api/missions", json=body), 201)["id"]
            base = f"/api/missions/{mid}"
            wait_for(lambda: _ok(api.get(base))["sim_time"] > 200)

            pairs: list[tuple[Callable[[], httpx.Response], Callable[[], httpx.Response]]] = [
                (
                    lambda: api.put(f"{base}/policy", json={"policy": "lookahead"}),
                    lambda: api2.post(f"{base}/robots", json={"type": "hauler"}),
                ),
                (
                    lambda: api.post(f"{base}/robots/excavator-1/disable", json={}),
                    lambda: api2.post(f"{base}/robots", json={"type": "scout"}),
                ),
                (
                    lambda: api.post(f"{base}/robots/hauler-1/disable", json={"mode": "abrupt"}),
                    lambda: api2.post(f"{base}/robots/excavator-1/enable"),
                ),
            ]
            with ThreadPoolExecutor(2) as pool:
                for first, second in pairs:
                    answers = [f.result() for f in [pool.submit(first), pool.submit(second)]]
                    for r in answers:
                        assert r.status_code in (200, 201), r.text
            _ok(api.put(f"{base}/speed", json={"speed": 50}))  # still running at the restart
            actions = _replayable(api, base)
            assert len(actions) == 6
            # the history must hold commands that share a simulated time while running,
            # or this test does not test what it says
            assert _shared_times(actions), actions
            assert _ok(api.get(base))["status"] == "running"

        record, stored_actions, events = _restart_and_finish(server, mid)
    finally:
        server.stop()

    assert stored_actions == actions
    alone, alone_events = _uninterrupted(seed, "nearest", stored_actions)
    _same_run(record, events, alone, alone_events)
