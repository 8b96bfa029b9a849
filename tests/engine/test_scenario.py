"""Scenarios: the reference values, files, scaling, and refusals that name the field."""

import json
from pathlib import Path

import pytest

from engine import ScenarioError, load_scenario, parse_scenario, reference_scenario


def test_reference_scenario_is_spec_section_1():
    s = reference_scenario()
    assert (s.width, s.height, s.plant_xy) == (100.0, 100.0, (50.0, 50.0))
    assert (s.sites, s.minerals, s.scan_radius) == (10, 64, 2.5)
    assert (s.team.scouts, s.team.excavators, s.team.haulers) == (2, 4, 6)


def test_toml_and_json_files_load_to_the_same_scenario(tmp_path: Path):
    toml = tmp_path / "s.toml"
    toml.write_text('name = "small"\nsites = 4\nminerals = 9\n[team]\nhaulers = 3\n')
    js = tmp_path / "s.json"
    js.write_text(json.dumps({"name": "small", "sites": 4, "minerals": 9, "team": {"haulers": 3}}))
    assert load_scenario(toml) == load_scenario(js)
    assert load_scenario(toml).team.haulers == 3


@pytest.mark.parametrize(
    ("data", "field"),
    [
        ({"team": {"haulers": 0}}, "team.haulers"),
        ({"minerals": 3, "sites": 5}, "minerals"),
        ({"width": float("nan")}, "width"),
        ({"timing": {"dig_s": -1}}, "timing.dig_s"),
        ({"plant": (500.0, 5.0)}, "plant"),
        ({"craters": [{"x": 50, "y": 50, "r": 4}]}, "craters[0]"),
        ({"scan_radius": 1e-300}, "scan_radius"),
        ({"sites": 5000, "minerals": 5000}, "sites"),
        ({"speed": 3}, "speed"),
    ],
)
def test_unworkable_scenarios_are_refused_naming_the_field(data, field):
    with pytest.raises(ScenarioError) as err:
        parse_scenario(data)
    assert field in str(err.value)


def test_bad_files_say_what_is_wrong(tmp_path: Path):
    for name, text, says in [
        ("a.yaml", "x: 1", r"must end in \.toml or \.json"),
        ("b.toml", "name = ", "not valid TOML"),
        ("c.json", "[1, 2]", "top level"),
    ]:
        p = tmp_path / name
        p.write_text(text)
        with pytest.raises(ScenarioError, match=says):
            load_scenario(p)
    with pytest.raises(ScenarioError, match=r"missing\.toml"):
        load_scenario(tmp_path / "missing.toml")


def test_scaling_keeps_density_and_is_validated():
    s10 = reference_scenario().scaled(10)
    assert s10.name == "reference-x10"
    long = reference_scenario().model_copy(update={"name": "n" * 80}).scaled(16)
    assert long.name == "n" * 76 + "-x16"  # within the name's 80 characters
    assert (s10.team.haulers, s10.sites, s10.minerals, s10.random_craters) == (60, 100, 640, 60)
    assert s10.width == pytest.approx(100 * 10**0.5)
    assert s10.plant_xy == pytest.approx((50 * 10**0.5, 50 * 10**0.5))
    with pytest.raises(ScenarioError, match="scale"):
        reference_scenario().scaled(1_000_000)
