"""The world service's own process: the moon and its robots go on whether mission control is
there or not (`python -m field.world_process`, started by the server for a field mission).

It holds the mission's Zenoh endpoint, the world service (the ground truth) and the agent
processes it starts, watches and settles (`field.fleet.Fleet` in its `moon` mode), and
answers mission control's requests on `regolith/<m>/supervisor`: start, stop or list agents,
switch the policy, show the world. Only mission control may ask (signed with the mission's
`control` certificate: a restarted server makes a newer one from the authority it keeps with
the database). It reads its settings, the authority's key among them, from its standard
input, never from the command line or the environment.

It ends when mission control says `stop`, when the mission is over and mission control has
said nothing for `ORPHAN_S`, or when mission control has said nothing for `ABANDONED_S`
(SIGTERM ends it too): its agents are stopped with it.
"""

from __future__ import annotations

import base64
import contextlib
import json
import logging
import signal
import sys
import threading
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from engine.scenario import Scenario
from field.drain import Drain
from field.fleet import Fleet, Proc
from field.journal import read_file
from field.trust import Authority
from field.wire import supervisor_key

log = logging.getLogger("regolith.field.world_process")

ORPHAN_S = 600.0
"""A finished mission's world waits this long (wall) for mission control to read it back."""
ABANDONED_S = 3600.0
"""A running mission's world gives up on a mission control silent this long (wall)."""


@dataclass(frozen=True)
class Settings:
    """What the server hands the world's process on its standard input (one JSON line)."""

    mission: str
    secret: bytes  # the mission's authority (it issues the agents' credentials)
    scenario: Scenario
    seed: int
    policy: str
    speed: float
    port: int
    journal: Path
    host: str = "127.0.0.1"
    stall: str | None = None
    paused: bool = False  # the clock stands from the start (a mission created paused)

    def to_json(self) -> str:
        return json.dumps(
            {
                "mission": self.mission,
                "secret": base64.b64encode(self.secret).decode(),
                "scenario": self.scenario.model_dump(mode="json"),
                "seed": self.seed,
                "policy": self.policy,
                "speed": self.speed,
                "port": self.port,
                "journal": str(self.journal),
                "host": self.host,
                "stall": self.stall,
                "paused": self.paused,
            }
        )

    @classmethod
    def from_json(cls, text: str) -> Settings:
        d = json.loads(text)
        return cls(
            mission=str(d["mission"]),
            secret=base64.b64decode(d["secret"], validate=True),
            scenario=Scenario.model_validate(d["scenario"]),
            seed=int(d["seed"]),
            policy=str(d["policy"]),
            speed=float(d["speed"]),
            port=int(d["port"]),
            journal=Path(d["journal"]),
            host=str(d.get("host") or "127.0.0.1"),
            stall=d.get("stall"),
            paused=bool(d.get("paused", False)),
        )


def proc_dict(p: Proc) -> dict[str, Any]:
    return {
        "name": p.name,
        "gen": p.gen,
        "pid": p.popen.pid,
        "alive": p.alive,
        "exit": p.popen.poll(),
        "started_at": p.started_at,
        "killed_at": p.killed_at,
    }


class WorldProcess:
    def __init__(self, settings: Settings) -> None:
        self.settings = settings
        authority = Authority.restore(settings.mission, settings.secret, 1)
        self.fleet = Fleet(
            settings.scenario,
            settings.seed,
            settings.policy,
            settings.speed,
            port=settings.port,
            mission=settings.mission,
            listen_host=settings.host,
            stall=settings.stall,
            authority=authority,
            journal=settings.journal,
            moon=True,
        )
        if settings.paused:  # before any request can hold the lock, and any agent starts
            self.fleet.set_clock(paused=True)
        self.stopped = threading.Event()
        self.heard = time.monotonic()  # mission control's last word
        self._lock = threading.Lock()  # one request at a time changes the fleet
        self._requests = Drain(
            self.fleet.session.declare_queryable,
            supervisor_key(settings.mission),
            self._on_request,
            "supervisor",
        )

    def start_team(self) -> None:
        """Every agent of the team, before any request is answered: mission control's first
        view then holds the whole team (its process budget counts them), and an `add` or a
        `spawn` asked meanwhile waits instead of racing the roster. (It did on a loaded
        machine: an `add` answered before the haulers started was named `hauler-1`, the budget
        counted the few agents already up, and the team's own `hauler-1` started again.)"""
        with self._lock:
            self.fleet.up(operator=True)

    def _on_request(self, query: Any) -> None:
        link, key = self.fleet.link, supervisor_key(self.settings.mission)
        got = link.take_control_query(query, key, "the world's controls")
        if got is None:
            return
        _opened, req = got
        self.heard = time.monotonic()
        args = req.get("args") or {}
        try:
            if not isinstance(args, dict):
                raise ValueError("args: an object")
            with self._lock:
                reply: dict[str, Any] = {"ok": True, "value": self.handle(str(req.get("op")), args)}
        except (ValueError, KeyError, TypeError) as exc:
            reply = {"ok": False, "error": str(exc)[:200]}
        link.reply(query, key, req, reply)

    def handle(self, op: str, a: dict[str, Any]) -> Any:
        fleet = self.fleet
        if op == "view":
            return {**fleet.world.view(), "agents": self.agents(), "dropped": fleet.link.rejections}
        if op == "agents":
            return self.agents()
        if op == "spawn":
            name = str(a["name"])
            old = fleet.procs.get(name)
            if old is not None and old.alive:
                raise ValueError(f"name: {name!r} is running")
            return proc_dict(fleet.spawn(name))
        if op == "kill":
            fleet.kill(str(a["name"]))
            return None
        if op == "add":
            return fleet.add(str(a["type"]))
        if op == "set_policy":
            fleet.set_policy(str(a["policy"]))
            return None
        if op == "clock":  # pause, resume, re-pace: every agent at once (field/clock.py)
            speed = a.get("speed")
            paused = a.get("paused")
            if paused is not None and not isinstance(paused, bool):
                raise ValueError("paused: true or false")
            if speed is not None and (
                isinstance(speed, bool) or not isinstance(speed, int | float)
            ):
                raise ValueError("speed: a number")
            fleet.set_clock(paused=paused, speed=None if speed is None else float(speed))
            return fleet.world.clock.state.to_dict()
        if op == "journal":  # a life that ended: what its files on this disk hold
            name, gen, after = str(a["name"]), int(a["gen"]), int(a["after"])
            if not any(p.name == name and p.gen == gen for p in self._lives()):
                raise ValueError(f"name: no life {name}#{gen} here")
            return read_file(self.settings.journal, name, gen, after)
        if op == "stop":
            self.stopped.set()
            return None
        raise ValueError(f"op: unknown operation {op!r}")

    def _lives(self) -> list[Proc]:
        fleet = self.fleet
        return [*fleet.history, *([fleet.operator] if fleet.operator else [])]

    def agents(self) -> dict[str, Any]:
        fleet = self.fleet
        return {
            "procs": [proc_dict(p) for p in fleet.procs.values()],
            "operator": None if fleet.operator is None else proc_dict(fleet.operator),
            "lives": [proc_dict(p) for p in self._lives()],
            "world_gen": fleet.world_link.cred.gen,
            "endpoint": fleet.endpoint,
        }

    def run(self) -> None:
        self.start_team()
        while not self.stopped.wait(0.5):
            quiet = time.monotonic() - self.heard
            finished = self.fleet.world.terrain.finished.triggered
            if (finished and quiet > ORPHAN_S) or quiet > ABANDONED_S:
                log.warning("mission control silent for %.0f s: ending the mission", quiet)
                break

    def close(self) -> None:
        self._requests.undeclare()
        self.fleet.close()


def main() -> None:
    logging.basicConfig(level=logging.WARNING, format="world: %(message)s")
    settings = Settings.from_json(sys.stdin.readline(1 << 20))
    sys.stdin.close()
    world = WorldProcess(settings)
    signal.signal(signal.SIGTERM, lambda *_: world.stopped.set())
    try:
        world.run()
    except KeyboardInterrupt:
        pass
    finally:
        with contextlib.suppress(Exception):
            world.close()


if __name__ == "__main__":
    main()
