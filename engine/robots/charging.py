"""A robot's battery (engine/energy.py; only with the scenario's energy section on): when to
charge, the trip to a charger, and whether a task or a trip leaves enough to get back.

A bidder's concern, since a robot that could not finish a task and still reach a charger
bids -inf for it (`energy_allows`) and bids again once charged.
"""

from __future__ import annotations

from typing import Any

from engine.field import NEAR
from engine.geometry import dist
from engine.planning import PlanningError
from engine.robots.bidder import Bidder


class Charging(Bidder):
    """The battery side of a robot: charge when a task is out of reach, drive to charge."""

    def needs_charge(self) -> bool:
        """A task was out of reach, or the next one I hold is: charge before going on."""
        bat, energy = self.battery, self.ctx.energy
        assert bat is not None and energy is not None
        if not bat.must_charge and self.queue:
            nxt = self.queue[0]
            bat.must_charge = not energy.can_start(self, nxt.task_type, nxt.location)
        return bat.must_charge

    def recharge(self) -> Any:
        """Drive to the nearest charger and fill the battery; bid again afterwards."""
        bat, energy = self.battery, self.ctx.energy
        assert bat is not None and energy is not None
        charger = energy.nearest_charger(self.pos)
        if dist(self.pos, charger) > NEAR:
            self.state = "travelling"
            try:
                yield from self.go_to(charger)
            except PlanningError:
                if charger == energy.plant:
                    raise
                yield from self.go_to(energy.plant)
        self.state = "charging"
        t0 = float(self.env.now)
        self.ctx.observer.emit("charge_started", robot=self.name, level_kj=bat.level_at(t0))
        try:
            yield self.env.timeout(energy.charge_s(bat))
            bat.settle(float(self.env.now))
            bat.level = bat.capacity
            bat.must_charge = False
            energy.charges += 1
            self.state = "idle"
            self.ctx.observer.emit("charged", robot=self.name)
        finally:
            bat.charging_s += float(self.env.now) - t0
        self._bid_situation = ()
        self.consider_bids()

    def energy_for_trip(self, goal: tuple[float, float]) -> bool:
        """Energy to drive there and on to a charger? If not, I charge first."""
        bat, energy = self.battery, self.ctx.energy
        assert bat is not None and energy is not None
        length = dist(self.pos, goal) * energy.cfg.detour
        if energy.can_drive(self, length, goal) or bat.level_at(self.env.now) >= bat.capacity:
            return True
        bat.must_charge = True
        return False

    def energy_allows(self, task_type: str, where: tuple[float, float]) -> bool:
        """Could I do this task and still reach a charger? If not, I go to charge."""
        energy = self.ctx.energy
        if energy is None or energy.feasible(self, task_type, where):
            return True
        bat = self.battery
        assert bat is not None
        if not bat.must_charge and bat.level_at(float(self.env.now)) < bat.capacity:
            bat.must_charge = True  # (full and still out of reach: charging would not help)
            self.wake()
        return False
