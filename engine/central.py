"""The centralized baseline: a greedy central allocator with global state.

Every auction still runs on the bus (announce, bids, award, acknowledgement, close), with the
same robots and the same physics, so its figures compare with the decentralized policies'.
Only the award differs: instead of ranking the bids it received, the auctioneer asks a central
unit that reads the true state of the whole mission — every robot's true position and whether
it is free, every open auction of every auctioneer — and assigns the open tasks to the robots
free right now so as to minimise their summed travel time along true planned paths (the
Hungarian method, `scipy.optimize.linear_sum_assignment`). The auction goes to the robot that
assignment gives it, or waits if it gives it none.

The assignment is optimal only for that instant: it is myopic (it never waits for a robot
about to be free, never plans a sequence of tasks), so it is a greedy heuristic with global
knowledge, not an optimal allocation. Decision points are the moments an auction asks for its
winner: the end of its bid window, a late finite bid (a robot became free), and each
re-announcement. No robot could know what it reads; it is a yardstick, not a design.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Set
from typing import TYPE_CHECKING, Protocol

import numpy as np
from scipy.optimize import linear_sum_assignment  # type: ignore[import-untyped]

from engine.geometry import path_length
from engine.planning import PlanningError

if TYPE_CHECKING:
    from engine.auction_rules import AuctionRecord
    from engine.global_view import GlobalView, RobotState

FORBIDDEN = 1e12
"""Cost of a pairing the oracle must not choose (declined, or no path)."""


class Allocator(Protocol):
    """Decides an auction's award order in place of `rank_bids`."""

    def rank(
        self,
        ctx: GlobalView,
        rec: AuctionRecord,
        bids: Mapping[str, float],
        excluded: Set[str],
    ) -> list[str]: ...


def optimal_assignment(cost: np.ndarray) -> dict[int, int]:
    """Row → column of a minimum-cost assignment, leaving out forbidden pairings."""
    if cost.size == 0:
        return {}
    rows, cols = linear_sum_assignment(cost)
    return {int(r): int(c) for r, c in zip(rows, cols, strict=True) if cost[r, c] < FORBIDDEN}


class OracleAllocator:
    """Optimal assignment of every open task of a type to the free robots able to do it."""

    def rank(
        self,
        ctx: GlobalView,
        rec: AuctionRecord,
        bids: Mapping[str, float],
        excluded: Set[str],
    ) -> list[str]:
        tasks = [
            a
            for a in ctx.observer.auctions
            if a.status == "open" and a.task_type == rec.task_type and running(ctx, a)
        ]
        if rec not in tasks:
            return []
        promised = {
            a.awards[-1].winner
            for a in tasks
            if a is not rec and a.awards and a.awards[-1].outcome == "pending"
        }
        return assign_greedily(ctx, rec, tasks, promised, excluded)


def running(ctx: GlobalView, rec: AuctionRecord) -> bool:
    """Is the auction run now? A record stays open when its auctioneer fails until an
    auction naming it takes it over: no robot can be sent to it meanwhile. (The operator's
    console is no robot of the view, and never fails: its records are true.)"""
    auctioneer = ctx.robots.get(rec.auctioneer)
    return auctioneer is None or auctioneer.house.has_open(rec.id)


def assign_greedily(
    ctx: GlobalView,
    rec: AuctionRecord,
    tasks: list[AuctionRecord],
    promised: Set[str],
    excluded: Set[str],
) -> list[str]:
    """The robot a minimal-travel-time assignment of `tasks` to the robots free now (not
    promised elsewhere) gives `rec`, if any; `excluded` robots may not take `rec`."""
    robots = [
        r
        for name, r in sorted(ctx.robots.items())
        if r.capability == rec.task_type
        and r.bidder is not None
        and r.bidder.can_take()
        and name not in promised
    ]
    if not robots:
        return []
    cost = np.full((len(tasks), len(robots)), FORBIDDEN)
    for j, robot in enumerate(robots):
        for i, task in enumerate(tasks):
            if task is rec and robot.name in excluded:
                continue
            cost[i, j] = travel_s(ctx, robot, task.location)
    chosen = optimal_assignment(cost).get(tasks.index(rec))
    return [] if chosen is None else [robots[chosen].name]


def travel_s(ctx: GlobalView, robot: RobotState, goal: tuple[float, float]) -> float:
    """Time to drive from the robot's true position to the goal along the planned path."""
    try:
        length = path_length(ctx.planner.plan(robot.mobility.position()[0], goal))
    except PlanningError:
        return FORBIDDEN
    return length / robot.speed if math.isfinite(length) else FORBIDDEN
