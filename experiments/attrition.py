"""Attrition: robots that fail for good. Of each type's robots, all but one fail (abruptly or
gracefully, at random) within a short spell of one another, at a random time, and none comes
back. One robot of each type can do every task, so the survivors must finish the mission with
every mineral delivered. It tests what the random operator actions cannot: there, every robot
is enabled at the end, and a robot disabled in the engine keeps its duties and takes them up
again, which heals a duty nobody adopted; a field robot's new life starts with none.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Protocol

import numpy as np

from engine import Mission, Scenario, parse_scenario

TYPES = ("scout", "excavator", "hauler")


@dataclass
class AttritionRun:
    """One mission under attrition and what became of it."""

    seed: int
    policy: str
    failures: list[tuple[float, str, str]] = field(default_factory=list)  # (t, robot, mode)
    status: str = ""
    delivered: int = 0
    total: int = 0

    @property
    def finished(self) -> bool:
        return self.status == "completed" and self.delivered == self.total


class Watch(Protocol):
    """A check run beside the mission (the tests' invariant watch): `final` after its end."""

    def final(self) -> None: ...


def attrition_team(scenario: Scenario, each: int = 3) -> Scenario:
    """The scenario with `each` robots of every type."""
    data = scenario.model_dump()
    data["team"].update(scouts=each, excavators=each, haulers=each)
    return parse_scenario(data)


def attrition_mission(
    scenario: Scenario,
    seed: int,
    policy: str,
    *,
    window_s: tuple[float, float] = (100.0, 1500.0),
    spell_s: float = 40.0,
    planner: str = "straight",
    watch: Callable[[Mission], Watch] | None = None,
) -> AttritionRun:
    """Run one mission in which all but one robot of each type fail for good: each type's
    first failure at a random time in `window_s`, the others within `spell_s` after it."""
    rng = np.random.default_rng([seed, 0xA771])
    m = Mission(scenario, seed, policy, planner=planner)  # type: ignore[arg-type]
    watcher = None if watch is None else watch(m)
    failures: list[tuple[float, str, str]] = []
    for rtype in TYPES:
        names = sorted(r["name"] for r in m.robot_list() if r["type"] == rtype)
        doomed = [names[int(i)] for i in rng.permutation(len(names))[: len(names) - 1]]
        t = float(rng.uniform(*window_s))
        for k, name in enumerate(doomed):
            at = t if k == 0 else t + float(rng.uniform(0.0, spell_s))
            failures.append((at, name, "graceful" if rng.random() < 0.5 else "abrupt"))
    failures.sort()
    run = AttritionRun(seed, m.policy, failures, total=m.ctx.terrain.minerals_total)
    try:
        for at, name, mode in failures:
            m.advance(at)
            if m.done:
                break
            m.disable_robot(name, mode)
        m.run()
        if watcher is not None:
            watcher.final()
    finally:
        m.close()
    run.status, run.delivered = m.status, m.ctx.terrain.delivered
    return run
