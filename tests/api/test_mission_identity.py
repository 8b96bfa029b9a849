"""What a mission record says about what it is comparable with: every policy it ran under
(a live switch makes it mixed) and its scenario's content hash; and the token check."""

from __future__ import annotations

import httpx

from engine import reference_scenario
from experiments.spec import scenario_hash
from tests.api.conftest import LiveServer

FAST = {"planner": "straight", "speed": 1}


def test_a_switched_mission_lists_both_policies_live_listed_and_stored(
    server: LiveServer, api: httpx.Client
) -> None:
    plain = api.post("/api/missions", json={**FAST, "policy": "fcfs", "seed": 2}).json()
    mixed = api.post("/api/missions", json={**FAST, "policy": "fcfs", "seed": 2}).json()
    back = api.post("/api/missions", json={**FAST, "policy": "coalition", "seed": 2}).json()
    assert plain["policies"] == ["fcfs"] and plain["mixed_policy"] is False
    api.put(f"/api/missions/{mixed['id']}/policy", json={"policy": "coalition"}).raise_for_status()
    api.put(f"/api/missions/{mixed['id']}/policy", json={"policy": "coalition"}).raise_for_status()
    # a switch to the policy already in effect changes nothing; a switch back still mixes
    api.put(f"/api/missions/{back['id']}/policy", json={"policy": "coalition"}).raise_for_status()
    answer = api.put(f"/api/missions/{back['id']}/policy", json={"policy": "nearest"}).json()
    assert answer["policies"] == ["coalition", "nearest"]
    api.put(f"/api/missions/{back['id']}/policy", json={"policy": "coalition"}).raise_for_status()

    def check(m: dict[str, object]) -> None:
        expected = {
            plain["id"]: (["fcfs"], False, "fcfs"),
            mixed["id"]: (["fcfs", "coalition"], True, "fcfs"),
            back["id"]: (["coalition", "nearest", "coalition"], True, "coalition"),
        }[m["id"]]  # type: ignore[index]
        assert (m["policies"], m["mixed_policy"], m["initial_policy"]) == expected, m

    listed = api.get("/api/missions").json()["items"]
    for m in listed:  # live
        check(m)
    for m in (plain, mixed, back):
        check(api.get(f"/api/missions/{m['id']}").json())
        api.post(f"/api/missions/{m['id']}/stop").raise_for_status()
        final = api.get(f"/api/missions/{m['id']}").json()  # stored, read from the database
        assert final["status"] == "stopped"
        check(final)
        assert final["metrics"]["policy"] == final["initial_policy"]
    for m in api.get("/api/missions").json()["items"]:
        check(m)
    server.restart()  # nothing kept in memory
    for m in api.get("/api/missions").json()["items"]:
        check(m)


def test_scenario_hash_tells_scenarios_apart_and_matches_a_sweeps(api: httpx.Client) -> None:
    ref = api.post("/api/missions", json={**FAST, "seed": 1}).json()
    small = reference_scenario().model_dump(mode="json")
    small["name"] = "reference"  # same name, other content: told apart by the hash
    small["sites"] = 3
    other = api.post("/api/missions", json={**FAST, "seed": 1, "scenario": small}).json()
    assert ref["scenario_hash"] == scenario_hash(reference_scenario())
    assert other["scenario_hash"] != ref["scenario_hash"]
    assert len(other["scenario_hash"]) == 16
    listed = {m["id"]: m["scenario_hash"] for m in api.get("/api/missions").json()["items"]}
    assert listed == {ref["id"]: ref["scenario_hash"], other["id"]: other["scenario_hash"]}


def test_auth_check_answers_the_role_for_the_token_only(server: LiveServer) -> None:
    with server.client() as op, server.client(token=False) as anon:
        r = op.get("/api/auth/check")
        assert r.status_code == 200 and r.json() == {"role": "operator"}
        assert anon.get("/api/auth/check").status_code == 401
        wrong = anon.get("/api/auth/check", headers={"Authorization": "Bearer not-the-token"})
        assert wrong.status_code == 403
        assert "token" in wrong.json()["detail"]
