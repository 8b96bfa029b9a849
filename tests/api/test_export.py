"""`GET /api/missions/{id}/export.mcap`: a stored mission as an MCAP file, read back with the
`mcap` reader, every message checked against its JSON schema (tests/mcap_check.py), the counts
against what the server stored, the poses against the mission's own final state."""

from __future__ import annotations

import math
import threading
from collections.abc import Generator
from typing import Any

import httpx
import pytest

from app.api.routes.export import EXPORTS, _stream
from tests import aio
from tests.api.conftest import LiveServer, all_pages, run_to_end
from tests.api.test_field_mark import stand_in_field  # noqa: F401 - a fixture
from tests.mcap_check import Export, read_export


def _stored_kinds(api: httpx.Client, mid: int) -> dict[str, int]:
    """Stored events per kind, and in all (key ""), from the events API's totals."""
    first = api.get(f"/api/missions/{mid}/events", params={"limit": 1000}).json()
    kinds: set[str] = set()
    after = -1
    while True:
        page = api.get(f"/api/missions/{mid}/events", params={"after": after, "limit": 1000})
        body = page.json()
        kinds |= {e["kind"] for e in body["items"]}
        if body["next_after"] is None:
            break
        after = body["next_after"]
    out = {"": first["total"]}
    for kind in kinds:
        r = api.get(f"/api/missions/{mid}/events", params={"kind": kind, "limit": 1})
        out[kind] = r.json()["total"]
    return out


def _export(server: LiveServer, mid: int) -> Export:
    with server.client(token=False) as viewer:  # reads need no token, exports included
        r = viewer.get(f"/api/missions/{mid}/export.mcap")
    assert r.status_code == 200, r.text
    assert r.headers["content-type"] == "application/x-mcap"
    assert f"mission-{mid}.mcap" in r.headers["content-disposition"]
    return read_export(r.content)


def _check_counts(api: httpx.Client, mid: int, export: Export) -> None:
    stored = _stored_kinds(api, mid)
    total = stored.pop("")
    assert dict(export.kinds()) == stored  # one message per stored event, kind by kind
    assert export.count("/log") == total
    auctions = all_pages(api, f"/api/missions/{mid}/auctions")
    assert export.count("/events/auction_opened") == len(auctions)
    assert export.count("/events/bid") == sum(len(a["bids"]) for a in auctions)
    actions = api.get(f"/api/missions/{mid}/actions").json()
    assert [m["kind"] for _, m in export.topics["/operator/actions"]] == [
        a["kind"] for a in actions
    ]


def test_a_reference_mission_exports_with_valid_schemas_counts_and_poses(
    server: LiveServer, api: httpx.Client
) -> None:
    r = api.post("/api/missions", json={"policy": 1, "seed": 0, "paused": True})
    mid = r.json()["id"]
    api.put(f"/api/missions/{mid}/policy", json={"policy": 3}).raise_for_status()
    api.post(f"/api/missions/{mid}/resume").raise_for_status()
    record = run_to_end(api, mid)
    assert record["status"] == "completed"
    export = _export(server, mid)
    _check_counts(api, mid, export)

    end = record["sim_time"]
    assert export.statistics.message_end_time == round(end * 1e9)
    assert export.metadata["mode"] == "simulated" and export.metadata["mission"] == str(mid)
    ticks = math.ceil(end / 5.0) + 1  # every 5 simulated seconds, and the end
    for topic, schema in [
        ("/tf", "foxglove.FrameTransforms"),
        ("/robots/poses", "foxglove.PosesInFrame"),
        ("/scene/robots", "foxglove.SceneUpdate"),
        ("/robots/state", "regolith.RobotStates"),
    ]:
        assert export.count(topic) == ticks, topic
        assert export.schemas[topic] == schema
    assert export.schemas["/log"] == "foxglove.Log"

    # the replayed poses end where the mission did (its stored final state), action included
    final: list[dict[str, Any]] = api.get(f"/api/missions/{mid}/robots").json()
    _, last = export.topics["/robots/state"][-1]
    assert [(r["name"], r["x"], r["y"]) for r in last["robots"]] == [
        (r["name"], r["x"], r["y"]) for r in final
    ]
    assert last["counters"]["minerals_delivered"] == record["metrics"]["minerals_delivered"]
    # the map once, then every site as found and dug: all found and emptied at the end
    ((_, scene),) = export.topics["/scene/map"]
    assert "plant" in {e["id"] for e in scene["entities"]}
    sites: dict[str, dict[str, str]] = {}
    for _, update in export.topics["/scene/sites"]:
        for e in update["entities"]:
            sites[e["id"]] = {kv["key"]: kv["value"] for kv in e["metadata"]}
    assert sites and all(s["found"] == "True" and s["remaining"] == "0" for s in sites.values())


@pytest.mark.usefixtures("stand_in_field")
def test_a_field_mission_exports_its_events_without_poses(
    server: LiveServer, api: httpx.Client
) -> None:
    r = api.post("/api/missions", json={"policy": 1, "seed": 1, "field": True, "speed": 1000})
    assert r.status_code == 201, r.text
    mid = r.json()["id"]
    run_to_end(api, mid)
    export = _export(server, mid)
    _check_counts(api, mid, export)
    assert export.metadata["mode"] == "field" and export.metadata["poses"] == "none"
    assert not {"/tf", "/robots/poses", "/scene/robots", "/robots/state"} & set(export.topics)
    assert export.count("/scene/map") == 1


def test_a_live_mission_exports_as_far_as_it_has_run(server: LiveServer, api: httpx.Client) -> None:
    mid = api.post("/api/missions", json={"policy": 2, "seed": 3, "speed": 50}).json()["id"]
    export = _export(server, mid)  # whatever is stored now, consistent with itself
    assert export.count("/log") == sum(export.kinds().values())
    api.post(f"/api/missions/{mid}/stop").raise_for_status()


def test_a_stream_left_early_closes_its_writer_and_gives_its_slot_back() -> None:
    """A client that goes away after the first block: the writer (and its replay engine) is
    closed and the export's slot is free again, as when the stream ends normally."""
    slots = threading.BoundedSemaphore(EXPORTS)
    closed: list[str] = []

    def endless() -> Generator[bytes, None, None]:
        try:
            while True:
                yield b"block"
        finally:
            closed.append(threading.current_thread().name)

    async def leave_early() -> None:
        assert slots.acquire(blocking=False)
        stream = _stream(endless(), slots)
        assert await anext(stream) == b"block"
        await stream.aclose()  # what the server does when the client has gone

    aio.run(leave_early())
    assert closed and closed[0] != threading.main_thread().name  # closed on a worker thread
    assert all(slots.acquire(blocking=False) for _ in range(EXPORTS))  # every slot is back


@pytest.mark.parametrize(
    ("path", "code", "says"),
    [
        ("/api/missions/999/export.mcap", 404, "999"),
        ("/api/missions/0/export.mcap", 422, "path"),
    ],
)
def test_an_unknown_mission_is_a_clear_error(
    api: httpx.Client, path: str, code: int, says: str
) -> None:
    r = api.get(path)
    assert r.status_code == code
    assert says in r.text
