"""What an agent's robot sees of the robots beside it, in other processes, and the hand-over
exchange with them (`engine.robots.rendezvous`).

`PeerBody` stands in `ctx.robots` for a robot in another process: what a robot standing
beside it can see of it (where it is, whether it is alive, what it waits for), a `look`
query to that robot's agent. `FieldRendezvous` carries the hand-over messages: each one a
`handover` query to the receiver's agent, which hands it to its robot (`serve_body`). A peer
that does not answer (killed, unreachable) is seen as not there, and its answer is no.
"""

from __future__ import annotations

import base64
import dataclasses
import math
from typing import TYPE_CHECKING, Any

from engine.robots.rendezvous import (
    Arrived,
    Handover,
    Here,
    Left,
    Loading,
    Ready,
    Rendezvous,
    Sight,
    Transfer,
)
from field.robot import make_robot

if TYPE_CHECKING:
    from field.remote import Asker
    from field.robot import FieldContext
    from field.trust import Opened


LOOK_DEFAULT: dict[str, Any] = {
    "alive": False,
    "pos": [float("nan"), float("nan")],
    "ahead": [],
    "waiting_for": None,
    "bucket": 0,
    "bin": 0,
    "state": "unknown",
}


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
    """A robot in another process, as the robots of this one see it."""

    def __init__(self, asker: Asker, name: str, rtype: str) -> None:
        self._asker = asker
        self.name = name
        self.rtype = rtype
        self._seen: dict[str, Any] | None = None
        self._seen_step = -1

    def _look(self) -> dict[str, Any]:
        if self._seen is None or self._seen_step != self._asker.step:
            seen = self._asker.ask_body(self.name, "look")
            self._seen = seen if isinstance(seen, dict) else LOOK_DEFAULT
            self._seen_step = self._asker.step
        return self._seen

    def forget(self) -> None:
        """A message to it may change what it looks like: look again."""
        self._seen = None

    alive = property(lambda s: bool(s._look()["alive"]))
    pos = property(lambda s: tuple(s._look()["pos"]))
    ahead = property(lambda s: list(s._look()["ahead"]))
    waiting_for = property(lambda s: s._look()["waiting_for"])
    bucket = property(lambda s: s._look()["bucket"])
    bin = property(lambda s: s._look()["bin"])
    state = property(lambda s: s._look()["state"])


# --- the hand-over exchange over the network ------------------------------------------------
def encode(msg: Handover) -> dict[str, Any]:
    """A hand-over message as a `handover` query's arguments."""
    return {"msg": type(msg).__name__.lower(), **dataclasses.asdict(msg)}


def decode(a: dict[str, Any]) -> Handover:
    """The hand-over message a query's arguments carry (ValueError, KeyError: none)."""
    kind = a.get("msg")
    if kind == "arrived":
        return Arrived(None if a.get("task_id") is None else str(a["task_id"]))
    if kind == "left":
        return Left()
    if kind == "here":
        return Here()
    if kind == "ready":
        return Ready(bool(a["free"]))
    if kind == "loading":
        s = float(a["transfer_s"])
        if not (math.isfinite(s) and s >= 0.0):
            raise ValueError(f"transfer_s: {s!r}")
        return Loading(s)
    if kind == "transfer":
        return Transfer(str(a["task_id"]))
    raise ValueError(f"msg: {kind!r} is not a hand-over message")


def sight(d: dict[str, Any]) -> Sight:
    """A caller as it looks (`look`, sent with its query), to the robot it talks to."""
    pos = d["pos"]
    ahead = d.get("ahead") or ()
    waiting_for = d.get("waiting_for")
    return Sight(
        str(d["name"]),
        str(d["rtype"]),
        bool(d["alive"]),
        (float(pos[0]), float(pos[1])),
        tuple(str(t) for t in ahead),
        None if waiting_for is None else str(waiting_for),
    )


class FieldRendezvous(Rendezvous):
    """The hand-over exchange between agents: a message is a `handover` query to the
    receiver's agent, its answer the reply (no answer: no)."""

    def __init__(self, asker: Asker, robots: dict[str, Any]) -> None:
        super().__init__(robots)
        self._asker = asker

    def send(self, sender: Any, to: str, msg: Handover) -> bool:
        """A `Transfer` carries a `once` id: the receiver's agent has the world service
        record the move under it before its robot takes the mineral. Unanswered (a lost
        reply, a starved or killed hauler), the world service settles it: either the move
        happened, or from now on it never will. Two processes' state cannot otherwise
        change in one step."""
        peer = self._robots.get(to)
        if isinstance(peer, PeerBody):
            peer.forget()
        args = encode(msg)
        if not isinstance(msg, Transfer):
            return bool(self._asker.ask_body(to, "handover", **args))
        once = args["once"] = self._asker.new_id("handover")
        taken = self._asker.ask_body(to, "handover", **args)
        if taken is None:
            taken = self._asker.ask_world("settle", once=once)
        return bool(taken)


def serve_body(
    asker: Asker, robot: Any, robots: dict[str, Any], req: dict[str, Any], frame: bytes = b""
) -> dict[str, Any]:
    """Answer a body query to this process's robot: a `look`, or a hand-over message from
    the robot beside it (`robots` gains a stand-in for a caller not met before). `frame` is
    the signed query as it came: a `Transfer` hands it to the world service as the giver's
    consent to the move."""
    if req.get("op") == "look":
        return {"ok": True, "value": look(robot)}
    asker.step += 1  # what the message does may change what the robots look like
    handle = getattr(robot, "on_handover", None)
    if req.get("op") != "handover" or handle is None:
        return {"ok": False, "error": f"op: {req.get('op')!r} is not served"}
    args = req["args"]
    msg = decode(args)
    sender = sight(req["caller"])
    if sender.name not in robots:
        robots[sender.name] = PeerBody(asker, sender.name, sender.rtype)
    once = str(args.get("once", ""))

    def witness() -> bool:
        """The world service records the move `once`: it refuses one the giver has given
        up on, or did not sign (its own query, `frame`, goes with it). The agent's lock
        stays held meanwhile: nothing changes between the check and the receipt."""
        x, y = sender.pos
        proof = base64.b64encode(frame).decode()
        return bool(
            asker.ask_world(
                "handover", once=once, by=asker.name, src=sender.name, x=x, y=y, consent=proof
            )
        )

    return {"ok": True, "value": bool(handle(sender, msg, witness))}


def place_robot(
    asker: Asker, ctx: FieldContext, name: str, rtype: str, pos: Any, roster: dict[str, str]
) -> Any:
    """This agent's robot on its context, beside stand-ins for the other agents' robots; its
    hand-overs with them go through a `FieldRendezvous`."""
    robot = make_robot(name, rtype, ctx, pos)
    if hasattr(robot, "rendezvous"):  # it hands minerals over
        robot.rendezvous = FieldRendezvous(asker, ctx.robots)  # type: ignore[attr-defined]
    ctx.robots[name] = robot
    for peer, ptype in roster.items():
        if peer != name:
            ctx.liveness.add(peer)
            ctx.robots[peer] = PeerBody(asker, peer, ptype)  # type: ignore[assignment]
    ctx.liveness.introduce_all(ctx.env.now)
    robot.peers = {**roster, name: rtype}
    return robot


def caller_refused(req: dict[str, Any], opened: Opened) -> str | None:
    """Why a body query is not served (None: it is): anything but a `look` only from the
    robot it names as the caller, whose type is taken from its certificate."""
    caller = req.get("caller")
    if req.get("op") != "look" and (
        not isinstance(caller, dict) or caller.get("name") != opened.sender
    ):
        return "caller: not the signer"
    if isinstance(caller, dict):
        caller["rtype"] = opened.cert.role  # what it is, not what it says it is
    return None
