"""The excavator's transport desk: the transports it auctions for its minerals (ahead of
the bucket under a lead policy, for a full bucket, for a mineral lying where it stands),
their task ids, and, with radio range on, reporting in when nobody hears one.

Out of range of the base station an excavator's transport auction may reach no idle hauler;
it then drives into reach with the full bucket until a hauler wins the transport
(docs/model.md#radio-range), and back to the site, where the winner waits for it.
"""

from __future__ import annotations

import contextlib
import math
from typing import TYPE_CHECKING, Any, Protocol

from engine.energy import Powered
from engine.geometry import Point, dist, path_length
from engine.planning import PlanningError
from engine.terrain import NEAR

if TYPE_CHECKING:
    from engine.auction_house import AuctionHouse
    from engine.context import MissionContext
    from engine.robots.charging import Charging
    from engine.robots.core import Assignment
    from engine.robots.mobility import Mobility
    from engine.robots.recovery import Recovery
    from engine.terrain import SiteState


class TransportingRobot(Powered, Protocol):
    """What the transport desk needs of its excavator: its auction house, the transports of
    its pile (`ahead`, next mineral first; `waiting_for`, the one for the full bucket)."""

    name: str
    ctx: MissionContext
    house: AuctionHouse
    mobility: Mobility
    charging: Charging | None
    recovery: Recovery
    ahead: list[str]
    waiting_for: str | None

    @property
    def state(self) -> str: ...
    @state.setter
    def state(self, value: str) -> None: ...
    def spawn(self, gen: Any) -> None: ...


class Transports:
    """What an excavator does as the auctioneer of its minerals' transports."""

    def __init__(self, robot: TransportingRobot) -> None:
        self.robot = robot
        self.name = robot.name
        self.ctx = robot.ctx
        self.env = robot.ctx.env
        self._serial = 0
        self._ground_serial = 0
        self._back_at = -math.inf  # radio range: when I last came back from reporting in

    def new_id(self, kind: str) -> str:
        """A task id never used before: `t` for a transport auctioned ahead, `r` for one
        offered again for a full bucket."""
        self._serial += 1
        return self.ctx.observer.of_this_life(f"{self.name}#{kind}{self._serial}")

    # --- ahead of the bucket (a lead policy) ----------------------------------------------
    def auction_ahead(self, site: SiteState | Point) -> None:
        where = site if isinstance(site, tuple) else (site.x, site.y)
        task_id = self.new_id("t")
        self.robot.ahead.append(task_id)
        self.robot.house.open("transport", where, task_id, kind="excavator_hauler")

    def auction_on_the_way(self, a: Assignment) -> None:
        """Under a transport lead, the first mineral's transport falls due while I drive to the
        site (a pile holds at least one): auction it then, so a hauler arrives about when I do."""
        robot = self.robot
        cfg = self.ctx.scenario
        dig_s = cfg.timing.dig_s
        haul_s = dist(a.location, self.ctx.world.plant) / cfg.speeds.hauler
        lead = self.ctx.policy.transport_lead_s(haul_s, dig_s)
        if lead <= 0.0 or robot.ahead:
            return
        try:
            drive_s = path_length(self.ctx.planner.plan(robot.pos, a.location)) / robot.speed
        except PlanningError:
            return
        due = drive_s + dig_s - lead
        if due <= 0.0:
            self.auction_ahead(a.location)
        else:
            robot.spawn(self._auction_when_due(a, due))

    def _auction_when_due(self, a: Assignment, due: float) -> Any:
        yield self.env.timeout(due)
        robot = self.robot
        if robot.current is a and robot.state == "travelling" and not robot.ahead:
            self.auction_ahead(a.location)

    def drop_ahead(self, early: dict[str, Any]) -> None:
        """Leaving the pile: transports not yet won are withdrawn (the won ones end void)."""
        for task_id in self.robot.ahead:
            self.robot.house.cancel_task(task_id)
        self.robot.ahead.clear()
        early.clear()

    # --- minerals on the ground -----------------------------------------------------------
    def auction_ground_minerals(self) -> None:
        """Minerals lying where I stand (a failed robot's) get a transport, unless one is known."""
        here = self.robot.pos
        for g in list(self.ctx.terrain.ground):
            if dist((g.x, g.y), here) > NEAR or self._known_at((g.x, g.y)):
                continue
            self._ground_serial += 1
            tid = self.ctx.observer.of_this_life(f"{self.name}#g{self._ground_serial}")
            self.robot.house.open("transport", (g.x, g.y), tid, kind="excavator_hauler")

    def _known_at(self, p: Point) -> bool:
        """Is a transport for a mineral lying here already offered or under way? My own pile's
        transports do not count (they are for what I dig), nor is old news about peers
        believed: their auctions must be fresh, their winners must still list the task."""
        robot = self.robot
        house, peers = robot.house, robot.recovery.peer_duties
        pile = {*robot.ahead, robot.waiting_for}
        board = self.ctx.liveness
        known = [(r.task_type, r.location) for r in house.open_records() if r.task_id not in pile]
        known += [(a.task_type, a.location) for a in house.watches if a.task_id not in pile]
        for allocs in peers.peer_alloc.values():
            for a in allocs.values():
                hb = board.last_heartbeat(self.name, a.winner)
                if hb is not None and a.task_id in hb.tasks:
                    known.append((a.task_type, a.location))
        known += [
            (a.task_type, a.location)
            for peer in peers.peer_open
            for a in peers.peer_open[peer].values()
            if peers.peer_handles(a.task_id)
        ]
        return any(t == "transport" and dist(loc, p) <= NEAR for t, loc in known)

    # --- radio range: a transport nobody hears ---------------------------------------------
    def unheard(self, task_id: str) -> bool:
        """Is this transport's auction open, unwon, for longer than two retry intervals,
        while I am out of the base station's reach (so, likely, of every idle hauler)?"""
        radio = self.ctx.radio
        assert radio is not None
        house = self.robot.house
        if task_id in house.watches or radio.in_contact(self.name):
            return False
        proto = self.ctx.scenario.protocol
        now = float(self.env.now)
        if now - self._back_at <= 2 * proto.retry_s:
            return False  # just back from reporting in: a hauler may be on its way
        return any(
            r.task_id == task_id and now - r.opened_at > 2 * proto.retry_s
            for r in house.open_records()
        )

    def report_in(self, site: SiteState, task_id: str) -> Any:
        """Drive into the base's reach with the full bucket until a hauler wins the
        transport (or a few retry intervals pass), then back to the site: the winner waits
        for me there."""
        robot = self.robot
        radio = self.ctx.radio
        assert radio is not None
        self.ctx.observer.emit("reporting_in", robot=self.name, task_id=task_id)
        spot, back = radio.contact_point(robot.pos), (site.x, site.y)
        energy = self.ctx.energy
        if energy is not None:
            there_and_back = (dist(robot.pos, spot) + dist(spot, back)) * energy.cfg.detour
            if not energy.can_drive(robot, there_and_back, back):
                assert robot.charging is not None  # (bucket and all; then report in from there)
                yield from robot.charging.recharge()
        robot.state = "travelling"
        with contextlib.suppress(PlanningError):
            yield from robot.mobility.go_to(spot)
        proto = self.ctx.scenario.protocol
        until = float(self.env.now) + 3 * proto.retry_s
        robot.state = "reporting"  # (not "waiting": a partner must not take this for a site)
        while (
            task_id not in robot.house.watches
            and robot.house.is_open(task_id)
            and self.env.now < until
        ):
            yield self.env.timeout(proto.bid_window_s)
        robot.state = "travelling"
        yield from robot.mobility.go_to(back)
        self._back_at = float(self.env.now)
