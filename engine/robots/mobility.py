"""A robot's mobility part: where it stands, the path it drives and at what speed, how far
it has come, and how long its work takes (a seeded draw under uncertain work)."""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING, Any, Protocol

from engine.geometry import Point, path_length, point_along, remaining_path
from engine.planning import Path

if TYPE_CHECKING:
    import simpy

    from engine.context import MissionContext


@dataclass(slots=True)
class Motion:
    t0: float
    path: Path
    length: float
    speed: float


class Mover(Protocol):
    """What the mobility part needs of its robot."""

    ctx: MissionContext

    def motion_changed(self) -> None:
        """The robot set off or stopped (the draw on its battery may have changed)."""
        ...

    def heartbeat(self) -> None: ...


class Mobility:
    """Position, heading and motion along a planned path, on the simulation clock."""

    def __init__(self, robot: Mover, pos: Point, speed: float) -> None:
        self.robot = robot
        self.ctx = robot.ctx
        self.env: simpy.Environment = robot.ctx.env
        self.pos = pos
        self.heading = 0.0
        self.speed = speed
        self.distance = 0.0
        self.motion: Motion | None = None

    def position(self, t: float | None = None) -> tuple[Point, float]:
        m = self.motion
        if m is None:
            return self.pos, self.heading
        t = self.env.now if t is None else t
        return point_along(m.path, min(m.length, max(0.0, (t - m.t0) * m.speed)))

    def remaining_route(self) -> list[Point]:
        m = self.motion
        if m is None:
            return []
        return remaining_path(m.path, min(m.length, (self.env.now - m.t0) * m.speed))

    def drive(self, path: Path, report: bool = False) -> Any:
        """Drive along a path at this robot's speed; interruptible only by failure. With
        `report`, a heartbeat goes out as it sets off, saying where it is going (a hauler with
        a mineral: if it fails on the way, its watcher searches that very route)."""
        length = path_length(path)
        if length <= 0.0:
            self.pos = path[-1]
            return
        speed = self.leg_speed()
        self.set_off(path, length, speed)
        if report:
            self.robot.heartbeat()
        yield self.env.timeout(length / speed)
        self.stop(length)

    def set_off(self, path: Path, length: float, speed: float) -> None:
        """Start along a path of this length at this speed (the caller times the drive)."""
        self.motion = Motion(float(self.env.now), path, length, speed)
        self.robot.motion_changed()

    def leg_speed(self) -> float:
        """This leg's speed: the nominal one, or a seeded draw under uncertain work."""
        d = self.ctx.durations
        return self.speed if d is None else d.leg_speed(self.speed)

    def work_s(self, mean: float) -> float:
        """How long a piece of work (dig, transfer, unload) of this mean duration takes."""
        d = self.ctx.durations
        return mean if d is None else d.work(mean)

    def stop(self, travelled: float | None = None) -> None:
        """Stop where the motion has brought the robot (`travelled`: metres along its path)."""
        m = self.motion
        if m is None:
            return
        if travelled is None:
            travelled = min(m.length, (self.env.now - m.t0) * m.speed)
        self.pos, self.heading = point_along(m.path, travelled)
        self.distance += travelled
        self.motion = None
        self.robot.motion_changed()

    def go_to(self, goal: Point) -> Any:
        yield from self.drive(self.ctx.planner.plan(self.pos, goal))
