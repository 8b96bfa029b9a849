"""What a live mission's record says while it runs: its status, policies, speed and time,
read from the runner under the gate (the stored row says the rest)."""

from __future__ import annotations

from collections.abc import Iterable
from dataclasses import dataclass
from typing import Any

from app.live.mission import LiveMission


@dataclass(frozen=True)
class LiveState:
    """A consistent reading of a live mission, taken under the gate."""

    status: str
    policy: str
    speed: float | None
    sim_time: float
    metrics: dict[str, Any] | None = None
    policies: tuple[str, ...] = ()


def policies_in_effect(initial: str, actions: Iterable[tuple[str, dict[str, Any]]]) -> list[str]:
    """The policies a run used, in order: the initial one, then each switch to another (a
    switch back counts: fcfs → coalition → fcfs is three). More than one: a mixed run."""
    used = [initial]
    for kind, args in actions:
        new = args.get("policy")
        if kind == "set_policy" and isinstance(new, str) and new != used[-1]:
            used.append(new)
    return used


def live_state(lm: LiveMission, metrics: bool = False) -> LiveState:
    """Read `lm` (the caller holds the gate)."""
    m = lm.mission
    return LiveState(
        status=lm.status,
        policies=tuple(
            policies_in_effect(m.initial_policy, ((a["kind"], a["args"]) for a in m.actions))
        ),
        policy=lm.mission.policy,
        speed=lm.speed,
        sim_time=float(lm.mission.now),
        metrics=lm.mission.metrics() if metrics else None,
    )
