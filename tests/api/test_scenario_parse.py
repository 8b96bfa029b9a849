"""`POST /api/scenarios/parse`: a scenario file's text (TOML with the standard library's
`tomllib`, or JSON) becomes the validated scenario the dashboard sends to start a mission."""

from __future__ import annotations

from pathlib import Path

import httpx

from tests.api.conftest import LiveServer, make_settings

SMALL = """\
# a small team on a small area
name = "small"
width = 60
height = 60.0
sites = 4
minerals = 8

[team]
scouts = 1
excavators = 2
haulers = 3

[[craters]]
x = 10
y = 20.5
r = 3
"""


def test_a_toml_file_becomes_the_scenario_with_every_default(api: httpx.Client) -> None:
    res = api.post("/api/scenarios/parse", json={"text": SMALL})
    assert res.status_code == 200, res.text
    scenario = res.json()
    reference = api.get("/api/scenarios/reference").json()
    assert scenario.keys() == reference.keys()
    assert scenario["name"] == "small" and scenario["width"] == 60.0
    assert scenario["team"] == {"scouts": 1, "excavators": 2, "haulers": 3}
    assert scenario["craters"] == [{"x": 10.0, "y": 20.5, "r": 3.0}]
    assert scenario["timing"] == reference["timing"]
    # it is what POST /api/missions takes as `scenario`
    body = {"scenario": scenario, "paused": True, "planner": "straight"}
    created = api.post("/api/missions", json=body)
    assert created.status_code == 201, created.text
    assert created.json()["scenario"] == scenario


def test_json_files_are_read_too(api: httpx.Client) -> None:
    res = api.post("/api/scenarios/parse", json={"format": "json", "text": '{"sites": 3}'})
    assert res.status_code == 200 and res.json()["sites"] == 3
    bad = api.post("/api/scenarios/parse", json={"format": "json", "text": '{"sites": 3,\n}'})
    assert bad.status_code == 422 and "line 2" in bad.json()["message"]


def test_bad_toml_syntax_is_422_with_the_line(api: httpx.Client) -> None:
    res = api.post("/api/scenarios/parse", json={"text": 'name = "x"\nwidth = \n'})
    assert res.status_code == 422
    body = res.json()
    assert body["detail"][0]["loc"] == ["body", "text"]
    assert body["message"].startswith("body.text: not valid TOML:")
    assert "line 2" in body["message"]


def test_an_invalid_field_is_422_naming_it(api: httpx.Client) -> None:
    res = api.post("/api/scenarios/parse", json={"text": "[team]\nhaulers = -1\n"})
    assert res.status_code == 422
    assert res.json()["message"].startswith("body.scenario.team.haulers: ")
    res = api.post("/api/scenarios/parse", json={"text": "colour = 'red'\n"})
    assert res.status_code == 422 and "body.scenario.colour" in res.json()["message"]
    res = api.post("/api/scenarios/parse", json={"text": "x = [1, 2]\n", "format": "yaml"})
    assert res.status_code == 422 and "body.format" in res.json()["message"]


def test_this_servers_size_limits_apply(tmp_path: Path) -> None:
    server = LiveServer(make_settings(tmp_path, max_robots=13)).start()
    try:
        with server.client() as api:
            res = api.post("/api/scenarios/parse", json={"text": "[team]\nhaulers = 10\n"})
        assert res.status_code == 422
        assert "body.scenario.team" in res.json()["message"]
        assert "REGOLITH_MAX_ROBOTS" in res.json()["message"]
    finally:
        server.stop()


def test_operators_only(server: LiveServer) -> None:
    with server.client(token=False) as anon:
        assert anon.post("/api/scenarios/parse", json={"text": SMALL}).status_code == 401
        assert anon.get("/api/scenarios/reference").status_code == 200


def test_the_realism_options_parse_and_a_bad_one_is_422_naming_it(api: httpx.Client) -> None:
    """docs/model.md: the committed lunar-realistic scenario parses with its four sections on;
    a mission of it shows each robot's charge; a bad option value names its field."""
    text = (Path(__file__).resolve().parents[2] / "scenarios" / "lunar-realistic.toml").read_text()
    res = api.post("/api/scenarios/parse", json={"text": text})
    assert res.status_code == 200, res.text
    scenario = res.json()
    for section in ("energy", "docks", "uncertainty", "radio"):
        assert scenario[section]["enabled"] is True
    assert "energy" not in api.get("/api/scenarios/reference").json()  # off: left out
    mid = api.post("/api/missions", json={"policy": 4, "paused": True, "scenario": scenario})
    assert mid.status_code == 201, mid.text
    robots = api.get(f"/api/missions/{mid.json()['id']}/robots").json()
    assert robots and all(r["charge"] == 1.0 for r in robots)
    bad = api.post("/api/scenarios/parse", json={"text": "[docks]\nenabled = true\ncount = 0\n"})
    assert bad.status_code == 422
    assert "docks.count" in bad.text
