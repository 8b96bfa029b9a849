"""One mission interface: a simulated mission and a field mission both implement
`engine.MissionInterface` (the type checker holds each class to it, see the ends of
engine/mission.py and field/control.py; here, at run time), and field mode builds its team
and checks its operators' input with the engine's own code."""

from __future__ import annotations

import pytest

from engine import CommandRejected, Mission, MissionInterface
from engine.placement import place_task
from engine.scenario import Scenario
from engine.team import roster, start_positions
from field import control
from field.refusals import FieldRefusal, check_field
from field.world_view import WorldView
from tests.engine.factories import small_scenario
from tests.field.test_control_views import StandInFleet


@pytest.fixture
def field_mission() -> control.FieldMission:
    fleet = StandInFleet(Scenario(), 0, "nearest", 50.0)
    return control.FieldMission(Scenario(), 0, "nearest", 50.0, handle=fleet)  # type: ignore[arg-type]


def test_both_kinds_of_mission_implement_the_interface(
    field_mission: control.FieldMission,
) -> None:
    m = Mission(small_scenario(), 0, "fcfs", planner="straight")
    try:
        assert isinstance(m, MissionInterface) and m.mode == "simulated"
        assert isinstance(field_mission, MissionInterface) and field_mission.mode == "field"
    finally:
        m.close()


def test_the_world_service_starts_the_team_where_a_simulated_mission_does() -> None:
    m = Mission(small_scenario(), 3, "fcfs", planner="straight")
    try:
        team = roster(m.scenario.team)
        starts = start_positions(m.world, m.scenario.start_spread, len(team))
        assert list(team) == [r["name"] for r in m.robot_list()]
        assert starts == [m.robots[name].pos for name in team]
    finally:
        m.close()


def test_mission_control_knows_the_map_and_starts_the_world_process_uses() -> None:
    """Mission control, a process apart from the world's, derives the fixed part of the world
    (map, roster, start ring) from the scenario and seed; it must be the world's own."""
    m = Mission(small_scenario(), 5, "fcfs", planner="straight")
    try:
        view = WorldView(small_scenario(), 5, "fcfs")
        assert view.world.to_dict() == m.world.to_dict()
        assert [view.starts[n] for n in view.roster] == [m.robots[n].pos for n in view.roster]
    finally:
        m.close()


def test_a_task_is_placed_as_the_simulated_mission_places_it() -> None:
    m = Mission(small_scenario(), 0, "fcfs", planner="straight")
    try:
        for where in [(-1.0, 5.0), (float("nan"), 1.0), (1.0,)]:
            with pytest.raises(CommandRejected) as in_field:
                place_task(m.world, m.ctx.terrain.sites, 2.0, "transport", where)
            with pytest.raises(CommandRejected) as in_engine:
                m.inject_task("transport", where)
            assert str(in_field.value) == str(in_engine.value)
    finally:
        m.close()


def test_one_place_refuses_a_centralized_policy(field_mission: control.FieldMission) -> None:
    with pytest.raises(FieldRefusal) as refused:
        check_field(policy="central-greedy")
    assert refused.value.loc == ("policy",)
    with pytest.raises(CommandRejected, match=str(refused.value)):
        field_mission.set_policy("central-greedy")
