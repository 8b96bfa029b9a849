"""Random operator action sequences: the combined-fault test of liveness.

An operator disables robots (gracefully or abruptly), enables them, adds robots, injects
tasks and switches the policy at random times, sometimes two actions at one instant; at the
end every robot is enabled again. A team restored to full strength must finish the mission
with every mineral delivered. The sequence is drawn while the mission runs (an action is
chosen from the robots' states at its time), so it depends only on the seed and is recorded
as the mission's own action list, which replays to the same run.
"""

from __future__ import annotations

import contextlib
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from engine import CommandRejected, Mission, Scenario
from engine.policies import POLICIES

KINDS = ("disable_graceful", "disable_abrupt", "enable", "add", "inject", "set_policy")
WEIGHTS = (0.2, 0.25, 0.25, 0.1, 0.1, 0.1)


@dataclass
class ChaosRun:
    """One randomized mission and what became of it."""

    seed: int
    policy: str
    actions: list[dict[str, Any]] = field(default_factory=list)
    restored_at: float = 0.0
    status: str = ""
    delivered: int = 0
    total: int = 0
    makespan_s: float | None = None
    sim_time_s: float = 0.0

    @property
    def finished(self) -> bool:
        return self.status == "completed" and self.delivered == self.total


def _choose(m: Mission, rng: np.random.Generator) -> dict[str, Any] | None:
    """One operator action that is valid now, or None when the drawn kind has no target."""
    kind = KINDS[int(rng.choice(len(KINDS), p=WEIGHTS))]
    robots = m.robot_list()
    up = sorted(r["name"] for r in robots if r["enabled"])
    down = sorted(r["name"] for r in robots if not r["enabled"])
    if kind.startswith("disable") and up:
        name = up[int(rng.integers(len(up)))]
        mode = "graceful" if kind == "disable_graceful" else "abrupt"
        return {"kind": "disable_robot", "args": {"name": name, "mode": mode}}
    if kind == "enable" and down:
        return {"kind": "enable_robot", "args": {"name": down[int(rng.integers(len(down)))]}}
    if kind == "add":
        rtype = ("scout", "excavator", "hauler")[int(rng.integers(3))]
        return {"kind": "add_robot", "args": {"type": rtype, "position": None}}
    if kind == "inject":
        return _injection(m, rng)
    if kind == "set_policy":
        names = sorted(POLICIES)
        return {"kind": "set_policy", "args": {"policy": names[int(rng.integers(len(names)))]}}
    return None


def _injection(m: Mission, rng: np.random.Generator) -> dict[str, Any] | None:
    """Mostly a known site (the operator's usual case), sometimes an empty free point."""
    found = [s for s in m.ctx.terrain.sites if s.found_at is not None]
    if found and rng.random() < 0.7:
        s = found[int(rng.integers(len(found)))]
        return {"kind": "inject_task", "args": {"type": "excavate", "location": [s.x, s.y]}}
    w, h = m.world.width, m.world.height
    for _ in range(20):
        x, y = float(rng.uniform(0, w)), float(rng.uniform(0, h))
        if m.world.is_free(x, y):
            task = "excavate" if rng.random() < 0.5 else "transport"
            return {"kind": "inject_task", "args": {"type": task, "location": [x, y]}}
    return None


def chaos_mission(
    scenario: Scenario,
    seed: int,
    policy: str,
    *,
    actions: int,
    window_s: float,
    planner: str = "ompl",
    watch: Callable[[Mission], Any] | None = None,
) -> ChaosRun:
    """Run one mission under `actions` random operator actions drawn over the first
    `window_s` simulated seconds, then enable every robot and run to the end."""
    rng = np.random.default_rng([seed, 0xC4A05])
    m = Mission(scenario, seed, policy, planner=planner)  # type: ignore[arg-type]
    if watch is not None:
        watch(m)
    run = ChaosRun(seed, m.policy, total=m.ctx.terrain.minerals_total)
    times: list[float] = sorted(float(t) for t in rng.uniform(0, window_s, size=actions))
    for i in range(1, len(times)):
        if rng.random() < 0.15:
            times[i] = times[i - 1]  # two actions at the same simulated instant
    try:
        for t in times:
            m.advance(t)
            if m.done:
                break
            action = _choose(m, rng)
            if action is not None:
                _try(m, {"t": m.now, **action})
        if not m.done:
            m.advance(window_s)
            run.restored_at = m.now
            for r in m.robot_list():
                if not r["enabled"]:
                    _try(m, {"t": m.now, "kind": "enable_robot", "args": {"name": r["name"]}})
        m.run()
    finally:
        m.close()
    run.actions = list(m.actions)
    run.status, run.delivered = m.status, m.ctx.terrain.delivered
    run.makespan_s, run.sim_time_s = m.ctx.terrain.finished_at, m.now
    return run


def _try(m: Mission, action: dict[str, Any]) -> None:
    with contextlib.suppress(CommandRejected):  # e.g. the robot had finished leaving
        m.apply(action)
