"""Path planning behind one small interface: OMPL's RRT-Connect for real runs, a straight line
for unit tests.

Bid costs and driven paths come from the same planner, so a bid is the honest length of
the path the robot would drive. A collision-free straight segment is returned directly (it is
the shortest path; RRT-Connect plus simplification converges to it anyway), and repeated
queries are cached per run.
"""

from __future__ import annotations

import itertools
import threading
from collections import OrderedDict
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any, Protocol

import numpy as np
import numpy.typing as npt

from engine.geometry import Point
from engine.world import World

Path = tuple[Point, ...]


class PlanningError(RuntimeError):
    """No collision-free path was found."""


@dataclass
class PlannerStats:
    queries: int = 0
    straight: int = 0
    cached: int = 0
    ompl_queries: int = 0


class PathPlanner(Protocol):
    stats: PlannerStats

    def plan(self, start: Point, goal: Point) -> Path: ...

    def close(self) -> None: ...


class StraightLinePlanner:
    """Straight lines, for worlds without obstacles and fast unit tests."""

    def __init__(self) -> None:
        self.stats = PlannerStats()

    def plan(self, start: Point, goal: Point) -> Path:
        self.stats.queries += 1
        self.stats.straight += 1
        return (start, goal)

    def close(self) -> None:
        pass


Packed = npt.NDArray[np.float64]
"""A path kept in a planner's cache: its points as rows of floats, 16 bytes a point instead of
the ~120 of a tuple of two Python floats (scale 100 keeps 16,384 paths of ~30 points)."""


def pack(path: Path) -> Packed:
    return np.array(path, dtype=np.float64)


def unpack(packed: Packed) -> Path:
    """The path as it was packed: the same floats, as tuples (every point of an engine path
    is floats already: pydantic makes every location of a scenario or a message a float)."""
    return tuple((x, y) for x, y in packed.tolist())


class ShortcutPlanner:
    """What every obstacle-aware planner shares: a collision-free straight segment is the
    answer (it is the shortest path), and a repeated query is answered from a per-run cache;
    a subclass solves the rest (`_solve`).

    `cache_limit`: the solved paths kept (None: all). Only a planner whose answer is a
    function of the query alone may forget one: a random planner's repeated query must get
    the path it got the first time."""

    cache_limit: int | None = None

    def __init__(self, world: World) -> None:
        self.stats = PlannerStats()
        self._index = world.index
        self._cache: OrderedDict[tuple[Point, Point], Packed] = OrderedDict()

    def plan(self, start: Point, goal: Point) -> Path:
        self.stats.queries += 1
        key = (start, goal)
        cache = self._cache
        hit = cache.get(key)
        if hit is not None:  # solved before, so not straight: no need to test the segment
            self.stats.cached += 1
            if self.cache_limit is not None:
                cache.move_to_end(key)
            return unpack(hit)
        if self._index.segment_free(start, goal):
            self.stats.straight += 1
            return (start, goal)
        path = self._solve(start, goal)
        cache[key] = pack(path)
        if self.cache_limit is not None and len(cache) > self.cache_limit:
            cache.popitem(last=False)
        return path

    def _solve(self, start: Point, goal: Point) -> Path:
        raise NotImplementedError


CHECKS = 2500
"""Termination checks RRT-Connect may make per attempt (×1, ×2, ×3, ×4 over four attempts).

A count, not a time limit, so a query gives the same path however loaded the machine is (a
wall-clock limit made a run differ when the process stalled mid-query). Queries in the
reference scenario need at most ~80 checks; 2,500 is about the 50 ms limit used before.
"""


class OmplPlanner(ShortcutPlanner):
    """RRT-Connect over the world's craters, with an exact segment-vs-circle motion check."""

    def __init__(self, world: World, rng: np.random.Generator, checks: int = CHECKS) -> None:
        from ompl import base as ob
        from ompl import geometric as og
        from ompl import util as ou

        ou.setLogLevel(ou.LogLevel.LOG_NONE)
        super().__init__(world)
        self._rng = rng
        self._checks = checks
        self._ob = ob
        self._ou = ou
        index = self._index

        class ExactMotion(ob.MotionValidator):  # type: ignore[misc]
            def checkMotion(self, s1: Any, s2: Any, *rest: Any) -> bool:
                return index.segment_free((s1[0], s1[1]), (s2[0], s2[1]))

        space = ob.RealVectorStateSpace(2)
        bounds = ob.RealVectorBounds(2)
        bounds.setLow(0, 0.0)
        bounds.setHigh(0, world.width)
        bounds.setLow(1, 0.0)
        bounds.setHigh(1, world.height)
        space.setBounds(bounds)
        ss = og.SimpleSetup(space)
        si = ss.getSpaceInformation()
        ss.setStateValidityChecker(lambda s: index.point_free(s[0], s[1]))
        self._motion = ExactMotion(si)
        si.setMotionValidator(self._motion)
        ss.setPlanner(og.RRTConnect(si))
        ss.setup()
        self._space, self._ss = space, ss

    def _solve(self, start: Point, goal: Point) -> Path:
        ss, space = self._ss, self._space
        for attempt in range(4):
            seed = int(self._rng.integers(1, 2**31 - 1))
            with _SEEDED_SOLVE:
                self._ou.RNG.setSeed(seed)
                ss.clear()
                st, gl = space.allocState(), space.allocState()
                st[0], st[1] = start
                gl[0], gl[1] = goal
                ss.setStartAndGoalStates(st, gl)
                budget = self._checks * (attempt + 1)
                ptc = self._ob.PlannerTerminationCondition(_countdown(budget))
                ss.solve(ptc)
                del ptc
                solved = ss.haveExactSolutionPath()
                if solved:
                    ss.simplifySolution()
                    geo = ss.getSolutionPath()
                    pts = tuple((float(s[0]), float(s[1])) for s in geo.getStates())
                    del geo
            self.stats.ompl_queries += 1
            if solved and len(pts) >= 2:
                return (start, *pts[1:-1], goal)
        raise PlanningError(f"no path from {start} to {goal}")

    def close(self) -> None:
        """Release OMPL objects now rather than at interpreter exit."""
        self.__dict__.pop("_ss", None)
        self.__dict__.pop("_motion", None)
        self.__dict__.pop("_space", None)


_SEEDED_SOLVE = threading.Lock()
"""OMPL's random generator is one per process and `RNG.setSeed` sets it for all: a solve must
run from its seed to its path with no other thread's solve in between, or two engines in one
process (the service steps live missions on one thread and replays playback on others)
would draw from each other's sequence and stop being reproducible."""


def _countdown(budget: int) -> Callable[[], bool]:
    """A termination condition that says stop on its (budget + 1)-th question."""
    asked = itertools.count(1)
    return lambda: next(asked) > budget
