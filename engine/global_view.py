"""What a baseline with global knowledge may read of the whole mission (`GlobalView`).

The centralized baseline (`central-greedy`) and the clairvoyant reference (`offline`) decide
from the true state of every robot, auction and site, which no robot could know. They are
given this view, declared here, and nothing else of the mission; a decentralized policy is
given none. `engine.context.MissionContext` provides it.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import TYPE_CHECKING, Protocol

if TYPE_CHECKING:
    import simpy

    from engine.bidding import OpenAuction
    from engine.geometry import Point
    from engine.messages import TaskType
    from engine.observer import Observer
    from engine.planning import PathPlanner
    from engine.scenario import Scenario
    from engine.terrain import Terrain
    from engine.world import World


class HeldTask(Protocol):
    """A task a robot holds (`engine.robots.core.Assignment`): what and where."""

    @property
    def task_type(self) -> TaskType: ...
    @property
    def location(self) -> Point: ...


class BidderState(Protocol):
    """A bidding robot's auction state (`engine.robots.bidder.Bidder`)."""

    @property
    def reserved(self) -> OpenAuction | None: ...
    def can_take(self) -> bool: ...
    def free_at(self) -> tuple[float, Point]: ...


class SearchState(Protocol):
    """A scout's share of the search (`engine.robots.search.Search`): its route of cells and
    how far along it is."""

    @property
    def route(self) -> Sequence[int]: ...
    @property
    def cursor(self) -> int: ...


class Whereabouts(Protocol):
    """Where a robot is and the route it is driving (`engine.robots.mobility.Mobility`)."""

    def position(self, t: float | None = None) -> tuple[Point, float]: ...
    def remaining_route(self) -> list[Point]: ...


class AuctionsRun(Protocol):
    """The auctions a robot runs now (its auctioneer part, `engine.auction_house`)."""

    def has_open(self, auction_id: str) -> bool: ...


class RobotState(Protocol):
    """What a baseline reads of one robot (`engine.robots.base.Robot`)."""

    @property
    def name(self) -> str: ...
    @property
    def rtype(self) -> str: ...
    @property
    def capability(self) -> TaskType | None: ...
    @property
    def speed(self) -> float: ...
    @property
    def alive(self) -> bool: ...
    @property
    def participating(self) -> bool: ...
    @property
    def motion(self) -> object | None: ...
    @property
    def current(self) -> HeldTask | None: ...
    @property
    def bidder(self) -> BidderState | None: ...
    @property
    def search(self) -> SearchState | None: ...
    @property
    def mobility(self) -> Whereabouts: ...
    @property
    def house(self) -> AuctionsRun: ...
    def tasks_held(self) -> Sequence[HeldTask]: ...
    def load(self) -> int: ...


class PolicyName(Protocol):
    """The policy in effect, as a baseline reads it: by name."""

    @property
    def name(self) -> str: ...


class GlobalView(Protocol):
    """The mission's true state: the scenario and world, the clock, every robot, the terrain's
    sites and minerals, the auction records and the event log (`observer`), the path planner
    (which `offline` wraps to drive its planned legs) and the policy in effect."""

    scenario: Scenario
    world: World
    env: simpy.Environment
    terrain: Terrain
    observer: Observer
    planner: PathPlanner

    @property
    def policy(self) -> PolicyName: ...
    @property
    def robots(self) -> Mapping[str, RobotState]: ...
