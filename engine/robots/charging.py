"""A robot's charging part (engine/energy.py; it acts only with the scenario's energy section
on): when to charge, the trip to a charger, and whether a task or a trip leaves enough to get
back. A robot that could not finish a task and still reach a charger bids -inf for it
(`allows`) and bids again once charged. The operator's console has no battery and no such
part."""

from __future__ import annotations

from collections import deque
from typing import TYPE_CHECKING, Any, Protocol

from engine.energy import Powered
from engine.geometry import Point, dist
from engine.planning import PlanningError
from engine.terrain import NEAR

if TYPE_CHECKING:
    from engine.context import MissionContext
    from engine.energy import Battery
    from engine.robots.core import Assignment
    from engine.robots.mobility import Mobility


class ChargingRobot(Powered, Protocol):
    """What the charging part needs of its robot (and the energy model reads of it)."""

    name: str
    ctx: MissionContext
    battery: Battery | None
    mobility: Mobility

    @property
    def queue(self) -> deque[Assignment]: ...
    @property
    def state(self) -> str: ...
    @state.setter
    def state(self, value: str) -> None: ...
    def stir(self) -> None: ...

    @property
    def bidder(self) -> _Rebidder | None: ...
    def wake(self) -> None: ...


class _Rebidder(Protocol):
    def look_afresh(self) -> None:
        """Bid again from scratch (charged: my time bids change)."""
        ...


class Charging:
    """The battery side of a robot: charge when a task is out of reach, drive to charge."""

    def __init__(self, robot: ChargingRobot) -> None:
        self.robot = robot
        self.ctx = robot.ctx
        self.env = robot.ctx.env

    def needs_charge(self) -> bool:
        """A task was out of reach, or the next one I hold is: charge before going on."""
        robot = self.robot
        bat, energy = robot.battery, self.ctx.energy
        assert bat is not None and energy is not None
        if not bat.must_charge and robot.queue:
            nxt = robot.queue[0]
            bat.must_charge = not energy.can_start(robot, nxt.task_type, nxt.location)
            self.robot.stir()
        return bat.must_charge

    def recharge(self) -> Any:
        """Drive to the nearest charger and fill the battery; bid again afterwards."""
        robot, body = self.robot, self.robot.mobility
        bat, energy = robot.battery, self.ctx.energy
        assert bat is not None and energy is not None
        charger = energy.nearest_charger(body.pos)
        if dist(body.pos, charger) > NEAR:
            robot.state = "travelling"
            try:
                yield from body.go_to(charger)
            except PlanningError:
                if charger == energy.plant:
                    raise
                yield from body.go_to(energy.plant)
        robot.state = "charging"
        t0 = float(self.env.now)
        self.ctx.observer.emit("charge_started", robot=robot.name, level_kj=bat.level_at(t0))
        try:
            yield self.env.timeout(energy.charge_s(bat))
            bat.settle(float(self.env.now))
            bat.level = bat.capacity
            bat.must_charge = False
            self.robot.stir()
            energy.charges += 1
            robot.state = "idle"
            self.ctx.observer.emit("charged", robot=robot.name)
        finally:
            bat.charging_s += float(self.env.now) - t0
        if robot.bidder is not None:
            robot.bidder.look_afresh()

    def trip_allowed(self, goal: Point) -> bool:
        """Energy to drive there and on to a charger? If not, I charge first."""
        robot = self.robot
        bat, energy = robot.battery, self.ctx.energy
        assert bat is not None and energy is not None
        length = dist(robot.mobility.pos, goal) * energy.cfg.detour
        if energy.can_drive(robot, length, goal) or bat.level_at(self.env.now) >= bat.capacity:
            return True
        bat.must_charge = True
        self.robot.stir()
        return False

    def allows(self, task_type: str, where: Point) -> bool:
        """Could I do this task and still reach a charger? If not, I go to charge."""
        energy = self.ctx.energy
        if energy is None or energy.feasible(self.robot, task_type, where):
            return True
        bat = self.robot.battery
        assert bat is not None
        if not bat.must_charge and bat.level_at(float(self.env.now)) < bat.capacity:
            bat.must_charge = True  # (full and still out of reach: charging would not help)
            self.robot.stir()
            self.robot.wake()
        return False

    def bucket_allowed(self, site: Point) -> bool:
        """Energy for one more dig and transfer and the drive to a charger? If not, the site
        is released (offered again) and I go to charge."""
        energy = self.ctx.energy
        if energy is None or energy.can_dig_one_more(self.robot, site):
            return True
        assert self.robot.battery is not None
        self.robot.battery.must_charge = True
        self.robot.stir()
        return False
