"""What a baseline with global knowledge may read of the whole mission (`GlobalView`).

The centralized baseline (`central-greedy`) and the clairvoyant reference (`offline`) decide
from the true state of every robot, auction and site, which no robot could know. They are
given this view, declared here, and nothing else of the mission; a decentralized policy is
given none. `engine.context.MissionContext` provides it.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import TYPE_CHECKING, Protocol

if TYPE_CHECKING:
    import simpy

    from engine.field import Field
    from engine.observer import Observer
    from engine.planning import PathPlanner
    from engine.policies import Policy
    from engine.robots.base import Robot
    from engine.scenario import Scenario
    from engine.world import World


class GlobalView(Protocol):
    """The mission's true state: the scenario and world, the clock, every robot, the field's
    sites and minerals, the auction records and the event log (`observer`), the path planner
    (which `offline` wraps to drive its planned legs) and the policy in effect."""

    scenario: Scenario
    world: World
    env: simpy.Environment
    field: Field
    observer: Observer
    planner: PathPlanner
    policy: Policy

    @property
    def robots(self) -> Mapping[str, Robot]: ...
