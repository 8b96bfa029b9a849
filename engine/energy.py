"""Energy (docs/model.md#energy): every robot's battery, what driving and work draw from it,
charging, and the feasibility test every bid and award passes.

A battery's level changes at a constant rate between two changes of the robot's state or
motion: driving draws `drive_kj_per_m` × speed, work (digging, a transfer, unloading,
scanning) draws `work_kw`, charging adds `charge_kw`, anything else (idle, waiting, queued)
draws nothing. At each change the level is settled and, while it falls, a watch is set for
the moment it would reach zero: a robot still drawing then stops where it is, a failure like
any other (the protocol's recovery rules take it from there).

A task is feasible for a robot if its estimate of the task's energy, plus the drive from the
task's end to the nearest charger, leaves the reserve untouched. Estimates use straight lines
times `detour` and mean work durations (times 1 + 2·cv under uncertain work): a robot knows its
battery and the map, not the future.
"""

from __future__ import annotations

import math
from collections.abc import Sized
from typing import TYPE_CHECKING, Protocol

from engine.geometry import Point, dist
from engine.realism import Battery as BatterySpec
from engine.realism import Energy

if TYPE_CHECKING:
    import simpy

    from engine.scenario import Scenario
    from engine.world import World

WORK_STATES = frozenset({"digging", "loading", "unloading", "scanning"})


class _Moving(Protocol):
    @property
    def speed(self) -> float: ...


class Located(Protocol):
    def position(self, t: float | None = None) -> tuple[Point, float]: ...


class _Spell(Protocol):
    @property
    def since(self) -> float: ...


class Powered(Protocol):
    """What the energy model reads of a robot (`engine.robots.base.Robot`)."""

    rtype: str
    battery: Battery | None
    alive: bool

    @property
    def timed(self) -> _Spell: ...

    @property
    def queue(self) -> Sized: ...

    @property
    def state(self) -> str: ...
    @property
    def motion(self) -> _Moving | None: ...
    @property
    def current(self) -> object | None: ...
    @property
    def pos(self) -> Point: ...
    @property
    def speed(self) -> float: ...
    @property
    def mobility(self) -> Located: ...
    def run_dry(self) -> None: ...


class Battery:
    """One robot's battery: the level settled at `since`, and the rate it changes at now."""

    __slots__ = ("_watch", "charging_s", "level", "must_charge", "rate", "since", "spec", "used")

    def __init__(self, spec: BatterySpec, now: float) -> None:
        self.spec = spec
        self.level = spec.capacity_kj
        self.rate = 0.0  # kW drawn (negative: charging)
        self.since = now
        self.used = 0.0
        self.charging_s = 0.0
        self.must_charge = False  # a task was out of reach: charge before taking another
        self._watch = 0

    @property
    def capacity(self) -> float:
        return self.spec.capacity_kj

    def settle(self, now: float) -> None:
        dt = now - self.since
        if dt > 0.0 and self.rate != 0.0:
            drawn = self.rate * dt
            if drawn > 0.0:
                self.used += min(drawn, self.level)
            self.level = min(self.capacity, max(0.0, self.level - drawn))
        self.since = now

    def level_at(self, now: float) -> float:
        drawn = self.rate * max(0.0, now - self.since)
        return min(self.capacity, max(0.0, self.level - drawn))

    def fraction(self, now: float) -> float:
        return self.level_at(now) / self.capacity


class EnergyModel:
    def __init__(self, cfg: Energy, scenario: Scenario, world: World, env: simpy.Environment):
        self.cfg = cfg
        self.env = env
        self.plant = plant = world.plant
        # a charger a random crater happens to cover is out of service for the run
        usable = [(float(x), float(y)) for x, y in cfg.chargers if world.is_free(x, y)]
        self.chargers: tuple[Point, ...] = (plant, *usable)
        unc = scenario.uncertainty
        self.margin = 1.0 + 2.0 * unc.work_cv if unc.enabled else 1.0
        t = scenario.timing
        self.dig_s, self.transfer_s, self.unload_s = t.dig_s, t.transfer_s, t.unload_s
        self.ran_dry = 0
        self.charges = 0

    def battery(self, rtype: str) -> Battery | None:
        spec = getattr(self.cfg, rtype, None)
        return Battery(spec, float(self.env.now)) if isinstance(spec, BatterySpec) else None

    # --- the level over time -------------------------------------------------------------
    def update(self, robot: Powered) -> None:
        """The robot's state or motion changed: settle its battery, set the new rate, and
        watch for the moment it would run dry."""
        bat = robot.battery
        assert bat is not None
        now = float(self.env.now)
        bat.settle(now)
        spec = bat.spec
        state = robot.state
        if state == "charging":
            rate = -self.cfg.charge_kw
        else:
            m = robot.motion
            rate = spec.drive_kj_per_m * m.speed if m is not None else 0.0
            if state in WORK_STATES and (state == "scanning" or m is None):
                rate += spec.work_kw
        bat.rate = rate
        bat._watch += 1
        if rate > 0.0 and robot.alive:
            token = bat._watch
            ev = self.env.timeout(bat.level / rate)
            ev.callbacks.append(lambda _e: self._dry(robot, token))

    def _dry(self, robot: Powered, token: int) -> None:
        bat = robot.battery
        if bat is None or bat._watch != token or not robot.alive:
            return
        bat.settle(float(self.env.now))
        bat.level = 0.0
        self.ran_dry += 1
        robot.run_dry()

    # --- estimates ----------------------------------------------------------------------
    def nearest_charger(self, p: Point) -> Point:
        return min(self.chargers, key=lambda c: (dist(p, c), c))

    def drive_kj(self, spec: BatterySpec, a: Point, b: Point) -> float:
        return dist(a, b) * self.cfg.detour * spec.drive_kj_per_m

    def work_kj(self, spec: BatterySpec, seconds: float) -> float:
        return spec.work_kw * seconds * self.margin

    def task_kj(self, spec: BatterySpec, task_type: str, start: Point, where: Point) -> float:
        """Energy to drive to a task, do it and reach a charger afterwards."""
        drive = self.drive_kj(spec, start, where)
        if task_type == "transport":  # load, carry to the plant (a charger), unload
            return (
                drive
                + self.work_kj(spec, self.transfer_s + self.unload_s)
                + self.drive_kj(spec, where, self.plant)
            )
        # excavate: at least one bucket, then to the nearest charger
        return (
            drive
            + self.work_kj(spec, self.dig_s + self.transfer_s)
            + self.drive_kj(spec, where, self.nearest_charger(where))
        )

    def spare(self, bat: Battery) -> float:
        """What the battery holds now beyond the reserve."""
        return bat.level_at(float(self.env.now)) - self.cfg.reserve * bat.capacity

    def feasible(self, robot: Powered, task_type: str, where: Point) -> bool:
        """Can the robot take this task (from where it is, or, if it already holds tasks,
        from a charger with a full battery: it charges before starting it if it must)?"""
        bat = robot.battery
        assert bat is not None
        if robot.current is not None or robot.queue:
            start = self.nearest_charger(where)
            full = bat.capacity * (1.0 - self.cfg.reserve)
            return self.task_kj(bat.spec, task_type, start, where) <= full
        here = robot.mobility.position()[0]
        return self.task_kj(bat.spec, task_type, here, where) <= self.spare(bat)

    def can_start(self, robot: Powered, task_type: str, where: Point) -> bool:
        bat = robot.battery
        assert bat is not None
        return self.task_kj(bat.spec, task_type, robot.pos, where) <= self.spare(bat)

    def can_dig_one_more(self, robot: Powered, site: Point) -> bool:
        bat = robot.battery
        assert bat is not None
        spec = bat.spec
        need = self.work_kj(spec, self.dig_s + self.transfer_s) + self.drive_kj(
            spec, site, self.nearest_charger(site)
        )
        return need <= self.spare(bat)

    def can_drive(self, robot: Powered, length: float, goal: Point, per_s: float = 0.0) -> bool:
        """Enough to drive `length` metres (drawing `per_s` kW more while at it) and then
        reach the nearest charger from the goal?"""
        bat = robot.battery
        assert bat is not None
        spec = bat.spec
        need = length * (spec.drive_kj_per_m + per_s / robot.speed) + self.drive_kj(
            spec, goal, self.nearest_charger(goal)
        )
        return need <= self.spare(bat)

    def charge_s(self, bat: Battery) -> float:
        """Seconds at a charger to fill the battery from its level now."""
        return max(0.0, bat.capacity - bat.level_at(float(self.env.now))) / self.cfg.charge_kw

    def metrics(self, robots: list[Powered]) -> dict[str, object]:
        now = float(self.env.now)
        used: dict[str, float] = {}
        charging: dict[str, float] = {}
        for r in robots:
            bat = r.battery
            if bat is None:
                continue
            bat.settle(now)
            used[r.rtype] = used.get(r.rtype, 0.0) + bat.used
            extra = now - r.timed.since if r.state == "charging" else 0.0
            charging[r.rtype] = charging.get(r.rtype, 0.0) + bat.charging_s + extra
        return {
            "energy_used_kj": used,
            "energy_used_total_kj": math.fsum(used.values()),
            "charging_s": charging,
            "charges": self.charges,
            "ran_dry": self.ran_dry,
        }
