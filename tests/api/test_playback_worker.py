"""The playback worker process (`app/services/playback.py`): stopped when idle and started again
on demand with the same answers, a killed worker's scrubs answered 503 and the next scrub
served by a new one, no worker left behind by the server, and, whatever the kills, every
answer the one an engine of the test's own computes.

Real parts: a real server on 127.0.0.1 (uvicorn in a thread, or `regolith serve` in its own
process), its SQLite file, the worker a real process killed with SIGKILL. Waits are on
progress or on the server's own gauges, never on a fixed time.
"""

from __future__ import annotations

import asyncio
import json
import random
import signal
import struct
import threading
from concurrent.futures import Future, ThreadPoolExecutor
from pathlib import Path
from typing import Any

import httpx
import psutil
import pytest

from app.live.records import stream_state
from app.services.playback_wire import MAX_FRAME, WireError, encode, read_frame
from engine import Mission, parse_scenario, reference_scenario
from tests.api.conftest import LiveServer, make_settings, run_to_end
from tests.api.serve_process import ServeProcess
from tests.progress import wait_progress

WORKER = "app.services.playback_worker"

pytestmark = pytest.mark.sqlite_only  # the worker's life, whatever the database


def _metric(api: httpx.Client, name: str) -> float:
    for line in api.get("/api/metrics").text.splitlines():
        if line.startswith(name + " "):
            return float(line.split()[1])
    raise AssertionError(f"{name} missing from /api/metrics")


def _workers(parent: psutil.Process) -> list[psutil.Process]:
    """The playback workers among `parent`'s descendants (zombies excluded)."""
    found = []
    for child in parent.children(recursive=True):
        try:
            if WORKER in " ".join(child.cmdline()) and child.status() != psutil.STATUS_ZOMBIE:
                found.append(child)
        except psutil.Error:
            pass
    return found


def _gone(pid: int) -> bool:
    try:
        return bool(psutil.Process(pid).status() == psutil.STATUS_ZOMBIE)
    except psutil.NoSuchProcess:
        return True


def _finished(api: httpx.Client, seed: int, actions: bool = False) -> tuple[int, float]:
    """A mission run to its end (with a failure and a policy switch if `actions`)."""
    speed = 200 if actions else "max"
    mid = int(api.post("/api/missions", json={"seed": seed, "speed": speed}).json()["id"])
    base = f"/api/missions/{mid}"
    if actions:
        wait_progress(
            lambda: api.get(base).json()["sim_time"] > 100,
            lambda: api.get(base).json()["sim_time"],
            "the mission to pass t=100",
        )
        api.post(f"{base}/robots/hauler-1/disable", json={"mode": "abrupt"}).raise_for_status()
        api.put(f"{base}/policy", json={"policy": "coalition"}).raise_for_status()
    record = run_to_end(api, mid)
    return mid, float(record["sim_time"])


def _reference(
    api: httpx.Client, mid: int, times: list[float], scenario: dict[str, Any] | None = None
) -> dict[float, dict[str, Any]]:
    """The state at each of `times` as an engine in this process shows it after the mission's
    replayable actions (what playback must answer, JSON as the route sends it)."""
    record = api.get(f"/api/missions/{mid}").json()
    actions = [a for a in api.get(f"/api/missions/{mid}/actions").json() if a["replay"]]
    sc = parse_scenario(scenario) if scenario is not None else reference_scenario()
    m = Mission(sc, record["seed"], record["initial_policy"], planner=record["planner"])
    out: dict[float, dict[str, Any]] = {}
    try:
        applied = 0
        for t in sorted(set(times)):
            while applied < len(actions) and actions[applied]["t"] <= t:
                m.advance(actions[applied]["t"])
                m.apply(actions[applied])
                applied += 1
            m.advance(t)
            out[t] = json.loads(json.dumps(stream_state(m.snapshot())))
    finally:
        m.close()
    return out


def _scrub(api: httpx.Client, mid: int, t: float) -> httpx.Response:
    return api.get(f"/api/missions/{mid}/state", params={"t": t})


def test_idle_worker_stops_and_a_new_one_answers_the_same(tmp_path: Path) -> None:
    server = LiveServer(make_settings(tmp_path, playback_idle_s=0.5)).start()
    try:
        with server.client() as api:
            mid, end = _finished(api, 3, actions=True)
            times = [0.0, end * 0.3, end * 0.8, end]
            first = {t: _scrub(api, mid, t).json() for t in times}
            assert _metric(api, "regolith_playback_worker_starts_total") == 1
            # idle (no scrub, checkpoints built): the worker is stopped and its memory gone
            wait_progress(
                lambda: _metric(api, "regolith_playback_worker_up") == 0,
                lambda: _metric(api, "regolith_playback_checkpoint_builds"),
                "the idle worker to stop",
            )
            assert not _workers(psutil.Process())
            assert _metric(api, "regolith_playback_engines") == 0
            built = _metric(api, "regolith_playback_engines_built_total")
            assert _metric(api, "regolith_playback_engines_closed_total") == built
            # the next scrub starts a new worker; every answer is the same, in another order
            for t in reversed(times):
                r = _scrub(api, mid, t)
                assert r.status_code == 200, r.text
                assert r.json() == first[t]
            assert _metric(api, "regolith_playback_worker_starts_total") == 2
            ref = _reference(api, mid, times)
            assert all(first[t]["state"] == ref[t] for t in times)
    finally:
        server.stop()


def test_a_killed_worker_answers_503_then_a_new_one_serves(tmp_path: Path) -> None:
    server = LiveServer(make_settings(tmp_path)).start()
    try:
        with server.client() as api:
            mid, end = _finished(api, 6)
            answers: list[httpx.Response] = []
            scrub = threading.Thread(target=lambda: answers.append(_scrub(api, mid, end)))
            scrub.start()
            # the scrub is with a worker (a first scrub replays the whole mission): kill it
            found = wait_progress(
                lambda: _metric(api, "regolith_playback_queue") >= 1 and _workers(psutil.Process()),
                lambda: len(answers),
                "the scrub to reach a worker",
            )
            assert isinstance(found, list)
            worker = found[0]
            worker.send_signal(signal.SIGKILL)
            scrub.join()
            (r,) = answers
            assert r.status_code == 503, r.text
            detail = r.json()["detail"]
            assert "playback worker" in detail and "SIGKILL" in detail, detail
            assert f"pid {worker.pid}" in detail and "try again" in detail
            # the next scrub starts a new worker and answers as before the kill
            again = _scrub(api, mid, end)
            assert again.status_code == 200, again.text
            assert again.json()["state"] == _reference(api, mid, [end])[end]
            assert _metric(api, "regolith_playback_worker_starts_total") == 2
            assert _metric(api, "regolith_playback_worker_up") == 1
    finally:
        server.stop()


@pytest.mark.parametrize("how", [signal.SIGTERM, signal.SIGKILL])
def test_no_worker_outlives_the_server(tmp_path: Path, how: signal.Signals) -> None:
    """A clean shutdown stops the worker; a server killed outright closes the worker's stdin,
    and the worker ends by itself."""
    with ServeProcess(tmp_path) as srv, srv.client() as api:
        mid, end = _finished(api, 2)
        assert _scrub(api, mid, end / 2).status_code == 200
        assert srv.proc is not None
        (worker,) = _workers(psutil.Process(srv.proc.pid))
        srv.proc.send_signal(how)
        srv.proc.wait()
        wait_progress(
            lambda: _gone(worker.pid),
            lambda: worker.pid,  # nothing to measure: fails after the stall limit
            f"playback worker {worker.pid} to end with its server",
        )
        if how == signal.SIGTERM:
            assert "Traceback" not in srv.stderr(), srv.stderr()


def _kill_a_worker(me: psutil.Process, futures: list[Future[httpx.Response]]) -> bool:
    """SIGKILL the worker as soon as there is one (False: every scrub answered first)."""
    found = wait_progress(
        lambda: _workers(me) or all(f.done() for f in futures),
        lambda: sum(f.done() for f in futures),
        "a worker to kill",
    )
    if not isinstance(found, list):
        return False
    found[0].send_signal(signal.SIGKILL)
    return True


def test_random_scrubs_and_kills_beside_a_live_mission(tmp_path: Path) -> None:
    """Rounds of concurrent scrubs (repeats included: they share one answer) over two finished
    missions and a live one, the worker killed during some rounds: a scrub that met a kill
    answers 503 and is asked again; every answer equals the in-process reference."""
    rng = random.Random(2026)
    server = LiveServer(make_settings(tmp_path, playback_cursors=4)).start()
    try:
        with server.client() as api:
            done = [_finished(api, 4, actions=True), _finished(api, 7)]
            long = {**reference_scenario().model_dump(mode="json"), "minerals": 1500}
            long["max_time_s"] = 10_000_000
            body = {"seed": 9, "speed": 20, "scenario": long}
            live = int(api.post("/api/missions", json=body).json()["id"])
            now = wait_progress(
                lambda: (s := api.get(f"/api/missions/{live}").json()["sim_time"]) > 60 and s,
                lambda: api.get(f"/api/missions/{live}").json()["sim_time"],
                "the live mission to pass t=60",
            )
            ends = {**dict(done), live: float(now)}
            times = {
                mid: [round(rng.uniform(0, end), 2) for _ in range(5)] for mid, end in ends.items()
            }
            ref = {
                mid: _reference(api, mid, ts, long if mid == live else None)
                for mid, ts in times.items()
            }
            me = psutil.Process()
            kills = 0
            with ThreadPoolExecutor(8) as pool:
                kill_in = set(rng.sample(range(6), 3))
                for round_ in range(6):
                    jobs = [(m, rng.choice(times[m])) for m in rng.choices(list(ends), k=8)]
                    futures = [pool.submit(_scrub, api, m, t) for m, t in jobs]
                    if round_ in kill_in and _kill_a_worker(me, futures):
                        kills += 1
                    for (mid, t), future in zip(jobs, futures, strict=True):
                        r = future.result()
                        while r.status_code == 503:
                            assert "playback worker" in r.json()["detail"], r.text
                            r = _scrub(api, mid, t)
                        assert r.status_code == 200, r.text
                        assert r.json()["state"] == ref[mid][t], (mid, t)
            assert kills > 0
            assert api.get(f"/api/missions/{live}").json()["status"] == "running"
            assert _metric(api, "regolith_playback_worker_starts_total") >= kills
    finally:
        server.stop()


def _read(data: bytes) -> dict[str, Any] | None:
    async def go() -> dict[str, Any] | None:
        reader = asyncio.StreamReader()
        reader.feed_data(data)
        reader.feed_eof()
        return await read_frame(reader)

    return asyncio.run(go())


def test_the_wire_refuses_what_is_not_a_frame_of_ours() -> None:
    """What the server takes from the worker's stdout is checked before it is used: a length
    over the cap is refused before reading it, and so is a frame that is not a JSON object."""
    assert _read(encode({"id": 1, "ok": {}})) == {"id": 1, "ok": {}}
    assert _read(b"") is None  # a clean end between frames
    too_big = struct.pack(">I", MAX_FRAME + 1)
    for data, says in [
        (too_big, "over the"),
        (b"\x00\x00", "header"),
        (struct.pack(">I", 10) + b"{}", "inside a 10-byte frame"),
        (struct.pack(">I", 3) + b"{x}", "not JSON"),
        (struct.pack(">I", 2) + b"[]", "not an object"),
    ]:
        with pytest.raises(WireError, match=says):
            _read(data)
    with pytest.raises(WireError, match="frame limit"):
        encode({"x": "a" * MAX_FRAME})
