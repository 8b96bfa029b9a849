"""What an agent's robot sees of the world outside its own process: the field, through the
world service, and the robots beside it, through their agents.

`RemoteField` has the methods of `engine.terrain.Terrain` that robots call; each becomes a query
to the world service. `PeerBody` stands in `ctx.robots` for a robot in another process: what
a robot standing beside it can see (where it is, whether it is alive, what it waits for) and
do with it (arrive to be loaded, empty a bucket into its bin), each a query to that robot's
agent. A peer that does not answer (killed, unreachable) is seen as not there.
"""

from __future__ import annotations

import base64
from typing import TYPE_CHECKING, Any, Protocol

from engine.geometry import Point, dist
from engine.terrain import NEAR, GroundMineral

if TYPE_CHECKING:
    from collections.abc import Callable


class Asker(Protocol):
    """The agent's query functions (field.agent.Agent)."""

    step: int
    name: str

    def ask_world(self, op: str, **args: Any) -> Any: ...

    def ask_body(self, name: str, op: str, **args: Any) -> Any: ...

    def new_id(self, what: str) -> str:
        """An id no other call of any agent, past or present, has used."""
        ...

    def stopping(self) -> bool: ...


class RemoteSite:
    """A site as a robot standing at it (or a scout that just saw it) knows it; the pile and
    who works it are read from and written to the world service."""

    def __init__(self, asker: Asker, d: dict[str, Any]) -> None:
        self._asker = asker
        self.id: str = d["id"]
        self.x: float = d["x"]
        self.y: float = d["y"]
        self.total: int = d["total"]
        self._seen: dict[str, Any] | None = None
        self._seen_step = -1

    def _get(self, key: str) -> Any:
        # read once per step of the agent (a policy pricing twenty auctions reads the pile
        # it stands at twenty times: twenty round trips to a busy world service made an
        # excavator fall minutes behind its messages, its heartbeats stopped)
        if self._seen is None or self._seen_step != self._asker.step:
            self._seen = self._asker.ask_world("site", id=self.id)
            self._seen_step = self._asker.step
        return None if self._seen is None else self._seen[key]

    def _set(self, key: str, value: Any) -> None:
        # `by`: a pile that shrinks went into the setter's bucket (the world's record of loads);
        # a dig carries a `once` id: asked again after a late reply, it is not a second dig
        once = {"once": self._asker.new_id("dig")} if key == "remaining" else {}
        self._seen = self._asker.ask_world(
            "site_set", id=self.id, by=self._asker.name, **{key: value}, **once
        )
        self._seen_step = self._asker.step

    remaining = property(lambda s: s._get("remaining") or 0, lambda s, v: s._set("remaining", v))
    # (None only when the agent is stopping: the world service is asked until it answers)
    worker = property(lambda s: s._get("worker"), lambda s, v: s._set("worker", v))
    last_worker = property(lambda s: s._get("last_worker"), lambda s, v: s._set("last_worker", v))
    found_at = property(lambda s: s._get("found_at"))


class RemoteField:
    """`engine.terrain.Terrain` as robots use it, served by the world service."""

    sites: tuple[RemoteSite, ...] = ()  # a robot never sees the list of all sites

    def __init__(self, asker: Asker) -> None:
        self._asker = asker
        self._at: dict[Point, RemoteSite | None] = {}  # sites never move: asked once per spot

    def _site(self, d: dict[str, Any] | None) -> RemoteSite | None:
        return None if d is None else RemoteSite(self._asker, d)

    def site_at(self, p: Point) -> RemoteSite | None:
        p = (float(p[0]), float(p[1]))
        if p not in self._at:
            if len(self._at) > 4096:
                self._at.clear()
            d = self._asker.ask_world("site_at", x=p[0], y=p[1])
            if d is None and self._asker.stopping():
                return None  # (not an answer: not kept)
            self._at[p] = self._site(d)
        return self._at[p]

    def sites_near(self, a: Point, b: Point, r: float) -> list[RemoteSite]:
        found = self._asker.ask_world("sites_near", ax=a[0], ay=a[1], bx=b[0], by=b[1], r=r)
        return [RemoteSite(self._asker, d) for d in found or ()]

    def note_site_found(self, site: RemoteSite, by: str) -> None:
        self._asker.ask_world("found", id=site.id, by=by)

    def mark_scanned(self, cell: int) -> None:
        self._asker.ask_world("scan", cell=cell, by=self._asker.name)

    @property
    def ground(self) -> list[GroundMineral]:
        found = self._asker.ask_world("ground") or ()
        return [GroundMineral(g["id"], g["x"], g["y"], g["dropped_at"]) for g in found]

    def ground_near(self, p: Point, radius: float = NEAR) -> GroundMineral | None:
        for g in self.ground:
            if dist((g.x, g.y), p) <= radius:
                return g
        return None

    def drop_mineral(self, p: Point, by: str) -> None:
        self._asker.ask_world("drop", x=p[0], y=p[1], by=by, once=self._asker.new_id("drop"))

    def pick_ground(self, g: GroundMineral, by: str) -> None:
        self._asker.ask_world("pick", id=g.id, by=by, once=self._asker.new_id("pick"))

    def note_delivery(self, by: str) -> None:
        self._asker.ask_world("deliver", by=by, once=self._asker.new_id("deliver"))


LOOK_DEFAULT: dict[str, Any] = {
    "alive": False,
    "pos": [float("nan"), float("nan")],
    "ahead": [],
    "waiting_for": None,
    "bucket": 0,
    "bin": 0,
    "state": "unknown",
}

CALLS = frozenset(
    {
        "hauler_arrived",
        "take",
        "wake",
        "ready_for",
        "standing_by",
        "partner_arrived",
        "partner_left",
    }
)
"""What one robot may do to another beside it; `field.agent` serves exactly these."""


def look(robot: Any) -> dict[str, Any]:
    """What a robot beside this one sees of it."""
    return {
        "name": robot.name,
        "rtype": robot.rtype,
        "alive": bool(robot.alive),
        "pos": [float(robot.pos[0]), float(robot.pos[1])],
        "ahead": list(getattr(robot, "ahead", ())),
        "waiting_for": getattr(robot, "waiting_for", None),
        "bucket": int(getattr(robot, "bucket", 0)),
        "bin": int(getattr(robot, "bin", 0)),
        "state": robot.state,
    }


class PeerBody:
    """A robot in another process, as the robots of this one touch it."""

    def __init__(self, asker: Asker, name: str, rtype: str) -> None:
        self._asker = asker
        self.name = name
        self.rtype = rtype
        self.loading_from: Any = None  # set by an excavator during a transfer; only local
        self._seen: dict[str, Any] | None = None
        self._seen_step = -1
        self.override: dict[str, Any] | None = None  # during a call from it: what it sent

    def _look(self) -> dict[str, Any]:
        if self.override is not None:
            return self.override
        if self._seen is None or self._seen_step != self._asker.step:
            seen = self._asker.ask_body(self.name, "look")
            self._seen = seen if isinstance(seen, dict) else LOOK_DEFAULT
            self._seen_step = self._asker.step
        return self._seen

    alive = property(lambda s: bool(s._look()["alive"]))
    pos = property(lambda s: tuple(s._look()["pos"]))
    ahead = property(lambda s: list(s._look()["ahead"]))
    waiting_for = property(lambda s: s._look()["waiting_for"])
    bucket = property(lambda s: s._look()["bucket"])
    bin = property(lambda s: s._look()["bin"])
    state = property(lambda s: s._look()["state"])

    def expects(self, task_id: str) -> bool:
        seen = self._look()
        return bool(task_id == seen["waiting_for"] or task_id in seen["ahead"])

    def _call(self, method: str, *args: Any) -> Any:
        self._seen = None  # what it does may change what it looks like
        return self._asker.ask_body(self.name, "call", method=method, args=list(args))

    def hauler_arrived(self, _hauler: Any, task_id: str) -> bool:
        return bool(self._call("hauler_arrived", task_id))

    def can_receive(self, exc: Any) -> bool:
        """In the field, asking is taking: the hauler's agent checks that it can receive and
        takes the mineral in one call, after the world service recorded the hand-over, so
        the bucket empties (in `Excavator.transfer`) only into a bin that took it.

        A call that goes unanswered (a lost reply, a starved or killed hauler) is settled by
        the world service, which records each hand-over once: either it happened, or from
        now on it never will. Two processes' state cannot otherwise change in one step."""
        task_id = exc.waiting_for
        once = self._asker.new_id("handover")
        taken = self._call("take", task_id, once)
        if taken is None:
            taken = self._asker.ask_world("settle", once=once)
        return bool(taken)

    def receive(self, _exc: Any, _task_id: str) -> None:
        """Taken already, by `can_receive`."""

    def wake(self) -> None:
        self._call("wake")

    def ready_for(self, _exc: Any) -> bool:
        return bool(self._call("ready_for"))

    def standing_by(self, _exc: Any) -> bool:
        return bool(self._call("standing_by"))

    def partner_arrived(self, _hauler: Any) -> None:
        self._call("partner_arrived")

    def partner_left(self, _hauler: Any) -> None:
        self._call("partner_left")


def serve_body(
    asker: Asker, robot: Any, robots: dict[str, Any], req: dict[str, Any], frame: bytes = b""
) -> dict[str, Any]:
    """Answer a body query to this process's robot: a `look`, or one of `CALLS` made by the
    robot beside it (`robots` gains a stand-in for a caller not met before). `frame` is the
    signed query as it came: a `take` hands it to the world service as the giver's consent."""
    if req.get("op") == "look":
        return {"ok": True, "value": look(robot)}
    caller = req["caller"]
    method, args = req["args"]["method"], list(req["args"].get("args") or [])
    serves = "can_receive" if method == "take" else method  # only a hauler takes
    if method not in CALLS or not hasattr(robot, serves):
        return {"ok": False, "error": f"method: {method!r} is not served"}
    known = robots.get(caller["name"])
    stand_in = known if isinstance(known, PeerBody) else None
    if stand_in is None:
        stand_in = robots[caller["name"]] = PeerBody(asker, caller["name"], caller["rtype"])
    stand_in.override = caller
    try:
        if method == "take":
            value = take(asker, robot, stand_in, str(args[0]), str(args[1]), frame)
        else:
            value = serve_call(robot, stand_in, method, args)
    finally:
        stand_in.override = None
    return {"ok": True, "value": value if isinstance(value, bool | None) else None}


def take(
    asker: Asker, hauler: Any, giver: PeerBody, task_id: str, once: str, consent: bytes
) -> bool:
    """An excavator beside this hauler would empty its bucket into its bin
    (`PeerBody.can_receive`): if the hauler can receive, and the world service records the
    hand-over `once` (it refuses one the excavator has given up on, or did not sign: the
    excavator's own `take` query, `consent`, goes with it), the mineral is the hauler's. The
    agent's lock stays held meanwhile: nothing changes between the check and the receipt."""
    if not hauler.can_receive(giver):
        return False
    x, y = giver.pos
    proof = base64.b64encode(consent).decode()
    if not asker.ask_world(
        "handover", once=once, by=asker.name, src=giver.name, x=x, y=y, consent=proof
    ):
        return False
    hauler.receive(giver, task_id)
    return True


def serve_call(robot: Any, caller: PeerBody, method: str, args: list[Any]) -> Any:
    """Run one of `CALLS` on this process's robot, with the calling robot's stand-in."""
    fn: Callable[..., Any] = getattr(robot, method)
    if method == "hauler_arrived":
        return fn(caller, *args)
    if method == "wake":
        return fn()
    return fn(caller)
