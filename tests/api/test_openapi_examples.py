"""The published OpenAPI examples are valid requests: what /docs' "Try it out" sends works.

Every request body in `/openapi.json` must carry `examples`, in its schema and as the body's
OpenAPI examples (without them Swagger UI makes its own from the schema: `"plant": [null,
null]`, a crater at -1e7, a 422), and each example, sent as is to its route on a real server,
must be accepted.
"""

from __future__ import annotations

from typing import Any

import httpx
import pytest

from tests.api.conftest import LiveServer


def _schema(spec: dict[str, Any], body: dict[str, Any]) -> dict[str, Any]:
    schema = body["content"]["application/json"]["schema"]
    for option in schema.get("anyOf", [schema]):  # an optional body: the model or null
        if "$ref" in option:
            name = option["$ref"].rsplit("/", 1)[1]
            found: dict[str, Any] = spec["components"]["schemas"][name]
            return found
    return dict(schema)


def _requests(spec: dict[str, Any]) -> list[tuple[str, str, dict[str, Any]]]:
    """(method, path, example) for every example of every request body; a body without
    examples fails here."""
    out = []
    for path, ops in spec["paths"].items():
        for method, op in ops.items():
            if "requestBody" not in op:
                continue
            body = op["requestBody"]
            examples = _schema(spec, body).get("examples")
            assert examples, f"{method.upper()} {path}: its request body has no examples"
            # and the same as the body's OpenAPI examples, the ones Swagger UI fills in
            shown = body["content"]["application/json"].get("examples", {})
            assert [e["value"] for e in shown.values()] == examples, (method, path)
            out += [(method, path, ex) for ex in examples]
    # creations first, a robot's disable last (it cannot be disabled twice)
    return sorted(out, key=lambda r: ("disable" in r[1], r[1].count("{"), r[1]))


@pytest.mark.sqlite_only  # the schemas, whatever the database
def test_every_published_request_example_is_accepted(server: LiveServer) -> None:
    with server.client() as api:
        spec = api.get("/openapi.json").json()
        requests = _requests(spec)
        assert {p for _, p, _ in requests} >= {"/api/missions", "/api/scenarios/parse"}
        mid = api.post("/api/missions", json={"paused": True}).json()["id"]
        for method, path, example in requests:
            url = path.replace("{mission_id}", str(mid)).replace("{name}", "hauler-1")
            res = api.request(method.upper(), url, json=example)
            assert res.status_code < 400, (method, path, example, res.status_code, res.text)
            if path == "/api/missions":
                _stop(api, res)
            elif path == "/api/sweeps":
                api.post(f"/api/sweeps/{res.json()['id']}/cancel")


def _stop(api: httpx.Client, res: httpx.Response) -> None:
    api.post(f"/api/missions/{res.json()['id']}/stop").raise_for_status()
