"""A hostile process on a field mission's bus (run by tests/field/test_hostile_peer.py):

    python -m tests.field.hostile_peer --endpoint tcp/127.0.0.1:P --mission M [--credential F]

It joins the mission's Zenoh endpoint and, for `--rounds` rounds, tries every class of attack
it knows: forged protocol messages in other robots' names (unsigned, signed by an authority
of its own, or, with `--credential`, signed with a real credential of another robot), forged
event and auction records, commands, operator tasks, ghost finds, deliveries and hand-overs,
piles set to zero, out-of-range scans, oversized and deeply nested payloads, replays of
frames it overheard, and lying answers to the robots' queries. It prints one JSON object:
what it sent, and every answer to a world request that changes the world which came back
`ok` (there must be none).
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from typing import Any

import zenoh

from field.link import Link
from field.transport import open_session
from field.trust import Authority, Credential, Sealer
from field.wire import (
    body_key,
    command_key,
    event_key,
    journal_key,
    message_key,
    messages_selector,
    operator_key,
    presence_key,
    supervisor_key,
    world_key,
)

ROBOTS = ["scout-1", "excavator-1", "hauler-1", "hauler-2"]
WRITES = ["found", "deliver", "handover", "site_set", "scan", "drop", "pick", "settle", "spawn"]


def _messages(m: str, name: str) -> list[tuple[str, dict[str, Any]]]:
    """Protocol messages in `name`'s name, in the wire's envelope."""
    loc = [50.0, 50.0]
    bodies = {
        "bid": {
            "auction_id": f"{name}/a1",
            "auctioneer": "excavator-1",
            "bidder": name,
            "location": loc,
            "utility": 1e300,
            "round": 0,
        },
        "heartbeat": {"rtype": "hauler", "t": 100.0, "x": 0.0, "y": 0.0, "state": "idle"},
        "close": {
            "auction_id": "excavator-1/a1",
            "auctioneer": name,
            "task_type": "transport",
            "location": loc,
            "task_id": "transport@50.000,50.000",
            "allocated_to": name,
        },
        "policychange": {"policy": "central-greedy"},
    }
    out = []
    for kind, body in bodies.items():
        env = {
            "v": 1,
            "type": kind,
            "mission": m,
            "sender": name,
            "seq": 0,
            "body": {"sender": name, **body},
        }
        out.append((message_key(m, kind, name), env))
    return out


def _reports(name: str) -> list[dict[str, Any]]:
    return [
        {"v": 1, "kind": "auction", "record": {"id": "forged/1"}},
        {"v": 1, "kind": "auction", "record": {"id": "excavator-1/a1", "awards": [{}]}},
        {"v": 1, "kind": "event", "t": "abc", "event": "delivered", "data": {}, "by": name},
        {
            "v": 1,
            "kind": "event",
            "t": 1.0,
            "event": "mineral_delivered",
            "data": {},
            "by": "hauler-1",
        },
    ]


def _world_calls(name: str) -> list[dict[str, Any]]:
    calls = [{"op": "found", "args": {"id": f"site-{i}", "by": name}} for i in range(1, 11)]
    calls += [
        {"op": "deliver", "args": {"by": n, "once": f"{n}@x/{i}"}}
        for i, n in enumerate(["ghost-1", "hauler-1", name] * 4)
    ]
    calls += [
        {"op": "site_set", "args": {"id": "site-1", "remaining": 0, "by": name}},
        {"op": "site_set", "args": {"id": "site-2", "worker": name, "by": name}},
        {"op": "scan", "args": {"cell": 10**8, "by": name}},
        {"op": "scan", "args": {"cell": -1, "by": name}},
        {
            "op": "handover",
            "args": {
                "once": "excavator-1@x/1",
                "by": name,
                "src": "excavator-1",
                "x": 0,
                "y": 0,
                "consent": "",
            },
        },
        {"op": "drop", "args": {"x": 1, "y": 1, "by": "hauler-1"}},
        {"op": "pick", "args": {"id": 0, "by": "hauler-1"}},
        {"op": "settle", "args": {"once": "excavator-1@x/handover-1"}},
        {"op": "spawn", "args": {"name": "hauler-1"}},
    ]
    return calls


class Attacker:
    def __init__(self, session: zenoh.Session, mission: str, cred: Credential | None) -> None:
        self.session, self.m = session, mission
        self.own = Sealer(Authority(mission).issue("hauler-1", "hauler"))  # a fake authority
        self.link = Link(session, cred, "attacker") if cred is not None else None
        self.name = cred.name if cred is not None else "hauler-99"
        self.sent = 0
        self.accepted: list[dict[str, Any]] = []
        self.overheard: list[tuple[str, bytes]] = []

    def put(self, key: str, data: dict[str, Any] | bytes) -> None:
        """The same payload three ways: plain, self-signed, and with the stolen credential."""
        raw = data if isinstance(data, bytes) else json.dumps(data).encode()
        payloads = [raw, self.own.seal(key, raw)]
        if self.link is not None:
            payloads.append(self.link.sealer.seal(key, raw))
        for p in payloads:
            self.session.put(key, p)
            self.sent += 1

    def ask(self, key: str, req: dict[str, Any], harmful: bool = False) -> None:
        """A request three ways; an `ok` answer to one that changes the world (or, with
        `harmful`, to any: the world process's controls, a robot's journal) is recorded."""
        raw = json.dumps({"v": 1, **req, "rid": "x"}).encode()
        payloads = [raw, self.own.seal(key, raw)]
        if self.link is not None:
            payloads.append(self.link.sealer.seal(key, raw))
        for p in payloads:
            self.sent += 1
            for reply in self.session.get(key, payload=p, timeout=1.0):
                if reply.ok is None or self.link is None:
                    continue
                got = self.link.open_json(f"reply:{key}", reply.ok.payload.to_bytes())
                if got and got[1].get("ok") and (harmful or req.get("op") in WRITES):
                    self.accepted.append({"req": req, "reply": got[1]})

    def round(self) -> None:
        m = self.m
        for name in [*ROBOTS, self.name]:
            for key, env in _messages(m, name):
                self.put(key, env)
                # in its own key, someone else's name; and someone else's key, its own name
                self.put(message_key(m, env["type"], self.name), env)
        for rep in _reports(self.name):
            self.put(event_key(m, self.name), rep)
            self.put(event_key(m, "excavator-1"), rep)
        for cmd in (
            {"v": 1, "cmd": "set_policy", "policy": "central-greedy"},
            {"v": 1, "cmd": "stop"},
        ):
            self.put(command_key(m), cmd)
        task = {
            "cmd": "inject_task",
            "task_type": "transport",
            "x": 50.0,
            "y": 40.0,
            "task_id": "transport@50.000,40.000",
        }
        self.ask(operator_key(m), task)
        for call in _world_calls(self.name):
            self.ask(world_key(m), call)
        # the world process's controls and the robots' journals are mission control's alone
        for op, args in (
            ("kill", {"name": "hauler-1"}),
            ("spawn", {"name": "hauler-9"}),
            ("add", {"type": "hauler"}),
            ("set_policy", {"policy": "fcfs"}),
            ("journal", {"name": "hauler-1", "gen": 1, "after": -1}),
            ("view", {}),
            ("stop", {}),
        ):
            self.ask(supervisor_key(m), {"op": op, "args": args}, harmful=True)
        for robot in ("hauler-1", "scout-1", "world"):
            self.ask(journal_key(m, robot), {"op": "after", "args": {"after": -1}}, harmful=True)
        for robot in ("hauler-1", "excavator-1"):
            self.ask(
                body_key(m, robot),
                {
                    "op": "handover",
                    "args": {"msg": "transfer", "task_id": "t", "once": "excavator-1@x/2"},
                    "caller": {"name": "excavator-1", "rtype": "excavator", "pos": [0, 0]},
                },
            )
        big = b'{"v":1,"pad":"' + b"x" * (2 * 1024 * 1024) + b'"}'
        deep = b"[" * 30_000 + b"]" * 30_000
        for junk in (big, deep, b"\xff\xfe not json"):
            self.put(message_key(m, "bid", "hauler-1"), junk)
            self.put(event_key(m, "hauler-1"), junk)
            self.ask(world_key(m), {"op": "status", "pad": junk.decode("latin-1")[:70_000]})
        for key, payload in self.overheard[-50:]:  # replays of real, signed frames
            self.session.put(key, payload)
            self.sent += 1


def main() -> None:
    p = argparse.ArgumentParser()
    p.add_argument("--endpoint", required=True)
    p.add_argument("--mission", required=True)
    p.add_argument("--credential")
    p.add_argument("--rounds", type=int, default=3)
    args = p.parse_args()
    cred = None
    if args.credential:
        with open(args.credential, encoding="utf-8") as f:
            cred = Credential.from_json(f.read())
    session = open_session(connect=args.endpoint)
    a = Attacker(session, args.mission, cred)
    m = args.mission
    session.declare_subscriber(
        messages_selector(m), lambda s: a.overheard.append((str(s.key_expr), s.payload.to_bytes()))
    )
    # lying answers: a world that says every pile is empty, robots that take any mineral
    lie = json.dumps({"v": 1, "ok": True, "value": None, "re": "x"}).encode()
    session.declare_queryable(world_key(m), lambda q: q.reply(q.key_expr, lie))
    for robot in ROBOTS:
        session.declare_queryable(body_key(m, robot), lambda q: q.reply(q.key_expr, lie))
    token = session.liveliness().declare_token(presence_key(m) + "-not")
    time.sleep(1.0)
    for _ in range(args.rounds):
        a.round()
        time.sleep(0.5)
    token.undeclare()
    print(json.dumps({"sent": a.sent, "accepted": a.accepted}))
    sys.stdout.flush()
    session.close()


if __name__ == "__main__":
    main()
