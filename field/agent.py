"""One robot, one operating-system process: `regolith agent --name hauler-1 --mission M
--connect tcp/HOST:PORT`.

The agent asks the world service for its place in the mission (scenario, seed, policy, start
position, the starting roster, the mission's clock), builds the engine's own robot class on a
`MissionContext` whose bus is Zenoh (`field.transport.ZenohBus`), whose field is the world
service (`field.remote.RemoteField`) and whose other robots are stand-ins answered by their
own agents (`field.remote.PeerBody`), and runs it on simulation time = wall time × speed.
"""

from __future__ import annotations

import contextlib
import dataclasses
import logging
import threading
import time
from collections import deque
from typing import Any

import numpy as np
import simpy

from engine.auction_rules import AuctionRecord
from engine.context import MissionContext
from engine.messages import Heartbeat, Hello, Message
from engine.mission import make_planner
from engine.policies import POLICIES, make_policy
from engine.robots import Excavator, Hauler, Operator, Robot, Scout
from engine.scenario import Scenario
from engine.spiral import spiral_routes
from engine.world import generate_world
from field.remote import CALLS, PeerBody, RemoteField, look, serve_call
from field.transport import Faults, ZenohBus, open_session
from field.wire import (
    body_key,
    check_segment,
    command_key,
    decode_inject,
    decode_json,
    encode_json,
    event_key,
    operator_key,
    world_key,
)
from field.world_service import MissionClock

log = logging.getLogger("regolith.field.agent")
_CLASSES: dict[str, type[Robot]] = {"scout": Scout, "excavator": Excavator, "hauler": Hauler}
QUERY_TIMEOUT_S = 2.0
"""How long (wall) a query to the world service or a peer may take; past it, no answer."""
MISSION_CONTROL_GONE_S = 10.0


def _moves_a_mineral(req: dict[str, Any]) -> bool:
    """A body call that moves a mineral from the caller to this robot (a hand-over)."""
    args = req.get("args")
    return req.get("op") == "call" and isinstance(args, dict) and args.get("method") == "receive"


class AgentError(RuntimeError):
    """The agent cannot join its mission (no world service, refused name, bad options)."""


class FieldContext(MissionContext):
    """A mission context whose auction records are also reported to mission control."""

    report: Any = None

    def new_auction(self, *args: Any, **kw: Any) -> AuctionRecord:
        rec = super().new_auction(*args, **kw)
        self.report({"kind": "auction", "record": rec.to_dict()})
        return rec

    def close_auction(self, rec: AuctionRecord, status: str, winner: str | None) -> None:
        super().close_auction(rec, status, winner)
        self.report({"kind": "auction", "record": rec.to_dict()})


class Agent:
    def __init__(
        self,
        name: str,
        mission: str,
        connect: str,
        speed: float | None = None,
        listen: str | None = None,
        faults: Faults | None = None,
    ) -> None:
        self.name = check_segment(name, "name")
        self.mission = check_segment(mission, "mission")
        self.step = 0
        self.lock = threading.Lock()
        self.stopped = threading.Event()
        self._pending: deque[dict[str, Any]] = deque()  # body calls kept for the clock loop
        self.session = open_session(listen=listen, connect=connect)
        spawn = self._spawn()
        if speed is not None and abs(speed - spawn["speed"]) > 1e-9:
            raise AgentError(
                f"speed: the mission runs at {spawn['speed']:g}×, not {speed:g}× "
                "(every process of a mission shares one clock)"
            )
        scenario = Scenario.model_validate(spawn["scenario"])
        self.clock = MissionClock(float(spawn["epoch"]), float(spawn["speed"]))
        seed = int(spawn["seed"])
        world_rng, _bus, plan_rng, _work = (
            np.random.default_rng(s) for s in np.random.SeedSequence(seed).spawn(4)
        )
        # the map (craters, plant, scan grid) is known; the sites are not: the world service
        # tells a robot of a site when it comes within its scan radius
        world = dataclasses.replace(generate_world(scenario, world_rng), sites=())
        self.env = simpy.Environment(initial_time=self.clock.now())
        ctx = FieldContext(
            scenario,
            world,
            make_planner("ompl", world, plan_rng),
            self.env,
            make_policy(spawn["policy"]),
        )
        ctx.report = self.report
        ctx.field = RemoteField(self)  # type: ignore[assignment]
        self.bus = ZenohBus(self.session, mission, ctx.liveness, self._note_peer, faults)
        ctx.bus = self.bus  # type: ignore[assignment]
        self.ctx = ctx
        self._events = self.session.declare_publisher(event_key(mission, name))
        ctx.observer.log.subscribe(
            lambda ev: self.report(
                {"kind": "event", "t": ev.t, "event": ev.kind, "data": ev.data, "by": name}
            )
        )
        rtype, roster = spawn["rtype"], dict(spawn["roster"])
        pos = (float(spawn["pos"][0]), float(spawn["pos"][1]))
        speed_mps = getattr(scenario.speeds, rtype, 1.0)
        if rtype == "operator":  # the operator's console: auctions operator tasks
            robot: Robot = Operator(name, ctx, pos, 1.0)
        elif rtype == "scout":
            routes = {
                f"scout-{i + 1}": r
                for i, r in enumerate(spiral_routes(world.grid, world.plant, scenario.team.scouts))
            }
            robot = Scout(name, ctx, pos, speed_mps, routes)
        else:
            robot = _CLASSES[rtype](name, ctx, pos, speed_mps)
        self.robot = robot
        ctx.robots[name] = robot
        for peer, ptype in roster.items():
            if peer != name:
                ctx.liveness.add(peer)
                ctx.robots[peer] = PeerBody(self, peer, ptype)  # type: ignore[assignment]
        ctx.liveness.introduce_all(self.env.now)
        roster[name] = rtype
        robot.peers = roster
        self._body = self.session.declare_queryable(body_key(mission, name), self._on_body)
        self._commands = self.session.declare_subscriber(command_key(mission), self._on_command)
        self._tasks = (
            self.session.declare_queryable(operator_key(mission), self._on_task)
            if rtype == "operator"
            else None
        )
        robot.start(joined_late=bool(spawn["joined_late"]))

    # --- queries ----------------------------------------------------------------------------
    def _ask(self, key: str, req: dict[str, Any]) -> dict[str, Any] | None:
        try:
            replies = self.session.get(key, payload=encode_json(req), timeout=QUERY_TIMEOUT_S)
            for reply in replies:
                if reply.ok is not None:
                    return decode_json(reply.ok.payload.to_bytes())
        except Exception:  # the session closed under a robot still running at shutdown
            if not self.stopped.is_set():
                raise
        return None

    def _spawn(self) -> dict[str, Any]:
        deadline = time.monotonic() + 30.0
        while time.monotonic() < deadline:
            rep = self._ask(world_key(self.mission), {"op": "spawn", "args": {"name": self.name}})
            if rep is not None:
                if not rep.get("ok"):
                    raise AgentError(str(rep.get("error")))
                value: dict[str, Any] = rep["value"]
                return value
            time.sleep(0.2)
        raise AgentError(f"mission {self.mission!r}: no world service answered in 30 s")

    def ask_world(self, op: str, **args: Any) -> Any:
        """Ground truth: asked again until the world service answers (a missing answer is
        not a fact: a pile read as empty for want of a reply would be abandoned for good).
        None only for a refused request, or once the agent is stopping."""
        while True:
            rep = self._ask(world_key(self.mission), {"op": op, "args": args})
            if rep is not None:
                if not rep.get("ok"):
                    log.warning("world %s refused: %s", op, rep.get("error"))
                    return None
                return rep["value"]
            log.warning("world %s: no answer yet, asking again", op)
            if self.stopped.is_set():
                return None

    def ask_body(self, name: str, op: str, **args: Any) -> Any:
        req = {"op": op, "args": args, "caller": look(self.robot)}
        rep = self._ask(body_key(self.mission, name), req)
        if rep is None or not rep.get("ok"):
            return None
        return rep["value"]

    def _on_body(self, query: Any) -> None:
        """Another robot looks at this one, or acts on it (Zenoh's thread)."""
        req = decode_json(query.payload.to_bytes() if query.payload is not None else b"")
        reply: dict[str, Any] = {"ok": False, "error": "malformed request"}
        if req is not None and self.lock.acquire(timeout=QUERY_TIMEOUT_S / 2):
            try:
                reply = self._serve_body(req)
            except (KeyError, TypeError, ValueError) as exc:
                reply = {"ok": False, "error": str(exc)[:200]}
            finally:
                self.lock.release()
        elif req is not None and _moves_a_mineral(req):
            # the caller has emptied its bucket already and goes on whatever I answer: the
            # mineral must reach my bin, so the call is kept for the clock loop to apply as
            # soon as it holds the lock (refusing it for a busy lock lost the mineral)
            log.warning("%s: busy; a hand-over kept for the clock loop", self.name)
            self._pending.append(req)
            self.bus.inbox.ready.set()
            reply = {"ok": True, "value": None}
        else:
            reply = {"ok": False, "error": "busy"}
        query.reply(query.key_expr, encode_json(reply))

    def _apply_pending(self) -> None:
        """Body calls kept while the lock was busy (`_on_body`); the lock is held."""
        robot: Any = self.robot
        while self._pending:
            req = self._pending.popleft()
            waiting = getattr(robot, "_loaded", None) is not None  # its task takes the bin
            before = robot.current
            try:
                self._serve_body(req)
            except (KeyError, TypeError, ValueError) as exc:
                log.warning("a kept body call failed: %s", exc)
            if not waiting and robot.current is not None and robot.current is not before:
                # it had stopped waiting: the hand-over becomes a task to carry, queued
                robot.queue.appendleft(robot.current)
                robot.current = None
            robot.wake()

    def _serve_body(self, req: dict[str, Any]) -> dict[str, Any]:
        if req.get("op") == "look":
            return {"ok": True, "value": look(self.robot)}
        caller = req["caller"]
        method, args = req["args"]["method"], list(req["args"].get("args") or [])
        if method not in CALLS or not hasattr(self.robot, method):
            return {"ok": False, "error": f"method: {method!r} is not served"}
        known: Any = self.ctx.robots.get(caller["name"])
        stand_in = known if isinstance(known, PeerBody) else None
        if stand_in is None:
            stand_in = PeerBody(self, caller["name"], caller["rtype"])
            self.ctx.robots[caller["name"]] = stand_in  # type: ignore[assignment]
        stand_in.override = caller
        try:
            value = serve_call(self.robot, stand_in, method, args)
        finally:
            stand_in.override = None
        self.step += 1
        return {"ok": True, "value": value if isinstance(value, bool | None) else None}

    # --- what arrives -----------------------------------------------------------------------
    def _note_peer(self, msg: Message) -> None:
        rtype = msg.rtype if isinstance(msg, Hello | Heartbeat) else msg.sender.rsplit("-", 1)[0]
        if msg.sender not in self.ctx.robots:
            self.ctx.robots[msg.sender] = PeerBody(self, msg.sender, rtype)  # type: ignore[assignment]

    def _on_command(self, sample: Any) -> None:
        cmd = decode_json(sample.payload.to_bytes())
        if cmd is None:
            return
        if cmd.get("cmd") == "stop":
            self.stopped.set()
        elif cmd.get("cmd") == "set_policy" and cmd.get("policy") in POLICIES:
            with self.lock:
                self.ctx.policy = make_policy(cmd["policy"])
                self.robot.wake()
                self.robot.policy_changed()
        else:
            log.warning("dropped an unknown command %r", cmd.get("cmd"))

    def _on_task(self, query: Any) -> None:
        """The operator's console: mission control asks it to auction an operator task."""
        task = decode_inject(query.payload.to_bytes() if query.payload is not None else b"")
        reply: dict[str, Any] = {"ok": False, "error": "malformed operator task"}
        if task is not None and not self.lock.acquire(timeout=QUERY_TIMEOUT_S / 2):
            reply = {"ok": False, "error": "busy"}  # mission control asks again
        elif task is not None:
            try:
                rec = self.robot.house.open(
                    task.task_type, (task.x, task.y), task.task_id, kind="operator"
                )
                reply = {"ok": True, "value": {"auction_id": rec.id}}
                self.bus.inbox.ready.set()  # the clock loop: its announcement is due now
            finally:
                self.lock.release()
        query.reply(query.key_expr, encode_json(reply))

    def report(self, data: dict[str, Any]) -> None:
        """An event or auction record for mission control (robots never read these)."""
        try:
            self._events.put(encode_json(data))
        except Exception as exc:  # pragma: no cover - a closed session at shutdown
            log.debug("report failed: %s", exc)

    # --- the clock loop ---------------------------------------------------------------------
    def _watch_mission_control(self) -> None:
        """Leave when the world service has not answered for MISSION_CONTROL_GONE_S (mission
        control ended or died): an agent never outlives its mission."""
        last = time.monotonic()
        while not self.stopped.wait(1.0):
            if self._ask(world_key(self.mission), {"op": "status", "args": {}}) is not None:
                last = time.monotonic()
            elif time.monotonic() - last > MISSION_CONTROL_GONE_S:
                log.warning("mission control is gone: leaving")
                self.stopped.set()

    def run(self) -> None:
        threading.Thread(target=self._watch_mission_control, daemon=True).start()
        env, clock, bus = self.env, self.clock, self.bus
        while not self.stopped.is_set():
            with self.lock:
                bus.inbox.ready.clear()
                self._apply_pending()
                t = clock.now()
                while env.peek() <= t:
                    env.step()
                if t > env.now:
                    env.run(until=t)  # nothing due: the clock moves on to the wall's time
                for msg in bus.inbox.due():
                    bus.deliver(msg, float(env.now))
                self.step += 1
                nxt = env.peek()
            wait = 0.05 if nxt == float("inf") else (nxt - clock.now()) / clock.speed
            pending = bus.inbox.next_due_in()
            if pending is not None:
                wait = min(wait, pending)
            # at least a millisecond: a timer due "now" waits for the wall to catch up
            bus.inbox.ready.wait(min(max(wait, 0.001), 0.05))

    def close(self) -> None:
        self.stopped.set()
        self.bus.close()
        with contextlib.suppress(Exception):  # the session may be gone already
            self.session.close()  # type: ignore[no-untyped-call]
