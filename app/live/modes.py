"""Which kind of mission the runner holds, by the mode it declares (`MissionInterface.mode`):
a simulated one, or a field mission (one process per robot, `field.control.FieldMission`),
and what a field mission's processes dropped."""

from __future__ import annotations

from typing import TYPE_CHECKING, TypeGuard

from engine import MissionInterface

if TYPE_CHECKING:
    from field.control import FieldMission


def is_field(mission: MissionInterface) -> TypeGuard[FieldMission]:
    """A live field mission: its robots are processes on the wall clock, its operator tasks
    go over the wire, and it runs processes and counts what they dropped."""
    return mission.mode == "field"


def dropped_of(mission: MissionInterface) -> dict[str, int]:
    """What a live field mission's processes dropped or refused, by reason (docs/field.md,
    "Trust"); empty for a simulated one."""
    if not is_field(mission):
        return {}
    r = mission.rejections()
    out = dict(r["by_reason"])
    out["reported by agents"] = sum(r["agents"].values())
    out["refused by the world service"] = r["world_refused"]
    return out
