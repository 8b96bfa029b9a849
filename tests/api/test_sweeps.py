"""Sweeps over the API: a background job with stored progress, results and figures, limits,
cancel, and resume after a cancel or a server stop. Real server, real database, real engine on
a small scenario (each run ~0.3 s)."""

from __future__ import annotations

import asyncio
import os
from pathlib import Path
from typing import Any

import httpx
import pytest
from sqlalchemy import Engine, text
from sqlalchemy.orm import Session, sessionmaker

from app.db.models import Base, Sweep, utcnow
from app.db.session import make_engine
from app.services.errors import Conflict
from app.services.store import Store
from app.sweeps.job import SweepJob
from app.sweeps.service import SweepManager, _page
from tests.api.conftest import LiveServer, make_settings
from tests.progress import wait_progress

SMALL: dict[str, Any] = {"name": "small", "width": 40.0, "height": 40.0, "sites": 4}


def _start(api: httpx.Client, **body: Any) -> dict[str, Any]:
    res = api.post("/api/sweeps", json={"scenario": SMALL, **body})
    assert res.status_code == 202, res.text
    sweep: dict[str, Any] = res.json()
    return sweep


def _until(api: httpx.Client, sid: int, *statuses: str, seen: list[Any] | None = None) -> Any:
    last: dict[str, Any] = {}

    def probe() -> dict[str, Any] | None:
        s: dict[str, Any] = api.get(f"/api/sweeps/{sid}").json()
        last.update(s)
        if seen is not None:
            seen.append(s)
        return s if s["status"] in statuses else None

    # any change in the record (a run done or failed, its status, elapsed time) is progress
    return wait_progress(probe, lambda: repr(sorted(last.items())), f"sweep {sid} {statuses}")


def _record(api: httpx.Client, sid: int) -> dict[str, Any]:
    record: dict[str, Any] = api.get(f"/api/sweeps/{sid}").json()
    return record


def _stored_done(server: LiveServer, sid: int) -> int:
    engine = make_engine(server.settings.database_url)  # behind the server's back
    try:
        with engine.connect() as db:
            done: int = db.scalar(text("select done from sweeps where id = :id"), {"id": sid})
            return done
    finally:
        engine.dispose()


def test_sweep_runs_in_the_background_and_serves_its_results(
    server: LiveServer, api: httpx.Client
) -> None:
    started = _start(api, policies=[1, "coalition"], seeds="0-1")
    assert started["status"] == "running"
    assert (started["policies"], started["seeds"], started["total"]) == (
        ["fcfs", "coalition"],
        [0, 1],
        4,
    )
    sid = started["id"]
    seen: list[dict[str, Any]] = []
    done = _until(api, sid, "completed", "failed", seen=seen)
    assert done["status"] == "completed", done["error"]
    assert (done["done"], done["total"], done["failed"], done["eta_s"]) == (4, 4, 0, None)
    counts = [s["done"] for s in seen]
    assert counts == sorted(counts)  # progress only grows (mid-run: the next test)

    assert len(done["runs"]) == 4
    assert [(r["policy"], r["seed"]) for r in done["runs"]] == [
        ("fcfs", 0),
        ("fcfs", 1),
        ("coalition", 0),
        ("coalition", 1),
    ]
    for run in done["runs"]:
        assert run["makespan_s"] > 0 and set(run["distance"]) >= {"scout", "excavator", "hauler"}
        assert run["makespan_ratio"] >= 1
    summary = done["summary"]
    assert summary["policies"] and summary["metrics"]["makespan_s"]
    names = {f["name"] for f in done["figures"]}
    assert {"makespan", "distance", "auction_open"} <= names
    fig = next(f for f in done["figures"] if f["name"] == "makespan")
    assert fig["verdict"] and fig["png"] == f"/api/sweeps/{sid}/figures/makespan.png"
    png = api.get(fig["png"])
    assert png.status_code == 200 and png.headers["content-type"] == "image/png"
    assert png.content.startswith(b"\x89PNG")
    svg = api.get(fig["svg"])
    assert svg.headers["content-type"].startswith("image/svg+xml") and b"<svg" in svg.content

    light = api.get(f"/api/sweeps/{sid}", params={"runs": "false"}).json()
    assert (light["runs"], light["summary"], light["done"]) == ([], None, 4)

    listed = api.get("/api/sweeps").json()
    assert listed["total"] == 1 and listed["items"][0]["id"] == sid
    assert listed["items"][0]["status"] == "completed"
    assert api.get("/api/sweeps", params={"status": "running"}).json()["total"] == 0
    out = Path(server.settings.data_dir) / "sweeps" / str(sid)
    assert (out / "runs.csv").read_text().count("\n") == 5
    assert api.post(f"/api/sweeps/{sid}/resume").status_code == 409  # nothing left to do
    assert api.post(f"/api/sweeps/{sid}/cancel").status_code == 409


def test_a_running_sweep_reports_its_progress_and_the_time_left(api: httpx.Client) -> None:
    """Between its first run and its last, a sweep says how far it is and how long is left.
    Twenty runs on two workers give the light polls here many chances to see it: a loaded
    machine once let all four runs of the test above finish between two of its polls."""
    sid = _start(api, policies=[1, "coalition"], seeds="0-9")["id"]
    last: dict[str, Any] = {}

    def first_done() -> dict[str, Any] | None:
        s: dict[str, Any] = api.get(f"/api/sweeps/{sid}", params={"runs": "false"}).json()
        last.update(s)
        return s if s["done"] > 0 or s["status"] != "running" else None

    mid = wait_progress(first_done, lambda: repr(sorted(last.items())), f"sweep {sid}: a run")
    assert mid["status"] == "running" and 0 < mid["done"] < mid["total"] == 20, mid
    assert mid["eta_s"] is not None and mid["eta_s"] > 0 and mid["elapsed_s"] > 0, mid
    cancelled = api.post(f"/api/sweeps/{sid}/cancel")  # the rest is not needed
    assert cancelled.status_code == 200 and cancelled.json()["status"] == "cancelled"


def _sweeps_db(tmp_path: Path, statuses: list[str]) -> Engine:
    """A SQLite file with one sweep row per status (ids from 1), no server: for the
    manager's reads where the row and its job disagree."""
    engine = make_engine(f"sqlite:///{tmp_path / 'sweeps.db'}")
    Base.metadata.create_all(engine)
    with Session(engine) as session:
        for status in statuses:
            fields = {"policies": ["fcfs"], "seeds": [0], "scale": 1, "scenario": {}}
            fields |= {"scenario_name": "reference", "total": 1, "created_at": utcnow()}
            session.add(Sweep(status=status, **fields))
        session.commit()
    return engine


def test_a_sweep_is_listed_by_the_status_it_shows_while_its_row_catches_up(
    tmp_path: Path,
) -> None:
    """A job knows its final status before its row does (the write is queued behind
    others), and every read shows the job's: a list filtered by status must read the same,
    or a sweep shown completed is counted among the running (CI saw exactly that)."""
    engine = _sweeps_db(tmp_path, ["completed", "running", "running"])
    with Session(engine) as session:
        live = {2: "running", 3: "completed"}  # sweep 3's job has just ended

        def shown(status: str | None) -> list[int]:
            rows, total = _page(session, status, live, 10, 0)
            assert total == len(rows)
            return [r.id for r in rows]

        assert shown("running") == [2]
        assert shown("completed") == [3, 1]
        assert shown(None) == [3, 2, 1]
        assert shown("failed") == []
    engine.dispose()


def test_a_sweep_writing_its_final_status_is_ended_for_every_request(tmp_path: Path) -> None:
    """Between a job's end and its row's final write, the sweep shows its final status: it
    holds no place of the running limit, and a resume waits for the write, then is refused
    as for any completed sweep (CI saw 429, 'already running', where 409 was due)."""
    engine = _sweeps_db(tmp_path, ["running"])
    store = Store(sessionmaker(engine))
    manager = SweepManager(make_settings(tmp_path), store)

    async def scenario() -> tuple[str, str]:
        job = SweepJob(1, None, tmp_path)  # type: ignore[arg-type]
        job.final = {"status": "completed", "error": None}
        queued = asyncio.Event()

        async def final_write() -> None:  # the job's last act, queued behind other writes
            await queued.wait()
            await store.update_sweep(1, job.final or {})
            manager.jobs.pop(1)

        job.task = asyncio.create_task(final_write())
        manager.jobs[1] = job
        with manager._slot():  # a new sweep may start: the ended job holds no place
            pass
        asyncio.get_running_loop().call_later(0.05, queued.set)
        with pytest.raises(Conflict) as refused:
            await manager.resume(1)
        return str(refused.value), (await manager.get(1))["status"]

    try:
        refused, status = asyncio.run(scenario())
    finally:
        store.close()
        engine.dispose()
    assert "is completed" in refused and status == "completed"


def test_sweep_requests_are_checked(server: LiveServer, api: httpx.Client) -> None:
    with server.client(token=False) as anon:
        assert anon.post("/api/sweeps", json={"seeds": "0"}).status_code == 401
        assert anon.get("/api/sweeps").status_code == 200  # reads are public
        assert anon.post("/api/sweeps/1/cancel").status_code == 401

    def refused(body: dict[str, Any], field: str) -> str:
        res = api.post("/api/sweeps", json=body)
        assert res.status_code == 422, res.text
        message: str = res.json()["message"]
        assert f"body.{field}" in message, message
        return message

    assert "empty" in refused({"seeds": "5-2"}, "seeds")
    refused({"seeds": "0-x"}, "seeds")
    refused({"seeds": {"from": 5, "to": 2}}, "seeds")
    assert "1000" in refused({"policies": [1, 2], "seeds": "0-999"}, "seeds")  # 2000 runs
    refused({"seeds": "0-99999999999"}, "seeds")
    refused({"policies": ["bogus"]}, "policies")
    refused({"policies": []}, "policies")
    refused({"scale": 0}, "scale")
    assert api.get("/api/sweeps").json()["total"] == 0  # nothing was started

    assert api.get("/api/sweeps/99").status_code == 404
    assert api.post("/api/sweeps/99/cancel").status_code == 404
    assert api.post("/api/sweeps/99/resume").status_code == 404
    assert api.get("/api/sweeps/99/figures/makespan.png").status_code == 404


@pytest.mark.sqlite_only  # paths on disk, whatever the database
def test_figure_and_file_names_cannot_leave_the_sweep_folder(
    server: LiveServer, api: httpx.Client
) -> None:
    sid = _start(api, policies=[1], seeds="0")["id"]
    assert _until(api, sid, "completed", "failed")["status"] == "completed"
    assert api.get(f"/api/sweeps/{sid}/figures/makespan.png").status_code == 200
    for name in [
        "..%2Fsweep.json",
        "..%2F..%2Fregolith.db",
        "%2E%2E%2Fsummary.json",
        "sweep.json",
        "report.md",
        "..%5Csweep.json",
        "makespan.png%00.svg",
    ]:
        res = api.get(f"/api/sweeps/{sid}/figures/{name}")
        assert res.status_code in (404, 422), (name, res.status_code)
        assert b"scenario_hash" not in res.content and b"SQLite" not in res.content
    assert api.get(f"/api/sweeps/{sid}/figures/nothing.png").status_code == 404

    # the result files download (runs.csv, summary.json, report.md); nothing else is reachable
    done = api.get(f"/api/sweeps/{sid}").json()
    out = Path(server.settings.data_dir) / "sweeps" / str(sid)
    names = {f["name"] for f in done["files"]}
    assert {"runs.csv", "summary.json", "report.md"} <= names
    for f in done["files"]:
        res = api.get(f["url"])
        assert res.status_code == 200, f
        assert res.content == (out / f["name"]).read_bytes()
        assert res.headers["content-type"].startswith(f["media_type"])
        disposition = res.headers["content-disposition"]
        assert disposition.startswith("attachment") and f"sweep-{sid}-{f['name']}" in disposition
    for name in ["sweep.json", "journal.jsonl", "..%2Fregolith.db", "runs.csv%00", "figures"]:
        res = api.get(f"/api/sweeps/{sid}/files/{name}")
        assert res.status_code in (404, 422), (name, res.status_code)
        assert b"SQLite" not in res.content
    assert api.get("/api/sweeps/999/files/runs.csv").status_code == 404


@pytest.mark.sqlite_only  # paths on disk, whatever the database
def test_a_symlink_in_the_sweep_folder_is_never_followed(
    server: LiveServer, api: httpx.Client, tmp_path: Path
) -> None:
    sid = _start(api, policies=[1], seeds="0")["id"]
    assert _until(api, sid, "completed", "failed")["status"] == "completed"
    out = Path(server.settings.data_dir) / "sweeps" / str(sid)
    secret = tmp_path / "operator-token"
    secret.write_text("secret-operator-token")
    viewer = server.client(token=False)
    # a result file and a figure replaced by links to a file outside the folder
    (out / "report.md").unlink()
    (out / "report.md").symlink_to(secret)
    (out / "figures" / "makespan.png").unlink()
    (out / "figures" / "makespan.png").symlink_to(secret)
    # a link to a file that is inside the folder is refused too: only regular files are served
    (out / "summary.json").rename(out / "summary.real")
    (out / "summary.json").symlink_to(out / "summary.real")
    for url in ("files/report.md", "figures/makespan.png", "files/summary.json"):
        res = viewer.get(f"/api/sweeps/{sid}/{url}")
        assert res.status_code == 404, (url, res.status_code)
        assert b"secret-operator-token" not in res.content
    links = {f["name"] for f in viewer.get(f"/api/sweeps/{sid}").json()["files"]}
    assert "report.md" not in links and "summary.json" not in links and "runs.csv" in links
    # a named pipe is no regular file: refused at once, never a read that blocks
    (out / "bounds.csv").unlink(missing_ok=True)
    os.mkfifo(out / "bounds.csv")
    assert viewer.get(f"/api/sweeps/{sid}/files/bounds.csv").status_code == 404
    # a linked figures folder is refused as a whole
    (out / "figures").rename(out / "figures.real")
    (out / "figures").symlink_to(out / "figures.real")
    assert viewer.get(f"/api/sweeps/{sid}/figures/makespan.svg").status_code == 404
    assert viewer.get(f"/api/sweeps/{sid}/files/runs.csv").status_code == 200


def test_cancel_then_resume_finishes_without_repeating_a_run(
    server: LiveServer, api: httpx.Client
) -> None:
    sid = _start(api, policies=["fcfs"], seeds="0-7")["id"]
    second = api.post("/api/sweeps", json={"seeds": "0"})
    assert second.status_code == 429 and "already running" in second.json()["detail"]
    wait_progress(  # progress reaches the database as it runs
        lambda: _stored_done(server, sid) >= 1, lambda: _record(api, sid), f"sweep {sid}: a run"
    )
    cancelled = api.post(f"/api/sweeps/{sid}/cancel")
    assert cancelled.status_code == 200, cancelled.text
    assert cancelled.json()["status"] == "cancelled"
    kept = cancelled.json()["done"]
    assert 1 <= kept < 8
    assert api.post(f"/api/sweeps/{sid}/cancel").status_code == 409

    resumed = api.post(f"/api/sweeps/{sid}/resume")
    assert resumed.status_code == 202 and resumed.json()["status"] == "running"
    done = _until(api, sid, "completed", "failed")
    assert done["status"] == "completed" and done["done"] == 8
    journal = Path(server.settings.data_dir) / "sweeps" / str(sid) / "runs.jsonl"
    assert len(journal.read_text().splitlines()) == 8  # each run exactly once


def test_a_sweep_stopped_with_the_server_is_interrupted_and_resumes(server: LiveServer) -> None:
    with server.client() as api:
        sid = _start(api, policies=["nearest"], seeds="0-7")["id"]
        wait_progress(
            lambda: _record(api, sid)["done"] >= 2, lambda: _record(api, sid), f"sweep {sid}"
        )
    server.restart()
    with server.client() as api:
        stopped = api.get(f"/api/sweeps/{sid}").json()
        assert stopped["status"] == "interrupted"
        assert 2 <= stopped["done"] < 8  # progress was stored
        resumed = api.post(f"/api/sweeps/{sid}/resume")
        assert resumed.status_code == 202, resumed.text
        done = _until(api, sid, "completed", "failed")
        assert done["status"] == "completed" and len(done["runs"]) == 8
