"""GET /api/policies: the engine's registry, readable by viewers, the menus' single source."""

from __future__ import annotations

from pathlib import Path

from engine import policy_table
from tests.api.conftest import LiveServer, make_settings


def test_viewers_read_every_registered_policy_in_registration_order(server: LiveServer) -> None:
    with server.client(token=False) as anon:
        res = anon.get("/api/policies")
        spec = anon.get("/openapi.json").json()
    assert res.status_code == 200, res.text
    assert res.json() == policy_table()
    names = [p["name"] for p in res.json()]
    assert names[:3] == ["fcfs", "coalition", "nearest"] and "central-greedy" in names
    assert [p["decentralized"] for p in res.json() if p["name"] == "central-greedy"] == [False]
    # the request enum accepts exactly the policies the list offers
    accepted = spec["components"]["schemas"]["PolicyUpdate"]["properties"]["policy"]["anyOf"]
    assert set(names) == set(accepted[0]["enum"])


def test_with_read_requires_token_the_list_needs_it_too(tmp_path: Path) -> None:
    server = LiveServer(make_settings(tmp_path, read_requires_token=True)).start()
    try:
        with server.client(token=False) as anon, server.client() as operator:
            assert anon.get("/api/policies").status_code == 401
            assert operator.get("/api/policies").status_code == 200
    finally:
        server.stop()
