"""What the policy asks a bidding robot (`engine.bidding.RobotView`): its pairing under
Policy 2, when and where it will be free, and what a task would cost it to reach: the
bidder's view for the policy, apart from its bookkeeping of auctions and bids."""

from __future__ import annotations

import math
from typing import TYPE_CHECKING, Protocol

from engine.bidding import OpenAuction
from engine.geometry import Point, path_length
from engine.planning import PlanningError

if TYPE_CHECKING:
    from engine.context import MissionContext
    from engine.robots.mobility import Mobility


class PeerWatch(Protocol):
    """What pricing reads of a robot's view of its peers (`Recovery`)."""

    def alive_until(self, name: str) -> float: ...


class PricedRobot(Protocol):
    """What pricing needs of its robot: where it is and the type's own answers."""

    mobility: Mobility
    partner: str | None

    @property
    def recovery(self) -> PeerWatch: ...

    def free_at(self) -> tuple[float, Point]: ...
    def paired(self) -> bool: ...
    def partner_working(self) -> bool: ...
    def transports_stranded(self) -> bool: ...


class Pricing:
    """The policy's view of a bidding robot; `Bidder` is one."""

    robot: PricedRobot
    ctx: MissionContext

    def paired(self) -> bool:
        return self.robot.paired()

    def has_partner(self) -> bool:
        return self.robot.partner is not None

    def partner_working(self) -> bool:
        return self.robot.partner_working()

    def paired_until(self) -> float:
        partner = self.robot.partner
        if partner is None or not self.ctx.policy.coalitions():
            return -math.inf
        return self.robot.recovery.alive_until(partner)

    def transports_stranded(self) -> bool:
        return self.robot.transports_stranded()

    def free_at(self) -> tuple[float, Point]:
        """When (seconds from now) and where this robot will be free, by its own estimate."""
        return self.robot.free_at()

    def eta_to(self, a: OpenAuction) -> float:
        """Seconds until this robot could stand at the task: finish what it holds, then drive."""
        wait, start = self.free_at()
        try:
            length = path_length(self.ctx.planner.plan(start, a.location))
        except PlanningError:
            return math.inf
        return wait + length / self.robot.mobility.speed

    def cost_to(self, a: OpenAuction) -> float:
        """Length of the path this robot would drive to the task (docs/spec.md §6.2); inf if
        there is none."""
        try:
            return path_length(self.ctx.planner.plan(self.robot.mobility.pos, a.location))
        except PlanningError:
            return math.inf
