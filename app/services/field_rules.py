"""What a field mission may be asked for (docs/field.md): checked before any agent starts,
so a refusal is a 4xx naming the field, never a half-started fleet."""

from __future__ import annotations

from typing import Any, Literal

from app.live.modes import is_field
from app.services.errors import Invalid
from engine import Scenario
from engine.scenario import REALISM_OPTIONS

Speed = float | Literal["max"]


def processes_of(mission: Any) -> int:
    """The agent processes a live mission runs (0 for a simulated one)."""
    return int(mission.processes()) if is_field(mission) else 0


def team_processes(scenario: Scenario) -> int:
    """The processes a new field mission starts: one per robot, and the operator's console."""
    t = scenario.team
    return t.scouts + t.excavators + t.haulers + 1


def check_field(scenario: Scenario, policy: str, speed: Speed, paused: bool) -> None:
    """What a field mission needs: a wall-clock speed, no pause, a decentralized policy and
    none of the realism options (docs/field.md)."""
    from engine.policies import POLICIES

    if speed == "max" or float(speed) < 1 or paused:
        raise Invalid("speed: a field mission runs at a fixed speed >= 1, unpaused", ("speed",))
    if not POLICIES[policy].decentralized:
        raise Invalid(
            f"policy: {policy} is centralized; field mode runs decentralized ones", ("policy",)
        )
    on = scenario.realism_on  # (field mode runs none of them)
    if on:
        raise Invalid(
            f"scenario.{on[0]}: field mode runs without the realism options "
            f"({', '.join(REALISM_OPTIONS)})",
            ("scenario", on[0]),
        )


def no_resume(mission_id: int) -> str:
    """Why an interrupted field mission is not resumed: a resume rebuilds a mission by
    replaying the engine, and a field run is not a function of its determinants."""
    return (
        f"mission {mission_id} is a field mission: its robots were processes of the server "
        "that stopped and are gone, and a field run cannot be rebuilt by replay (that would "
        "continue it as a simulated one); it stays interrupted with its records kept: start "
        "a new field mission"
    )
