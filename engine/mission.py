"""One mission: the engine's single public entry point.

Build it from a scenario, a seed and a policy; advance it to any simulation time; read a
snapshot; give it operator commands at the current time. The command line and the live
service are both clients of this class. Same scenario, seed and commands (at the same
simulation times) give the same run, bit for bit.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Iterable
from typing import TYPE_CHECKING, Any, Literal

import numpy as np
import simpy

from engine.auction_rules import AuctionRecord
from engine.collector import collector_paused
from engine.context import MissionContext
from engine.errors import CommandRejected, UnknownRobotError
from engine.events import Event
from engine.interface import MissionInterface, MissionMode
from engine.messages import PolicyChange
from engine.metrics import mission_metrics
from engine.placement import free_point, place_task
from engine.planning import OmplPlanner, PathPlanner, StraightLinePlanner
from engine.policies import Policy, PolicyContext, make_policy, policy_class, resolve_policy
from engine.realism_setup import install_realism, make_bus
from engine.robots import OPERATOR, Operator, Robot
from engine.scenario import ROBOT_TYPES, Scenario
from engine.tangent_planner import TangentPlanner
from engine.team import build_robot, check_type, robot_name, roster, scout_routes, start_positions
from engine.views import SimulatedViews
from engine.world import World, generate_world

PlannerKind = Literal["ompl", "exact", "straight"]
PLANNERS: tuple[PlannerKind, ...] = ("ompl", "exact", "straight")
"""RRT-Connect (the study's planner, the default), exact shortest paths over the tangent
graph, straight lines (obstacle-free tests only). docs/benchmarks.md compares the first two."""


class Mission(SimulatedViews):
    """A simulated mission (`engine.interface.MissionInterface`)."""

    mode: MissionMode = "simulated"

    def __init__(
        self,
        scenario: Scenario,
        seed: int,
        policy: str | int = "fcfs",
        planner: PlannerKind = "ompl",
        keep_events: bool = True,
    ) -> None:
        """`keep_events` False: events go to the subscribers only (`EventLog.stream_only`)
        and `events` is refused; for headless runs that want the metrics."""
        if not isinstance(seed, int) or seed < 0:
            raise ValueError("seed: must be a whole number >= 0")
        self.scenario = scenario
        self.seed = seed
        self.initial_policy = resolve_policy(policy)
        # spawn(5)'s first four streams are spawn(4)'s (and its first three spawn(3)'s): a
        # stream added last changes none before it, so the reference runs are unchanged
        world_rng, bus_rng, plan_rng, work_rng, self._policy_rng = (
            np.random.default_rng(s) for s in np.random.SeedSequence(seed).spawn(5)
        )
        self.world = generate_world(scenario, world_rng)
        chosen = make_planner(planner, self.world, plan_rng)
        self.env = simpy.Environment()
        self.ctx = ctx = MissionContext(scenario, self.world, chosen, self.env)
        if not keep_events:
            ctx.observer.log.stream_only()
        self.robots: dict[str, Robot] = {}  # the robots of ctx.robots, as their own classes
        ctx.policy = self._make_policy(self.initial_policy)
        install_realism(ctx, work_rng)
        ctx.bus = make_bus(ctx, bus_rng)
        team = roster(scenario.team)
        ctx.liveness.reserve(len(team) + 1)  # and the operator's console
        self.operator = Operator(OPERATOR, ctx, self.world.plant, 1.0)
        self._counts: dict[str, int] = {t: 0 for t in ROBOT_TYPES}
        self.routes = scout_routes(self.world, scenario.team.scouts)
        starts = self._start_positions(len(team))
        robots: list[Robot] = [self.operator]
        robots.extend(self._make_robot(t, p) for t, p in zip(team.values(), starts, strict=True))
        ctx.liveness.introduce_all(0.0)
        known = {r.name: r.rtype for r in robots}  # the team that starts together knows itself
        for r in robots:
            r.peers = dict(known)
        for r in robots:
            r.start()
        self._stalled = self.env.event()
        self.env.process(self._watch_for_stall())
        self.actions: list[dict[str, Any]] = []
        self.status = "running"
        self._closed = False

    # --- construction helpers -------------------------------------------------------------
    def _start_positions(self, n: int) -> list[tuple[float, float]]:
        return start_positions(self.world, self.scenario.start_spread, n)

    def _make_policy(self, name: str) -> Policy:
        """The policy with the run's policy stream; a baseline also gets the global view."""
        central = not policy_class(name).decentralized
        context = PolicyContext(self._policy_rng, global_view=self.ctx if central else None)
        return make_policy(name, context)

    def _make_robot(self, rtype: str, pos: tuple[float, float]) -> Robot:
        self._counts[rtype] += 1
        name = robot_name(rtype, self._counts[rtype])
        robot = build_robot(name, rtype, self.ctx, pos, self.routes)
        self.robots[name] = self.ctx.robots[name] = robot
        return robot

    # --- driving ------------------------------------------------------------------------
    @property
    def now(self) -> float:
        return float(self.env.now)

    @property
    def done(self) -> bool:
        return self.status != "running"

    @property
    def policy(self) -> str:
        return self.ctx.policy.name

    @property
    def events(self) -> list[Event]:
        log = self.ctx.observer.log
        if not log.keep:
            raise RuntimeError("events: this mission streams its events (keep_events=False)")
        return log.events

    @property
    def auctions(self) -> list[AuctionRecord]:
        return self.ctx.observer.auctions

    def subscribe(self, fn: Callable[[Event], None]) -> None:
        self.ctx.observer.log.subscribe(fn)

    def watch_auctions(self, fn: Callable[[str], None]) -> None:
        """`fn` is never called: every change of an engine record comes with an event naming it."""

    def advance(self, until: float) -> None:
        """Process every event up to simulation time `until` (clamped to the mission's end)."""
        if self.done:
            return
        env, finished = self.env, self.ctx.terrain.finished
        limit = min(float(until), self.scenario.max_time_s)
        stalled = self._stalled
        while not finished.triggered and not stalled.triggered and env.peek() <= limit:
            env.step()
        if finished.triggered:
            self._end("completed")
        elif stalled.triggered:
            self.ctx.observer.emit("mission_stalled", **self.stall_report())
            self._end("stalled")
        elif limit >= self.scenario.max_time_s:
            if limit > env.now:
                env.run(until=limit)
            self._end("timeout")
        elif limit > env.now:
            env.run(until=limit)

    def _watch_for_stall(self) -> Any:
        """End the mission `stalled` once nothing has moved it forward for stall_timeout_s."""
        timeout = self.scenario.stall_timeout_s
        while True:
            due = self.ctx.observer.progress_at + timeout
            if self.env.now >= due:
                self._stalled.succeed()
                return
            yield self.env.timeout(due - self.env.now)

    def run(self) -> dict[str, Any]:
        self.advance(math.inf)
        return self.metrics()

    def _end(self, status: str) -> None:
        self.status = status
        self.ctx.observer.emit(
            "mission_ended", status=status, makespan_s=self.ctx.terrain.finished_at
        )
        self.close()

    def close(self) -> None:
        if not self._closed:
            self._closed = True
            self.ctx.planner.close()

    # --- reading ------------------------------------------------------------------------
    def metrics(self) -> dict[str, Any]:
        """The run's figures: a pure function of scenario, seed, planner and actions."""
        out = self.run_figures()
        out.update(mission_metrics(self.ctx))
        out["policy_changes"] = self.policy_changes()
        return out

    # --- operator commands --------------------------------------------------------------
    def _record(self, kind: str, **args: Any) -> None:
        self.actions.append({"t": self.now, "kind": kind, "args": args})
        self.ctx.observer.progress_at = self.now  # an operator steering is not a stall

    def _check_running(self) -> None:
        """Settle the current instant, then refuse if the mission has ended.

        Every event already due at `now` runs before a command takes effect, whether the
        command comes live (at any point of a stepping slice, or before a paused mission's
        first step) or from a replay that advanced to the command's time: both paths then
        see the same state, so a recorded history always replays to the same log.
        """
        self.advance(self.now)
        if self.done:
            raise CommandRejected(f"mission has ended ({self.status})")

    def robot(self, name: str) -> Robot:
        r = self.robots.get(name)
        if r is None or r.rtype == "operator":
            raise UnknownRobotError(f"robot {name!r} does not exist in this mission")
        return r

    def set_policy(self, policy: str | int) -> str:
        self._check_running()
        try:
            name = resolve_policy(policy)
        except ValueError as exc:
            raise CommandRejected(str(exc)) from None
        self._record("set_policy", policy=name)
        old = self.ctx.policy.name
        self.ctx.policy = self._make_policy(name)
        if self.ctx.bus.board is not None:
            self.ctx.bus.board.stir_all()  # every bidder's quiet was under the old policy
        self.ctx.bus.publish(PolicyChange(sender=OPERATOR, policy=name))
        self.ctx.observer.emit("policy_changed", old=old, new=name)
        for r in self._robots():
            r.wake()
            r.policy_changed()
        return name

    def disable_robot(self, name: str, mode: str = "graceful") -> None:
        self._check_running()
        r = self.robot(name)
        if mode not in ("graceful", "abrupt"):
            raise CommandRejected("mode: must be 'graceful' or 'abrupt'")
        if not r.alive or r.leaving:
            raise CommandRejected(f"robot {name!r} is already {r.state}")
        self._record("disable_robot", name=name, mode=mode)
        if mode == "abrupt":
            self.ctx.observer.failures += 1
            r.fail()
            self.ctx.observer.emit("robot_failed", robot=name, x=r.pos[0], y=r.pos[1])
        else:
            r.disable()
            self.ctx.observer.emit("robot_disabled", robot=name)

    def enable_robot(self, name: str) -> None:
        self._check_running()
        r = self.robot(name)
        if r.alive and not r.leaving:
            raise CommandRejected(f"robot {name!r} is not disabled")
        self._record("enable_robot", name=name)
        if r.alive:
            r.leaving = False  # it had not finished leaving: it simply stays
        else:
            r.enable()
        self.ctx.observer.emit("robot_enabled", robot=name)

    def add_robot(self, rtype: str, position: tuple[float, float] | None = None) -> str:
        self._check_running()
        try:
            check_type(rtype)
        except ValueError as exc:
            raise CommandRejected(str(exc)) from None
        pos = free_point(self.world, position, "position") if position is not None else None
        if pos is None:
            pos = self._start_positions(1)[0]
        self._record("add_robot", type=rtype, position=None if position is None else list(pos))
        robot = self._make_robot(rtype, pos)
        robot.start(joined_late=True)
        self.ctx.observer.emit("robot_added", robot=robot.name, type=rtype, x=pos[0], y=pos[1])
        return robot.name

    def inject_task(self, task_type: str = "excavate", location: Iterable[float] = ()) -> str:
        self._check_running()
        task = place_task(
            self.world, self.ctx.terrain.sites, self.scenario.scan_radius, task_type, location
        )
        x, y = task.x, task.y
        self._record("inject_task", type=task_type, location=[x, y])
        rec = self.operator.house.open(task_type, (x, y), task.task_id, kind="operator")  # type: ignore[arg-type]
        self.ctx.observer.emit("task_injected", auction_id=rec.id, task_type=task_type, x=x, y=y)
        return rec.id

    def apply(self, action: dict[str, Any]) -> Any:
        """Replay one recorded action at its simulation time."""
        t = float(action["t"])
        if t < self.now - 1e-9:
            raise CommandRejected(f"t: action at {t} lies before the mission's time {self.now}")
        self.advance(t)
        args = dict(action.get("args", {}))
        kind = action["kind"]
        if kind == "set_policy":
            return self.set_policy(args["policy"])
        if kind == "disable_robot":
            return self.disable_robot(args["name"], args.get("mode", "graceful"))
        if kind == "enable_robot":
            return self.enable_robot(args["name"])
        if kind == "add_robot":
            pos = args.get("position")
            return self.add_robot(args["type"], None if pos is None else (pos[0], pos[1]))
        if kind == "inject_task":
            return self.inject_task(args["type"], args["location"])
        raise CommandRejected(f"kind: unknown action {kind!r}")


def make_planner(kind: str, world: World, rng: np.random.Generator) -> PathPlanner:
    if kind == "ompl":
        return OmplPlanner(world, rng)
    if kind == "exact":
        return TangentPlanner(world)
    if kind == "straight":
        return StraightLinePlanner()
    raise ValueError(f"planner: must be one of {', '.join(PLANNERS)}, not {kind!r}")


def run_mission(
    scenario: Scenario,
    seed: int,
    policy: str | int = "fcfs",
    actions: Iterable[dict[str, Any]] = (),
    planner: PlannerKind = "ompl",
) -> dict[str, Any]:
    """Run one mission headless to its end and return its metrics (its events are streamed,
    not kept: nobody reads them)."""
    m = Mission(scenario, seed, policy, planner, keep_events=False)
    try:
        with collector_paused():
            for action in sorted(actions, key=lambda a: float(a["t"])):
                m.apply(action)
            return m.run()
    finally:
        m.close()


if TYPE_CHECKING:  # the type checker holds `Mission` to the interface it declares
    _implements: type[MissionInterface] = Mission
