"""One robot, one operating-system process: `regolith agent --name hauler-1 --mission M
--connect tcp/HOST:PORT`.

The agent asks the world service for its place in the mission (scenario, seed, policy, start
position, the starting roster, the mission's clock), builds the engine's own robot class on a
`MissionContext` whose bus is Zenoh (`field.transport.ZenohBus`), whose field is the world
service (`field.remote.RemoteField`) and whose other robots are stand-ins answered by their
own agents (`field.bodies`: their looks and the hand-over exchange with them), and runs it on
mission time: the world service's clock (`field.clock`), which mission control pauses and
re-paces for every agent at once.
"""

from __future__ import annotations

import contextlib
import dataclasses
import itertools
import logging
import threading
import time
from collections.abc import Generator
from pathlib import Path
from typing import Any

import numpy as np
import simpy

from engine.messages import Heartbeat, Hello, Message
from engine.mission import make_planner
from engine.policies import POLICIES, PolicyContext, make_policy
from engine.scenario import Scenario
from engine.world import generate_world
from field.asking import BUSY, QUERY_TIMEOUT_S, AgentError, Asking
from field.bodies import PeerBody, caller_refused, place_robot, serve_body
from field.clock import PAUSED_WAIT_S, MissionClock, advance_to, poll_every
from field.drain import Drain
from field.journal import Journal
from field.journal import serve as serve_journal
from field.link import Link
from field.remote import RemoteField
from field.robot import FieldContext
from field.transport import Faults, Stalls, ZenohBus, open_session
from field.trust import CONTROL, SUPERVISORS, WORLD, Credential, Opened, Rejected
from field.wire import (
    body_key,
    check_segment,
    command_key,
    decode_inject,
    event_key,
    journal_key,
    operator_key,
    world_key,
)

log = logging.getLogger("regolith.field.agent")
AWAKE_S = 0.1
"""The clock loop wakes at least every 50 ms (wall): a longer gap is time the process was not
running (CPU starvation), and does not count against its peers' liveness (`Liveness.excuse`).
Without it, a robot starved for 0.3 s at K = 100 (its failure timeout, 30 s) declared every
peer failed at once and auctioned their tasks again, over and over on a loaded machine."""
DELIVER_PER_TURN = 100
ABSENCE_S = 30.0
"""How long (wall) the world service may say nothing signed before its agents leave (one that
ends says `stop`; this is for one that died). Short silences are not deaths: a world service
starved of CPU on a busy machine answers late. Agents that left at the first 3 s absence left
chaos runs with no scout or excavator alive, stuck for good."""
PRESENCE_POLL_S = 2.0
WATCHER_JOIN_S = QUERY_TIMEOUT_S + 1.0
"""How long `close` waits for the watch on the world service to end (it may be asking)."""
REPORT_REJECTIONS_S = 1.0
"""How often (wall) an agent tells mission control what it dropped, when that changed."""
POSE_INTERVAL_S = 5.0
"""How often (mission time) a robot reports its own pose, which mission control stores so a
field run can be played back (`app/services/field_playback.py` interpolates between two).
Mission time, not wall: the same spacing at any speed, none while the clock stands. 5 s keeps
a 2,500 s run at ~6,000 rows for twelve robots, and a robot (1 m/s at most by default) within a
few metres of the straight line drawn between two reports."""


class Agent(Asking):
    def __init__(
        self,
        name: str,
        mission: str,
        connect: str,
        credential: Credential,
        speed: float | None = None,
        listen: str | None = None,
        faults: Faults | None = None,
        stalls: Stalls | None = None,
        journal: Path | None = None,
    ) -> None:
        self.name = check_segment(name, "name")
        self.mission = check_segment(mission, "mission")
        if (credential.name, credential.mission) != (name, mission):
            raise AgentError(
                f"credentials: issued to {credential.name!r} of mission {credential.mission!r}, "
                f"not {name!r} of {mission!r}"
            )
        self.step = 0
        # the robot's state: the clock loop holds it while it steps the robot, the query
        # handlers while they serve a peer; the loop lets go while it waits for an answer
        self.lock = threading.Lock()
        self._loop_holds = False
        self._loop_thread: int | None = None
        self._watcher: threading.Thread | None = None  # the watch on the world (`run`)
        self._ids = itertools.count(1)
        self.stopped = threading.Event()
        self._world_heard = time.monotonic()  # the last signed word from the world service
        self.stalls = stalls
        self.session = open_session(listen=listen, connect=connect)
        self.link = Link(self.session, credential, f"agent {name}")
        # what it reports, numbered and kept on its disk: read back by a mission control that
        # was away (`field.journal`)
        self.journal = Journal(name, credential.gen, journal)
        self._reported_rejections = 0
        self._next_rejection_report = 0.0
        self.clock = MissionClock()  # none yet: every answer of the world carries it
        spawn = self._spawn()
        if self.clock.state.version < 0:
            raise AgentError(f"mission {self.mission!r}: the world service sent no clock")
        if speed is not None and abs(speed - spawn["speed"]) > 1e-9:
            raise AgentError(
                f"speed: the mission runs at {spawn['speed']:g}×, not {speed:g}× "
                "(every process of a mission shares one clock)"
            )
        scenario = Scenario.model_validate(spawn["scenario"])
        seed = int(spawn["seed"])
        world_rng, _bus, plan_rng, _work, policy_rng = (
            np.random.default_rng(s) for s in np.random.SeedSequence(seed).spawn(5)
        )
        self._policy_context = PolicyContext(policy_rng)  # field runs are decentralized only
        # the map (craters, plant, scan grid) is known; the sites are not: the world service
        # tells a robot of a site when it comes within its scan radius
        world = dataclasses.replace(generate_world(scenario, world_rng), sites=())
        self.env = simpy.Environment(initial_time=self.clock.now())
        ctx = FieldContext(
            scenario,
            world,
            make_planner("ompl", world, plan_rng),
            self.env,
            make_policy(spawn["policy"], self._policy_context),
        )
        ctx.report = self.report
        ctx.observer.life = credential.gen  # ids it makes are its life's alone
        ctx.terrain = RemoteField(self)  # type: ignore[assignment]
        self.bus = ZenohBus(self.link, ctx.liveness, self._note_peer, faults)
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
        self.robot = robot = place_robot(self, ctx, name, rtype, pos, roster)
        self._body = Drain(
            self.session.declare_queryable, body_key(mission, name), self._on_body, "body"
        )
        self._commands = Drain(
            self.session.declare_subscriber, command_key(mission), self._on_command, "commands"
        )
        self._journal = Drain(
            self.session.declare_queryable,
            journal_key(mission, name),
            lambda q: serve_journal(self.link, self.journal, journal_key(mission, name), q),
            "journal",
        )
        self._tasks = (
            Drain(self.session.declare_queryable, operator_key(mission), self._on_task, "tasks")
            if rtype == "operator"
            else None
        )
        robot.start(joined_late=bool(spawn["joined_late"]))
        if rtype != "operator":  # (the operator's console has no body)
            self.env.process(self._report_poses())

    def _on_body(self, query: Any) -> None:
        """Another robot looks at this one, or says something of a hand-over (Zenoh's thread).
        Only a member of the mission is answered, and a message only from its signer."""
        key = body_key(self.mission, self.name)
        got = self.link.take_query(query, key)
        if got is None:
            return
        opened, req = got
        refused = caller_refused(req, opened)
        if refused is not None:
            self.link.reply(query, key, req, {"ok": False, "error": refused})
            return
        reply: dict[str, Any] = {"ok": False, "error": BUSY}  # the caller asks again
        if self.lock.acquire(timeout=QUERY_TIMEOUT_S / 2):
            try:
                reply = serve_body(self, self.robot, self.ctx.robots, req, query.payload.to_bytes())
            except (KeyError, TypeError, ValueError, IndexError) as exc:
                reply = {"ok": False, "error": str(exc)[:200]}
            finally:
                self.lock.release()
            self.bus.inbox.ready.set()  # the clock loop: what the call triggered is due now
        self.link.reply(query, key, req, reply)

    # --- what arrives -----------------------------------------------------------------------
    def _note_peer(self, msg: Message) -> None:
        rtype = msg.rtype if isinstance(msg, Hello | Heartbeat) else msg.sender.rsplit("-", 1)[0]
        if msg.sender not in self.ctx.robots:
            self.ctx.robots[msg.sender] = PeerBody(self, msg.sender, rtype)  # type: ignore[assignment]

    def _on_command(self, sample: Any) -> None:
        """Commands are mission control's and the world service's (signed with theirs)."""
        got = self.link.open_json(command_key(self.mission), sample.payload.to_bytes())
        cmd = self._from_control(got, "a command", SUPERVISORS)
        if cmd is None:
            return
        if cmd.get("cmd") == "stop":
            self.stopped.set()
        elif cmd.get("cmd") == "clock":  # a newer state only; a malformed one changes nothing
            if self.clock.adopt(cmd.get("clock")):
                self.bus.inbox.ready.set()  # the clock loop: time stops or moves on now
        elif (
            cmd.get("cmd") == "set_policy"
            and cmd.get("policy") in POLICIES
            and POLICIES[cmd["policy"]].decentralized  # (a centralized one needs global state)
        ):
            with self.lock:
                self.ctx.policy = make_policy(cmd["policy"], self._policy_context)
                self.robot.wake()
                self.robot.policy_changed()
        else:
            log.warning("dropped an unknown command %r", cmd.get("cmd"))

    def _on_task(self, query: Any) -> None:
        """The operator's console: mission control asks it to auction an operator task (the
        operator's authority is mission control's: it checked the operator's token)."""
        key = operator_key(self.mission)
        req = self._from_control(self.link.take_query(query, key), "an operator task")
        if req is None:
            return  # (not answered: the asker is no one to answer)
        task = decode_inject({k: v for k, v in req.items() if k not in ("rid", "until")})
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
        self.link.reply(query, key, req, reply)

    def _from_control(
        self,
        got: tuple[Opened, dict[str, Any]] | None,
        what: str,
        signers: frozenset[str] = frozenset({CONTROL}),
    ) -> Any:
        """The body of a checked frame if one of `signers` signed it; None (counted) else."""
        if got is None:
            return None
        opened, data = got
        if opened.sender not in signers:
            self.link.opener.rejections.count(Rejected("not mission control", opened.sender, what))
            return None
        if opened.sender == WORLD:
            self._world_heard = time.monotonic()
        return data

    def report(self, data: dict[str, Any]) -> None:
        """An event or auction record for mission control (robots never read these),
        journaled first; a count of what it dropped goes unnumbered (only the latest counts)."""
        if data.get("kind") != "rejections":
            data = self.journal.record(data)
        try:
            self.link.put(event_key(self.mission, self.name), data, self._events)
        except Exception as exc:  # pragma: no cover - a closed session at shutdown
            log.debug("report failed: %s", exc)

    def _report_poses(self) -> Generator[simpy.Event, None, None]:
        """Where this robot is, every `POSE_INTERVAL_S` of mission time (read as the engine's
        views read it, `engine.views.SimulatedViews`), for the mission's stored record."""
        robot = self.robot
        while True:
            (x, y), heading = robot.mobility.position()
            self.report(
                {
                    "kind": "pose",
                    "t": float(self.env.now),
                    "x": float(x),
                    "y": float(y),
                    "heading": float(heading),
                    "state": str(robot.state),
                    "load": int(robot.load()),
                }
            )
            yield self.env.timeout(POSE_INTERVAL_S)

    # --- the clock loop ---------------------------------------------------------------------
    def _watch_world(self) -> None:
        """Leave once the world service has said nothing signed for `ABSENCE_S` without a
        break (slowness is not absence: a starved world service keeps its agents). Mission
        control's absence does not count: the robots mine on without it and it reads back
        what they did (`field.journal`). The world's word is a signed answer or command,
        never a liveliness token: anyone on the bus can declare one."""
        while not self.stopped.wait(every := poll_every(self.clock, PRESENCE_POLL_S)):
            following = every < PRESENCE_POLL_S
            if not following and time.monotonic() - self._world_heard < PRESENCE_POLL_S:
                continue  # heard from it just now (while paused or after a change: ask)
            with contextlib.suppress(Exception):  # a closed session: nobody answers
                self._ask(world_key(self.mission), {"op": "status", "args": {}}, WORLD)
            if time.monotonic() - self._world_heard >= ABSENCE_S:
                log.warning("the world service is gone: leaving")
                self.stopped.set()

    def run(self) -> None:
        self._loop_thread = threading.get_ident()
        self._watcher = threading.Thread(target=self._watch_world, name="watch world", daemon=True)
        self._watcher.start()
        env, clock, bus = self.env, self.clock, self.bus
        while not self.stopped.is_set():
            with self.lock:
                self._loop_holds = True
                try:
                    bus.inbox.ready.clear()
                    if self.stalls is not None:
                        self.stalls.take()  # injected: stop, holding the robot
                    t = clock.now()
                    # paused: nothing happens, not even what a message would start (it waits
                    # in the inbox); mission time stands, so no gap is excused or counted
                    if not clock.paused:
                        self._turn(t)
                    nxt = env.peek()
                    self._report_rejections()
                finally:
                    self._loop_holds = False
            wait = 0.05 if nxt == float("inf") else (nxt - clock.now()) / clock.speed
            pending = bus.inbox.next_due_in()
            if clock.paused:
                wait = PAUSED_WAIT_S  # a command to move on wakes it sooner
            elif pending is not None:
                wait = min(wait, pending)
            # at least a millisecond: a timer due "now" waits for the wall to catch up
            bus.inbox.ready.wait(min(max(wait, 0.001), 0.05))

    def _turn(self, t: float) -> None:
        """The robot's simpy environment brought to mission time `t`, then a batch of what
        arrived delivered (the clock loop, holding the robot)."""
        env, bus = self.env, self.bus
        away = t - env.now - AWAKE_S * self.clock.speed
        if away > 0:  # this process had no CPU: peers were not silent, I was deaf
            self.ctx.liveness.excuse(self.name, env.now, env.now + away)
        advance_to(env, t)
        # a backlog is worked through a batch per turn, the clock kept between:
        # a robot behind on its messages still heartbeats and keeps its timers
        for msg in bus.inbox.due(limit=DELIVER_PER_TURN):
            bus.deliver(msg, float(env.now))
        self.step += 1

    def _report_rejections(self) -> None:
        """What this agent dropped, for the mission's record (when it changed, at most
        once per `REPORT_REJECTIONS_S`)."""
        now = time.monotonic()
        total = self.link.opener.rejections.total
        if total != self._reported_rejections and now >= self._next_rejection_report:
            self._reported_rejections, self._next_rejection_report = (
                total,
                now + REPORT_REJECTIONS_S,
            )
            self.report({"kind": "rejections", **self.link.rejections})

    def close(self) -> None:
        self.stopped.set()
        watcher = self._watcher
        if watcher is not None and watcher is not threading.current_thread():
            # it may be asking the world: done before the session goes (`field.drain` says
            # why a thread inside Zenoh at the interpreter's exit aborts the process)
            watcher.join(WATCHER_JOIN_S)
        self.bus.close()
        self.journal.close()
        with contextlib.suppress(Exception):  # the session may be gone already
            self.session.close()  # type: ignore[no-untyped-call]
