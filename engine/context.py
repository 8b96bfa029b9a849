"""What one run shares: its services (the clock, the bus, the planner, the policy, the
liveness board, the robots present), the terrain and the observer.

Robots reach each other only through the bus. The terrain (`engine.terrain`: site piles, minerals
on the ground, scanned cells, deliveries) is shared because it is physical: a robot at a site
sees the pile and the robots beside it. The observer (`engine.observer`: the event log,
auction records, counters) is bookkeeping for the researcher; no robot decision reads it.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence, Set
from typing import TYPE_CHECKING, Any, Protocol

import simpy

from engine.auction_rules import AuctionRecord
from engine.energy import Located, Powered
from engine.global_view import HeldTask, RobotState, Whereabouts
from engine.liveness import Liveness
from engine.messages import Location, Message, TaskType
from engine.observer import Observer
from engine.planning import PathPlanner, PlanningError
from engine.scenario import Protocol as ProtocolSettings
from engine.scenario import Scenario
from engine.terrain import Terrain
from engine.world import World

if TYPE_CHECKING:
    from engine.bus import EmbeddedBus
    from engine.durations import Durations
    from engine.energy import EnergyModel
    from engine.geometry import Point
    from engine.plant import Plant
    from engine.policies import Policy


class Moving(Protocol):
    """A robot's drive under way (`engine.robots.mobility.Motion`)."""

    @property
    def speed(self) -> float: ...


class Body(RobotState, Powered, Protocol):
    """A robot as the mission holds it (`engine.robots.base.Robot`): what the baselines
    (`GlobalView`), the energy model, the radio, the metrics and the robots beside it read
    of it. The context names no robot class, so the robots sit above it."""

    rtype: str
    alive: bool

    @property
    def speed(self) -> float: ...
    @property
    def motion(self) -> Moving | None: ...
    @property
    def current(self) -> HeldTask | None: ...
    @property
    def mobility(self) -> Whereabouts: ...
    @property
    def distance(self) -> float: ...
    def state_times(self) -> dict[str, float]: ...
    def wake(self) -> None: ...


class Believer(Protocol):
    """What the radio reads of a robot to judge a silent peer (`engine.robots.base.Robot`)."""

    name: str

    @property
    def down(self) -> Set[str]: ...
    @property
    def mobility(self) -> Located: ...


class RadioRange(Protocol):
    """Radio range as the robots and the metrics read it (`engine.radio.RadioNet`)."""

    def in_contact(self, name: str) -> bool: ...
    def contact_point(self, p: Point) -> Point: ...
    def presumed_out_of_reach(self, robot: Believer, peer: str, now: float) -> bool: ...
    def metrics(self) -> dict[str, Any]: ...


class MissionContext:
    def __init__(
        self,
        scenario: Scenario,
        world: World,
        planner: PathPlanner,
        env: simpy.Environment,
        policy: Policy | None = None,
    ) -> None:
        self.scenario = scenario
        self.world = world
        self.planner = planner
        self.env = env
        self.policy: Policy  # set by its creator (a baseline's global view is this context)
        if policy is not None:
            self.policy = policy
        self.observer = Observer(lambda: float(env.now))
        self.bus: EmbeddedBus  # set by the mission once the bus exists
        self.liveness = Liveness()
        self.robots: dict[str, Body] = {}
        self.terrain = Terrain(world, env, self.observer)
        # the realism options (docs/model.md): None while off, so the reference model pays nothing
        self.durations: Durations | None = None
        self.docks: Plant | None = None
        self.energy: EnergyModel | None = None
        self.radio: RadioRange | None = None

    # --- what an auctioneer needs (engine.auction_ports.AuctionPorts) ----------------------
    @property
    def protocol(self) -> ProtocolSettings:
        return self.scenario.protocol

    def publish(self, msg: Message) -> None:
        self.bus.publish(msg)

    def emit(self, kind: str, /, **data: Any) -> None:
        self.observer.emit(kind, **data)

    def new_auction(
        self,
        auctioneer: str,
        kind: str,
        task_type: TaskType,
        location: Location,
        task_id: str,
        search_path: tuple[Location, ...],
        reauction_of: str | None,
    ) -> AuctionRecord:
        return self.observer.new_auction(
            auctioneer,
            kind,
            task_type,
            location,
            task_id,
            search_path,
            reauction_of,
            policy=self.policy.name,
        )

    def close_auction(self, rec: AuctionRecord, status: str, winner: str | None) -> None:
        self.observer.close_auction(rec, status, winner)

    def note_decline(self, rec: AuctionRecord, winner: str, outcome: str) -> None:
        self.observer.note_decline(rec, winner, outcome)

    def oracle_rank(
        self, rec: AuctionRecord, bids: Mapping[str, float], excluded: Set[str]
    ) -> list[str] | None:
        policy = self.policy
        oracle = policy.allocator()
        return None if oracle is None else oracle.rank(policy.global_view, rec, bids, excluded)

    def break_tie(self, rec: AuctionRecord, tied: Sequence[str]) -> str:
        return self.policy.break_tie(rec, tied)

    def road_to_plant(self, start: Location) -> tuple[Location, ...]:
        """The planned road from here to the plant (empty if there is none)."""
        try:
            return self.planner.plan(start, self.world.plant)
        except PlanningError:
            return ()

    # --- across the terrain and the robots ---------------------------------------------------
    def minerals_in(self) -> dict[str, int]:
        """Where every mineral is now; the sum is always the total (conservation)."""
        terrain = self.terrain
        buckets = sum(getattr(r, "bucket", 0) for r in self.robots.values())
        bins = sum(getattr(r, "bin", 0) for r in self.robots.values())
        return {
            "sites": sum(s.remaining for s in terrain.sites),
            "buckets": buckets,
            "bins": bins,
            "ground": len(terrain.ground),
            "delivered": terrain.delivered,
        }
