"""Small scenarios and missions for engine tests."""

from __future__ import annotations

from typing import Any

from engine import Mission, Scenario, parse_scenario
from engine.errors import CommandRejected
from tests.engine.invariants import InvariantWatch


def small_scenario(**overrides: Any) -> Scenario:
    """A 40×40 world with a small team: fast, but every mechanism is exercised."""
    data: dict[str, Any] = {
        "name": "small",
        "width": 40.0,
        "height": 40.0,
        "sites": 3,
        "minerals": 8,
        "team": {"scouts": 1, "excavators": 2, "haulers": 2},
        "random_craters": 1,
        "crater_radius": (1.5, 3.0),
        "max_time_s": 20000.0,
    }
    for key, value in overrides.items():
        if isinstance(value, dict) and isinstance(data.get(key), dict):
            data[key] = {**data[key], **value}
        else:
            data[key] = value
    return parse_scenario(data)


def quiet_scenario(**overrides: Any) -> Scenario:
    """No craters, a lone scout that takes long to find anything: the stage for hand-built
    auctions injected by the operator at t=0."""
    base: dict[str, Any] = {
        "width": 100.0,
        "height": 100.0,
        "sites": 1,
        "minerals": 1,
        "random_craters": 0,
        "team": {"scouts": 1, "excavators": 1, "haulers": 1},
    }
    base.update(overrides)
    return small_scenario(**base)


def play_actions(m: Mission, actions: list[tuple[float, str, Any]]) -> None:
    """Advance to each action's time and take it (fail, leave, enable, add, policy, inject);
    one the mission refuses (a robot already down, a policy in force) is skipped."""
    for t, kind, arg in actions:
        m.advance(t)
        try:
            if kind == "fail":
                m.disable_robot(arg, "abrupt")
            elif kind == "leave":
                m.disable_robot(arg, "graceful")
            elif kind == "enable":
                m.enable_robot(arg)
            elif kind == "add":
                m.add_robot(arg)
            elif kind == "policy":
                m.set_policy(arg)
            else:
                m.inject_task(arg, (20.0, 20.0))
        except CommandRejected:
            pass


def events_of(m: Mission, kind: str) -> list[dict[str, Any]]:
    return [dict(e.data, t=e.t) for e in m.events if e.kind == kind]


FAILURES = ((98.0, "scout-1"), (155.0, "hauler-1"), (400.0, "excavator-2"))
"""One robot of each type fails abruptly, while the others of its type carry on."""


def run_with_failures(policy: str, seed: int) -> Mission:
    """A small world (3 sites, 9 minerals; 2 scouts, 2 excavators, 3 haulers) run to its end
    under `policy` with `FAILURES`, the invariants checked at every event and at the end."""
    team = {"scouts": 2, "excavators": 2, "haulers": 3}
    m = Mission(small_scenario(sites=3, minerals=9, team=team), seed, policy)
    watch = InvariantWatch(m)
    for t, name in FAILURES:
        m.advance(t)
        if not m.done:
            m.disable_robot(name, "abrupt")
    m.run()
    watch.final()
    return m
