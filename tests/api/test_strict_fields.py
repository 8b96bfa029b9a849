"""Request fields are strict: `false` is not policy 0 (the central baseline), `true` is not
speed 1, `"5"` is not seed 5; sweep seeds end where mission seeds do (2^31 - 1)."""

from __future__ import annotations

from typing import Any

import httpx
import pytest

from engine.policies import unused_number
from tests.api.conftest import LiveServer

UNKNOWN = unused_number()  # a number no policy holds


def _refused(api: httpx.Client, method: str, path: str, body: dict[str, Any], field: str) -> None:
    res = api.request(method, path, json=body)
    assert res.status_code == 422, res.text
    assert f"body.{field}" in res.json()["message"], res.json()["message"]


@pytest.mark.parametrize(
    ("body", "field"),
    [
        ({"policy": False}, "policy"),
        ({"policy": True}, "policy"),
        ({"policy": 1.0}, "policy"),
        ({"speed": True}, "speed"),
        ({"speed": "5"}, "speed"),
        ({"seed": True}, "seed"),
        ({"seed": "5"}, "seed"),
        ({"seed": 2**31}, "seed"),
        ({"paused": "yes"}, "paused"),
        ({"paused": 1}, "paused"),
    ],
)
def test_mission_fields_take_no_lookalikes(
    api: httpx.Client, body: dict[str, Any], field: str
) -> None:
    _refused(api, "POST", "/api/missions", {"planner": "straight", **body}, field)
    assert api.get("/api/missions").json()["total"] == 0


def test_commands_are_strict_too(server: LiveServer, api: httpx.Client) -> None:
    mid = api.post("/api/missions", json={"paused": True, "planner": "straight"}).json()["id"]
    _refused(api, "PUT", f"/api/missions/{mid}/speed", {"speed": True}, "speed")
    _refused(api, "PUT", f"/api/missions/{mid}/policy", {"policy": False}, "policy")
    _refused(api, "POST", f"/api/missions/{mid}/tasks", {"location": [True, 5]}, "location")
    mission = api.get(f"/api/missions/{mid}").json()
    assert mission["policy"] == "fcfs" and mission["speed"] == 1.0 and not mission["actions"]
    # the real thing still works: whole numbers are numbers, names and numbers are policies
    assert api.put(f"/api/missions/{mid}/speed", json={"speed": 3}).json()["speed"] == 3.0
    assert api.put(f"/api/missions/{mid}/policy", json={"policy": 3}).json()["policy"] == "nearest"


@pytest.mark.parametrize(
    ("body", "field"),
    [
        ({"policies": [False]}, "policies.0"),
        ({"scale": True}, "scale"),
        ({"seeds": [True, 2]}, "seeds"),
        ({"seeds": {"from": True, "to": 3}}, "seeds"),
        ({"seeds": "2147483647-2147483650"}, "seeds"),  # text seeds were not bounded at all
        ({"seeds": "99999999999"}, "seeds"),
        ({"seeds": [2**31]}, "seeds"),
    ],
)
def test_sweep_fields_are_strict_and_seeds_bounded(
    api: httpx.Client, body: dict[str, Any], field: str
) -> None:
    _refused(api, "POST", "/api/sweeps", body, field)
    assert api.get("/api/sweeps").json()["total"] == 0


@pytest.mark.parametrize(
    "content_type", ["application/x-www-form-urlencoded", "text/plain", "multipart/form-data"]
)
def test_a_body_not_sent_as_json_says_what_to_send(api: httpx.Client, content_type: str) -> None:
    """`curl -d '{…}'` without `-H "Content-Type: application/json"` sends a form: the 422
    says to send JSON, not only "Input should be a valid dictionary"."""
    body = '{"policy": "fcfs", "seed": 0, "planner": "straight"}'
    res = api.post("/api/missions", content=body, headers={"Content-Type": content_type})
    assert res.status_code == 422, res.text
    message = res.json()["message"]
    assert message.startswith("body: send JSON with Content-Type: application/json"), message
    assert content_type in message
    assert api.get("/api/missions").json()["total"] == 0
    # the same body as JSON is a mission
    res = api.post("/api/missions", content=body, headers={"Content-Type": "application/json"})
    assert res.status_code == 201, res.text
    api.post(f"/api/missions/{res.json()['id']}/stop")


@pytest.mark.parametrize(
    ("path", "body", "message"),
    [
        (
            "/api/missions",
            {"speed": -1},
            "body.speed: Input should be greater than or equal to 0, or 'max'",
        ),
        (
            "/api/missions",
            {"speed": "fast"},
            "body.speed: Input should be a valid number, or 'max'",
        ),
        (
            "/api/missions",
            {"speed": 1e-300},
            "body.speed: must be 0 (pause), at least 0.1, or 'max'",
        ),
        ("/api/missions", {"speed": 0.05}, "body.speed: must be 0 (pause), at least 0.1, or 'max'"),
        ("/api/missions", {"policy": UNKNOWN}, "body.policy: "),
        ("/api/sweeps", {"seeds": {"from": 1}}, "body.seeds.to: Field required"),
        ("/api/sweeps", {"seeds": 5.5}, "body.seeds: "),
        ("/api/sweeps", {"policies": [UNKNOWN]}, "body.policies.0: "),
    ],
)
def test_a_field_of_two_types_is_named_alone(
    api: httpx.Client, path: str, body: dict[str, Any], message: str
) -> None:
    """A field taking a number or "max" (a name or a number, …) fails once per type; the
    message names the field (`body.speed`), never the validator (`constrained-float`)."""
    res = api.post(path, json=body)
    assert res.status_code == 422, res.text
    said = res.json()["message"]
    assert said.startswith(message) and said.count("body.") == 1, said
    for leak in ("constrained", "literal[", "function-after", "str]", "int]", "lax-", "range."):
        assert leak not in said, said
    first = res.json()["detail"][0]["loc"][:2]
    assert first == said.split(":")[0].split(".")[:2]  # the detail's location, tags left out


def test_speed_has_a_floor(server: LiveServer, api: httpx.Client) -> None:
    mid = api.post("/api/missions", json={"paused": True, "planner": "straight"}).json()["id"]
    res = api.put(f"/api/missions/{mid}/speed", json={"speed": 1e-300})
    assert res.status_code == 422 and res.json()["message"].startswith("body.speed: must be 0")
    assert api.put(f"/api/missions/{mid}/speed", json={"speed": 0.1}).json()["speed"] == 0.1
