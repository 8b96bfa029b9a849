"""The hand-over exchange across two agents (field/bodies.py `FieldRendezvous`,
`serve_body`), with the real world service as its witness and the hauler's real side of the
exchange (`engine.robots.handover.Taking`): the network between the two robots loses
replies, leaves queries unanswered and delivers them late; the hauler stands by, leaves,
fails and comes back; the excavator fails. At every step the mineral is in exactly one
place, the robots and the world's record agree, and a move the giver settled as never done
never happens."""

from __future__ import annotations

from collections.abc import Iterator
from typing import Any

import pytest
import simpy
from hypothesis import given, settings
from hypothesis import strategies as st

from engine.robots.handover import Taking
from engine.robots.rendezvous import Loading, Transfer
from field.bodies import FieldRendezvous, look, serve_body
from field.transport import open_session
from field.wire import body_key, encode_json
from field.world_rules import Refused
from tests.field.test_world_service import MISSION, Team, _dig


@pytest.fixture(scope="module")
def session() -> Iterator[object]:
    s = open_session()
    yield s
    s.close()  # type: ignore[attr-defined]


class Robot:
    """A robot's body as the exchange reads it (an excavator's bucket, a hauler's bin)."""

    def __init__(self, name: str, pos: tuple[float, float]) -> None:
        self.name, self.rtype = name, name.rsplit("-", 1)[0]
        self.ctx = type("Ctx", (), {"env": simpy.Environment()})()
        self.alive, self.pos, self.state = True, pos, "waiting"
        self.bucket = self.bin = 0
        self.current: Any = None
        self.waiting_for: str | None = "t1"
        self.ahead: list[str] = []
        self.taking = Taking(self)  # type: ignore[arg-type]

    def wake(self) -> None:
        pass

    def tasks_changed(self) -> None:
        pass  # the board of rounds (engine/round_board.py) is the simulation's, not the field's

    def on_handover(self, sender: Any, msg: Any, witness: Any) -> bool:
        return self.taking.on_handover(sender, msg, witness)


class Asker:
    """One agent's queries: the world service's answers (a refusal is None, as an agent's),
    and the body queries the test's network carries."""

    def __init__(self, team: Team, name: str, net: Net) -> None:
        self.team, self.name, self.net = team, name, net
        self.step, self._n = 0, 0

    def new_id(self, what: str) -> str:
        self._n += 1
        return f"{self.name}@z/{what}-{self._n}"

    def stopping(self) -> bool:
        return False

    def ask_world(self, op: str, **args: Any) -> Any:
        try:
            return self.team.ask(self.name, op, **args)
        except Refused:
            return None

    def ask_body(self, name: str, op: str, **args: Any) -> Any:
        return self.net.carry(self.name, name, op, args)


class Net:
    """The network between the excavator's agent and the hauler's: each query goes through,
    loses its reply, or is held back (unanswered) to arrive later."""

    def __init__(self, team: Team, exc: Robot, hauler: Robot) -> None:
        self.team, self.exc, self.hauler = team, exc, hauler
        self.fault = "ok"
        self.held: list[tuple[dict[str, Any], bytes]] = []
        self.hauler_asker = Asker(team, hauler.name, self)
        self.hauler_robots: dict[str, Any] = {}

    def carry(self, sender: str, to: str, op: str, args: dict[str, Any]) -> Any:
        req = {"op": op, "args": args, "caller": look(self.exc)}
        frame = self.team.sealers[sender].seal(body_key(MISSION, to), encode_json(req))
        if self.fault == "unanswered":
            self.held.append((req, frame))
            return None
        reply = self.serve(req, frame)
        return None if self.fault == "lost" else reply

    def serve(self, req: dict[str, Any], frame: bytes) -> Any:
        if not self.hauler.alive:
            return None  # a dead agent answers nothing
        rep = serve_body(self.hauler_asker, self.hauler, self.hauler_robots, req, frame)
        return rep["value"] if rep["ok"] else None


FAULTS = {"transfer_ok": "ok", "transfer_lost_reply": "lost", "transfer_unanswered": "unanswered"}
STEPS = st.lists(
    st.sampled_from(
        [
            "stand_by",
            "leave",
            "hauler_fails",
            "hauler_back",
            "excavator_fails",
            "transfer_ok",
            "transfer_lost_reply",
            "transfer_unanswered",
            "late_delivery",
            "deliver",
            "dig",
        ]
    ),
    max_size=25,
)


@settings(max_examples=60, deadline=None)
@given(steps=STEPS)
def test_the_mineral_is_in_one_place_whatever_fails_at_each_step(
    session: object, steps: list[str]
) -> None:
    run(session, steps)


@pytest.mark.parametrize(
    ("steps", "moved"),
    [
        (["stand_by", "transfer_ok"], True),
        (["transfer_ok"], False),  # it never stood by
        (["stand_by", "leave", "transfer_ok"], False),
        (["stand_by", "transfer_lost_reply"], True),  # taken; the giver's settle says so
        (["stand_by", "transfer_unanswered", "late_delivery"], False),  # settled as never
        (["stand_by", "transfer_unanswered", "transfer_ok"], True),  # a new id, a new move
        (["stand_by", "hauler_fails", "hauler_back", "transfer_ok"], False),  # a new life
        (["stand_by", "excavator_fails", "transfer_ok"], False),
    ],
)
def test_each_step_moves_the_mineral_or_leaves_it(
    session: object, steps: list[str], moved: bool
) -> None:
    exc, hauler = run(session, steps)
    assert (hauler.bin, exc.bucket) == ((1, 0) if moved else (0, int(exc.alive)))


def run(session: object, steps: list[str]) -> tuple[Robot, Robot]:
    """Play the steps; check the mineral's place after each; the two robots at the end."""
    team = Team(session)
    w = team.w
    try:
        total = sum(w.minerals_in().values())
        exc, hauler = Robot("excavator-1", (0.0, 0.0)), Robot("hauler-1", (0.2, 0.0))
        _dig(team, "excavator-1")
        exc.bucket = 1
        net = Net(team, exc, hauler)
        rv = FieldRendezvous(Asker(team, exc.name, net), {})
        settled_never: set[str] = set()
        for step in steps:
            if step == "stand_by" and hauler.alive and not hauler.bin:
                hauler.taking.wait()
            elif step == "leave":
                hauler.taking.stop()
            elif step == "hauler_fails" and hauler.alive:
                hauler.alive, hauler.bin = False, 0  # `drop_loads`; the world drops it too
                hauler.taking.stop()
                w.robot_lost(hauler.name)
            elif step == "hauler_back":
                hauler.alive = True  # a new life: not standing by
            elif step == "excavator_fails" and exc.alive:
                exc.alive, exc.bucket = False, 0
                w.robot_lost(exc.name)
            elif step.startswith("transfer") and exc.alive and exc.bucket:
                net.fault = FAULTS[step]
                rv.send(exc, hauler.name, Loading(3.0))
                before = len(w.done)
                if rv.send(exc, hauler.name, Transfer("t1")):
                    exc.bucket = 0
                else:
                    settled_never.update(k for k, v in list(w.done.items())[before:] if not v)
                net.fault = "ok"
            elif step == "late_delivery" and net.held:
                req, frame = net.held.pop(0)
                took = net.serve(req, frame)
                assert not (took and req["args"].get("once") in settled_never)
            elif step == "deliver" and hauler.alive and hauler.bin:
                team.ask(hauler.name, "deliver", once=f"hauler-1@z/d-{len(w.done)}", by="hauler-1")
                hauler.bin = 0
            elif step == "dig" and exc.alive and not exc.bucket and w.terrain.sites[0].remaining:
                _dig(team, "excavator-1")
                exc.bucket = 1
            assert sum(w.minerals_in().values()) == total  # the world's record adds up
            assert exc.bucket == w.loads.get(exc.name, 0), step  # and the robots agree with it
            assert hauler.bin == w.loads.get(hauler.name, 0), step
            assert exc.bucket <= 1 and hauler.bin <= 1
        return exc, hauler
    finally:
        w.close()
