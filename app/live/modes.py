"""Which kind of mission the runner holds: an engine mission or a field mission (one process per
robot, `field.control.FieldMission`), and what a field mission's processes dropped."""

from __future__ import annotations

from typing import Any


def is_field(mission: object) -> bool:
    """A live field mission (`field.control.FieldMission`, whose `mode` is the stored one):
    its robots are processes on the wall clock, its operator tasks go over the wire."""
    return getattr(mission, "mode", "simulated") == "field"


def dropped_of(mission: Any) -> dict[str, int]:
    """What a live field mission's processes dropped or refused, by reason (docs/field.md,
    "Trust"); empty for a simulated one."""
    if not is_field(mission):
        return {}
    r: dict[str, Any] = mission.rejections()
    out = dict(r["by_reason"])
    out["reported by agents"] = sum(r["agents"].values())
    out["refused by the world service"] = r["world_refused"]
    return out
