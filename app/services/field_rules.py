"""What a field mission may be asked for (docs/field.md): checked before any agent starts,
so a refusal is a 4xx naming the field, never a half-started fleet."""

from __future__ import annotations

from typing import Literal

from app.live.modes import is_field
from app.services.errors import Invalid
from engine import MissionInterface, Scenario
from engine.team import roster
from field import refusals

Speed = float | Literal["max"]


def processes_of(mission: MissionInterface) -> int:
    """The agent processes a live mission runs (0 for a simulated one)."""
    return int(mission.processes()) if is_field(mission) else 0


def team_processes(scenario: Scenario) -> int:
    """The processes a new field mission starts: one per robot, and the operator's console."""
    return len(roster(scenario.team)) + 1


def check_field(scenario: Scenario, policy: str, speed: Speed, paused: bool) -> None:
    """What field mode refuses (`field.refusals`), as a 422 naming the field."""
    try:
        refusals.check_field(scenario=scenario, policy=policy, speed=speed, paused=paused)
    except refusals.FieldRefusal as exc:
        raise Invalid(str(exc), exc.loc) from None


def check_field_speed(speed: Speed) -> None:
    """A new speed for a live field mission: a finite one >= 1 (422 naming `body.speed`)."""
    try:
        refusals.check_field(speed=speed)
    except refusals.FieldRefusal as exc:
        raise Invalid(str(exc), ("body", *exc.loc)) from None


def no_resume(mission_id: int) -> str:
    """Why an interrupted field mission is not resumed: a resume rebuilds a mission by
    replaying the engine, and a field run is not a function of its determinants."""
    return (
        f"mission {mission_id} is a field mission: its world service and robots are gone (a "
        "server that starts takes back those still running), and a field run cannot be "
        "rebuilt by replay (that would continue it as a simulated one); it stays interrupted "
        "with its records kept: start a new field mission"
    )
