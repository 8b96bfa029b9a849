"""The clairvoyant reference (`offline`): plan the whole mission, then carry the plan out.

At its first decision the allocator reads what no robot could know — every site's place and
pile, when the scouts' fixed spirals will find each one (predicted by driving their routes on
paper), every excavator's and hauler's position — and asks `engine.schedule.optimize` for a
schedule: each excavator's sites in order, each hauler's minerals in order. Then it carries
the schedule out in the same simulator, through the same auctions:

- an auction asks for its winner (`rank`): if the plan gives its task (a site, or a
  transport at a site) to a robot whose *next* planned task it is, that robot wins as soon
  as it has room; until then the auction waits. Tasks the plan does not cover (an injected
  task, a mineral on the ground, a transport offered again) go by central-greedy's rule
  among the robots with room;
- a robot with nothing to do drives to the site of its next planned task and waits there
  (`standby`): an excavator stands on a site before a scout has found it, and digs only once
  it is found and the auction is won, as the task chain requires (docs/spec.md §3).

**Repair.** When the team changes (a robot fails, is disabled, enabled or added) the plan is
made again from that moment, for the sites no excavator holds, with every robot's own
estimate of when it is free (`free_at`). A planned task still pending `PATIENCE_S` after its
planned time is dropped from the plan and goes by the greedy rule, so the plan can delay a
task but never hold it forever. A live switch to `offline` plans from the moment of the
switch in the same way.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence, Set
from dataclasses import dataclass
from typing import TYPE_CHECKING

from engine.central import assign_greedily, running
from engine.foresight import SnappingPlanner, legs, predict_found
from engine.geometry import Point, dist
from engine.schedule import Job, Problem, Schedule, Unit, optimize
from engine.terrain import NEAR

if TYPE_CHECKING:
    from engine.auction_rules import AuctionRecord
    from engine.bidding import OpenAuction
    from engine.global_view import GlobalView, RobotState

PATIENCE_S = 300.0
"""A planned task not handed out this long after its planned time leaves the plan."""
WORK = 3_000_000
"""Search effort: decodes × (minerals × haulers × excavators) stays under this, and under
`MAX_DECODES` (`REPAIR_DECODES` for a plan made again mid-mission) — counts, so the same
problem always gets the same schedule."""
MAX_DECODES = 1000
REPAIR_DECODES = 100
EXACT_SITES = 30
"""Up to this many sites every leg the schedule weighs is measured along the run planner's path;
beyond, a crater-blocked leg not to or from the plant is estimated at `DETOUR` × the straight
line (at scale 10 the ~20,000 legs would otherwise cost ~20 s of path planning)."""
DETOUR = 1.2


@dataclass(slots=True)
class Entry:
    """One planned task of one robot."""

    robot: str
    site: str
    pos: Point
    at: float  # planned time: an excavator's first dig, a hauler's transfer
    task: str  # excavate | transport
    k: int = 0  # a hauler's: the k-th transfer at the site
    state: str = "pending"  # pending | awarded | dropped
    auction: str | None = None  # the auction it was awarded in


class OfflineAllocator:
    """Plans once (and again when the team changes) and awards by the plan."""

    def __init__(self) -> None:
        self.plans: dict[str, list[Entry]] = {}
        self.roster: tuple[tuple[str, str], ...] | None = None
        self.bound: dict[str, Entry] = {}  # auction id → the entry awarded in it
        self.pending: dict[tuple[str, str], int] = {}  # (site, task type) → pending entries
        self._sites: dict[Point, str | None] = {}
        self.schedule: Schedule | None = None
        self.plans_made = 0

    # --- the auctioneer's question ---------------------------------------------------------
    def rank(
        self,
        ctx: GlobalView,
        rec: AuctionRecord,
        bids: Mapping[str, float],
        excluded: Set[str],
    ) -> list[str]:
        self._ensure(ctx)
        entry = self.bound.pop(rec.id, None)
        if entry is not None and entry.state == "awarded":
            self._set(entry, "pending")  # that award was declined or went unanswered
        site = self._site(ctx, rec.location)
        if site is not None:
            chosen = self._by_plan(ctx, rec, site, excluded)
            if chosen is not None:
                return chosen
        return self._greedy(ctx, rec, excluded)

    def standby(self, ctx: GlobalView, name: str) -> Point | None:
        """Where an idle robot should wait: the site of its next planned task."""
        self._ensure(ctx)
        for e in self.plans.get(name, ()):
            rec = ctx.observer.auctions_by_id.get(e.auction or "")
            if e.state == "awarded" and rec is not None and rec.status == "open":
                return e.pos  # awarded, not confirmed yet: stay for it
        nxt = self._next(ctx, name)
        return None if nxt is None else nxt.pos

    # --- executing the plan ----------------------------------------------------------------
    def _next(self, ctx: GlobalView, name: str) -> Entry | None:
        now = float(ctx.env.now)
        for e in self.plans.get(name, ()):
            if e.state != "pending":
                continue
            if now > e.at + PATIENCE_S:
                self._set(e, "dropped")
                continue
            return e
        return None

    def _by_plan(
        self, ctx: GlobalView, rec: AuctionRecord, site: str, excluded: Set[str]
    ) -> list[str] | None:
        """The planned robot ([] while it cannot take it yet); None: the plan has no such task."""
        ready: list[tuple[int, float, str, Entry]] = []
        # one hauler at a time comes for a pile's next bucket, in the planned order: at a pile
        # the first hauler to stand by gets the bucket, so a later one must not arrive first
        gated = rec.task_type == "transport" and _pickup_pending(ctx, rec)
        promised = _promised(ctx, rec)
        for name in sorted(self.plans):
            robot = ctx.robots.get(name)
            if robot is None or robot.capability != rec.task_type:
                continue
            nxt = self._next(ctx, name)
            if nxt is None or nxt.site != site:
                continue
            if gated:
                continue
            bidder = robot.bidder
            if (
                bidder is not None
                and bidder.can_take()
                and name not in excluded
                and name not in promised
            ):
                ready.append((nxt.k, nxt.at, name, nxt))
        if ready:
            _, _, name, entry = min(ready)
            self._set(entry, "awarded")
            entry.auction = rec.id
            self.bound[rec.id] = entry
            return [name]
        return [] if self.pending.get((site, rec.task_type), 0) else None

    def _greedy(self, ctx: GlobalView, rec: AuctionRecord, excluded: Set[str]) -> list[str]:
        """central-greedy's rule over the open tasks the plan does not cover, and that are run
        (attrition seed 45: a failed auctioneer's record, open until its adopter takes it
        over, drew the last hauler, and every auction really run waited for ever)."""
        tasks = [
            a
            for a in ctx.observer.auctions
            if a.status == "open"
            and a.task_type == rec.task_type
            and running(ctx, a)
            and not self._covers(ctx, a)
        ]
        if rec not in tasks:
            tasks.append(rec)
        promised = _promised(ctx, rec)
        return assign_greedily(ctx, rec, tasks, promised, excluded)

    def _covers(self, ctx: GlobalView, rec: AuctionRecord) -> bool:
        site = self._site(ctx, rec.location)
        return site is not None and self.pending.get((site, rec.task_type), 0) > 0

    def _set(self, e: Entry, state: str) -> None:
        key = (e.site, e.task)
        self.pending[key] = self.pending.get(key, 0) + (state == "pending") - (e.state == "pending")
        e.state = state

    def invited(
        self, ctx: GlobalView, name: str, auctions: Sequence[OpenAuction]
    ) -> list[OpenAuction]:
        """The auctions this robot should bid in: its next planned task's, and every one the
        plan does not cover (bids decide nothing here; they keep the records like the other
        policies' and wake an auction that waits). Its next task is looked up once, at the first
        auction the plan covers: a look drops the entries past their patience, so a second one
        at the same instant finds the same."""
        out: list[OpenAuction] = []
        looked, nxt = False, None
        for a in auctions:
            site = self._site(ctx, a.location)
            if site is not None and self.pending.get((site, a.task_type), 0):
                if not looked:
                    looked, nxt = True, self._next(ctx, name)
                if nxt is None or nxt.site != site:
                    continue
            out.append(a)
        return out

    def _site(self, ctx: GlobalView, p: Point) -> str | None:
        """The site at a task's place (auctions name a site by its exact coordinates)."""
        if p not in self._sites:
            site = ctx.terrain.site_at(p)
            self._sites[p] = None if site is None else site.id
        return self._sites[p]

    # --- planning --------------------------------------------------------------------------
    def _ensure(self, ctx: GlobalView) -> None:
        if not isinstance(ctx.planner, SnappingPlanner):
            ctx.planner = SnappingPlanner(ctx.planner, ctx)
        roster = tuple(
            (r.name, r.rtype)
            for r in sorted(ctx.robots.values(), key=lambda r: r.name)
            if r.rtype in ("excavator", "hauler") and r.participating
        )
        if roster != self.roster:
            self.roster = roster
            self._plan(ctx, "start" if self.plans_made == 0 else "team changed")

    def _plan(self, ctx: GlobalView, reason: str) -> None:
        problem = build_problem(ctx)
        minerals = sum(j.minerals for j in problem.jobs)
        size = max(1, minerals * len(problem.haulers) * max(1, min(len(problem.excavators), 8)))
        most = MAX_DECODES if self.plans_made == 0 else REPAIR_DECODES
        budget = max(1, min(most, WORK // size))
        sched = optimize(problem, budget)
        self.schedule = sched
        self.plans_made += 1
        self.bound.clear()
        sites = {j.key: j.pos for j in problem.jobs}
        plans: dict[str, list[Entry]] = {}
        for name, digs in sched.digs.items():
            plans[name] = [Entry(name, d.job, sites[d.job], d.start, "excavate") for d in digs]
        for name, hauls in sched.hauls.items():
            plans[name] = [
                Entry(name, h.job, sites[h.job], h.transfer, "transport", h.k) for h in hauls
            ]
        self.plans = plans
        self.pending = {}
        for entries in plans.values():
            for e in entries:
                self.pending[(e.site, e.task)] = self.pending.get((e.site, e.task), 0) + 1
        ctx.observer.emit(
            "offline_planned",
            reason=reason,
            sites=len(problem.jobs),
            minerals=sum(j.minerals for j in problem.jobs),
            makespan_s=sched.makespan if math.isfinite(sched.makespan) else None,
            decodes=sched.evaluations,
        )


def build_problem(ctx: GlobalView) -> Problem:
    """The work left, as the schedule sees it: sites no live excavator holds (found or not),
    and every participating excavator and hauler at the time and place it will be free."""
    now = float(ctx.env.now)
    cfg = ctx.scenario
    found = predict_found(ctx)
    latest = max([now, *found.values()])
    held: list[Point] = []
    for r in ctx.robots.values():
        if r.rtype == "excavator" and r.alive:
            held += [a.location for a in r.tasks_held()]
            reserved = None if r.bidder is None else r.bidder.reserved
            if reserved is not None:
                held.append(reserved.location)
    jobs = []
    for s in ctx.terrain.sites:
        if s.remaining <= 0 or (s.worker is not None and ctx.robots[s.worker].alive):
            continue
        if any(dist(p, (s.x, s.y)) <= NEAR for p in held):
            continue
        seen = s.found_at if s.found_at is not None else found.get(s.id, latest)
        jobs.append(Job(s.id, (s.x, s.y), s.remaining, max(now, seen) + cfg.protocol.bid_window_s))

    def unit(r: RobotState) -> Unit:
        assert r.bidder is not None
        wait, pos = r.bidder.free_at()
        return Unit(r.name, pos, now + wait)

    team = sorted((r for r in ctx.robots.values() if r.participating), key=lambda r: r.name)

    exact = len(jobs) <= EXACT_SITES
    plant = ctx.world.plant

    def leg(a: Point, b: Point) -> float:
        if exact or plant in (a, b) or ctx.world.index.segment_free(a, b):
            return sum(dist(p, q) for p, q in legs(ctx, a, b))
        return dist(a, b) * DETOUR

    return Problem(
        plant=ctx.world.plant,
        jobs=tuple(jobs),
        excavators=tuple(unit(r) for r in team if r.rtype == "excavator"),
        haulers=tuple(unit(r) for r in team if r.rtype == "hauler"),
        v_excavator=cfg.speeds.excavator,
        v_hauler=cfg.speeds.hauler,
        dig_s=cfg.timing.dig_s,
        transfer_s=cfg.timing.transfer_s,
        unload_s=cfg.timing.unload_s,
        dist=leg,
    )


def _pickup_pending(ctx: GlobalView, rec: AuctionRecord) -> bool:
    """Is a hauler already coming for a bucket at this auction's place (awarded a transport
    there, or holding one, and not loaded yet)?"""
    here = rec.location
    for a in ctx.observer.auctions:
        if (
            a is not rec
            and a.status == "open"
            and a.task_type == "transport"
            and a.awards
            and a.awards[-1].outcome == "pending"
            and dist(a.location, here) <= NEAR
        ):
            return True
    for r in ctx.robots.values():
        if r.rtype != "hauler" or not r.alive:
            continue
        reserved = None if r.bidder is None else r.bidder.reserved
        if reserved is not None and _at(reserved.task_type, reserved.location, here):
            return True
        for t in r.tasks_held():
            if _at(t.task_type, t.location, here) and not (t is r.current and r.load()):
                return True  # (a loaded one is on its way to the plant)
    return False


def _at(task_type: str, location: Point, here: Point) -> bool:
    return task_type == "transport" and dist(location, here) <= NEAR


def _promised(ctx: GlobalView, rec: AuctionRecord) -> set[str]:
    """Robots with an award pending in another open auction."""
    return {
        a.awards[-1].winner
        for a in ctx.observer.auctions
        if a is not rec and a.status == "open" and a.awards and a.awards[-1].outcome == "pending"
    }
