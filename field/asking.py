"""An agent's questions to the world service and to its peers, and how it waits for them:
the clock loop lets go of its robot meanwhile, a missing answer is asked again, and every
answer of the world service carries the mission's clock, which the agent adopts when newer
(`field.clock`): an agent that missed a pause or a new speed catches up at its next answer.
"""

from __future__ import annotations

import contextlib
import itertools
import logging
import threading
import time
from collections.abc import Iterator
from typing import Any

from engine.robots import Robot
from field.bodies import look
from field.clock import PAUSED_WAIT_S, MissionClock, clock_of
from field.link import Link
from field.trust import WORLD
from field.wire import body_key, world_key
from field.world_rules import PAUSED

log = logging.getLogger("regolith.field.agent")
QUERY_TIMEOUT_S = 2.0
"""How long (wall) a query to the world service or a peer may take; past it, no answer."""
BUSY = "busy"
BUSY_RETRIES = 4


class AgentError(RuntimeError):
    """The agent cannot join its mission (no world service, refused name, bad options)."""


class Asking:
    """The agent's queries (`field.agent.Agent` is one); what they use of the agent."""

    name: str
    mission: str
    link: Link
    session: Any
    robot: Robot
    clock: MissionClock
    lock: threading.Lock
    stopped: threading.Event
    _ids: itertools.count[int]
    _loop_holds: bool
    _loop_thread: int | None
    _world_heard: float

    def _ask(self, key: str, req: dict[str, Any], expect: str) -> dict[str, Any] | None:
        # the clock loop lets go of the robot while it waits: a peer asking this robot
        # something meanwhile is answered, not refused as busy (two robots asking each
        # other at once, each holding its own lock, both heard "busy" and took it as "not
        # there": a transport ended void, auctioned again, again)
        try:
            with self._parked():
                rep = self.link.ask(key, req, expect, QUERY_TIMEOUT_S)
            if rep is not None and expect == WORLD:
                self._world_heard = time.monotonic()
                self.clock.adopt(clock_of(rep))  # (a newer state only)
            return rep
        except Exception:  # the session closed under a robot still running at shutdown
            if not self.stopped.is_set():
                raise
        return None

    @contextlib.contextmanager
    def _parked(self) -> Iterator[None]:
        """The clock loop lets go of its robot meanwhile (`_ask` says why)."""
        parked = self._loop_holds and threading.get_ident() == self._loop_thread
        if parked:
            self._loop_holds = False
            self.lock.release()
        try:
            yield
        finally:
            if parked:
                self.lock.acquire()
                self._loop_holds = True

    def new_id(self, what: str) -> str:
        return f"{self.name}@{self.session.zid()}/{what}-{next(self._ids)}"

    def stopping(self) -> bool:
        return self.stopped.is_set()

    def _spawn(self) -> dict[str, Any]:
        deadline = time.monotonic() + 30.0
        while time.monotonic() < deadline:
            rep = self._ask(
                world_key(self.mission), {"op": "spawn", "args": {"name": self.name}}, WORLD
            )
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
        None only for a refused request, or once the agent is stopping. "Paused" is no
        refusal: asked again once time moves (this robot acted before it heard of the pause)."""
        while True:
            rep = self._ask(world_key(self.mission), {"op": op, "args": args}, WORLD)
            if rep is not None and rep.get("error") == PAUSED:
                with self._parked():  # (a peer asking meanwhile is answered)
                    if self.stopped.wait(PAUSED_WAIT_S):
                        return None
                continue
            if rep is not None:
                if not rep.get("ok"):
                    log.warning("world %s refused: %s", op, rep.get("error"))
                    return None
                return rep["value"]
            log.warning("world %s: no answer yet, asking again", op)
            if self.stopped.wait(0.05):  # (no route at all answers at once: not a busy loop)
                return None

    def ask_body(self, name: str, op: str, **args: Any) -> Any:
        """A peer's answer; None if it did not answer (gone, or too slow) or refused. A peer
        that says it is busy is there: it is asked again, a few times."""
        req = {"op": op, "args": args, "caller": look(self.robot)}
        for _ in range(BUSY_RETRIES):
            rep = self._ask(body_key(self.mission, name), req, name)
            if rep is None or self.stopped.is_set():
                return None
            if rep.get("ok"):
                return rep["value"]
            if rep.get("error") != BUSY:
                return None
        return None
