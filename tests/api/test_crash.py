"""SIGKILL the server mid-mission, start it again, resume: the finished mission is the same
as an uninterrupted run with the same actions (crash recovery by replay)."""

from __future__ import annotations

import os
import signal
import socket
import subprocess
import sys
from pathlib import Path
from typing import Any

import httpx

from engine import Mission, reference_scenario
from tests.api.conftest import AUTH, TOKEN, all_pages, database_for, run_to_end, wait_for
from tests.progress import REQUEST_S, START_S


def _serve(data: Path, port: int) -> subprocess.Popen[bytes]:
    env = {**os.environ, "REGOLITH_TOKEN": TOKEN}
    cmd = [sys.executable, "-c", "from app.cli import main; main()", "serve"]
    cmd += ["--port", str(port), "--data-dir", str(data), "--log-level", "warning"]
    if (url := database_for(data)) is not None:
        cmd += ["--db", url]
    proc = subprocess.Popen(cmd, env=env, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)

    def up() -> bool:
        try:
            return httpx.get(f"http://127.0.0.1:{port}/api/health").status_code == 200
        except httpx.TransportError:
            return False

    wait_for(up, timeout=START_S, every=0.1)  # as long as it starts (tests/progress.py)
    return proc


def _uninterrupted(actions: list[dict[str, Any]]) -> tuple[dict[str, Any], list[dict[str, Any]]]:
    m = Mission(reference_scenario(), 21, "fcfs")
    try:
        for action in actions:
            m.apply(action)
        metrics = m.run()
        return metrics, [a.to_dict() for a in m.auctions]
    finally:
        m.close()


def test_sigkill_mid_mission_then_resume_equals_an_uninterrupted_run(tmp_path: Path) -> None:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        port = s.getsockname()[1]
    base_url = f"http://127.0.0.1:{port}"
    proc = _serve(tmp_path, port)
    try:
        with httpx.Client(base_url=base_url, headers=AUTH, timeout=REQUEST_S) as api:
            mid = api.post("/api/missions", json={"seed": 21, "speed": 300}).json()["id"]
            base = f"/api/missions/{mid}"
            wait_for(lambda: api.get(base).json()["sim_time"] > 200)
            api.put(f"{base}/policy", json={"policy": "nearest"}).raise_for_status()
            api.post(f"{base}/robots/hauler-3/disable", json={"mode": "abrupt"}).raise_for_status()
            wait_for(lambda: api.get(base).json()["sim_time"] > 600)
            api.post(f"{base}/robots", json={"type": "excavator"}).raise_for_status()
            wait_for(lambda: api.get(base).json()["sim_time"] > 700)
    finally:
        proc.send_signal(signal.SIGKILL)
        proc.wait(timeout=30)

    proc = _serve(tmp_path, port)
    try:
        with httpx.Client(base_url=base_url, headers=AUTH, timeout=REQUEST_S) as api:
            assert api.get(base).json()["status"] == "interrupted"
            resumed = api.post(f"{base}/resume")
            assert resumed.status_code == 200, resumed.text
            record = run_to_end(api, mid)
            auctions = all_pages(api, f"{base}/auctions")
    finally:
        proc.send_signal(signal.SIGTERM)
        proc.wait(timeout=30)

    replayable = [
        {"t": a["t"], "kind": a["kind"], "args": a["args"]}
        for a in record["actions"]
        if a["replay"]
    ]
    assert [a["kind"] for a in replayable] == ["set_policy", "disable_robot", "add_robot"]
    metrics, expected = _uninterrupted(replayable)

    assert record["status"] == "completed"
    assert record["metrics"] == metrics
    stored = {a["id"]: a for a in auctions}
    assert set(stored) == {a["id"] for a in expected}
    for a in expected:
        got = stored[a["id"]]
        assert (got["status"], got["allocated_to"], got["closed_at"]) == (
            a["status"],
            a["allocated_to"],
            a["closed_at"],
        )
        assert [(b["bidder"], b["utility"]) for b in got["bids"]] == [
            (b["bidder"], b["utility"]) for b in a["bids"]
        ]
        assert [(w["winner"], w["outcome"]) for w in got["awards"]] == [
            (w["winner"], w["outcome"]) for w in a["awards"]
        ]
