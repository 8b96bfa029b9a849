"""Mission control's side of a field mission on this machine: the world service, the intake of
everything said on the mission's key space, one agent process per robot, and the faults
(`--kill NAME@T`: SIGKILL; `--add TYPE@T`: a new process; `--restart NAME@T`: a rejoin).

Every agent runs in its own process group, and `Fleet.close` (also on error) kills every group
still alive, so no agent outlives its fleet.
"""

from __future__ import annotations

import contextlib
import os
import signal
import socket
import subprocess
import sys
import threading
import time
import uuid
from dataclasses import dataclass
from pathlib import Path

from engine.robots import OPERATOR
from engine.scenario import ROBOT_TYPES, Scenario
from engine.team import check_type, robot_name, robot_type
from field.drain import Drain
from field.intake import Intake
from field.link import Link
from field.refusals import check_field
from field.transport import Stalls, open_session
from field.trust import WORLD, Authority, Credential
from field.wire import (
    PREFIX,
    InjectTask,
    body_key,
    command_key,
    messages_selector,
    operator_key,
)
from field.world_service import WorldService

INJECT_WAIT_S = 10.0
"""How long (wall) mission control waits for the operator's console to take a task."""


def free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])


def ask_console(link: Link, task_type: str, p: tuple[float, float], task_id: str) -> str:
    """Have a mission's operator console auction a task; its auction's id. Asked again while
    it says "busy" (or is still starting), for `INJECT_WAIT_S`; ValueError when it refuses or
    never answers."""
    fields = {"task_type": task_type, "x": p[0], "y": p[1], "task_id": task_id}
    req = InjectTask.model_validate({"v": 1, "cmd": "inject_task", **fields})
    deadline = time.monotonic() + INJECT_WAIT_S
    while time.monotonic() < deadline:
        rep = link.ask(operator_key(link.mission), req.model_dump(exclude={"v"}), OPERATOR, 2.0)
        if rep is not None and rep.get("ok"):
            return str(rep["value"]["auction_id"])
        if rep is not None and rep.get("error") != "busy":
            raise ValueError(f"inject_task: refused by the operator console: {rep}")
        time.sleep(0.1)
    raise ValueError("inject_task: the operator console did not answer")


@dataclass
class Proc:
    name: str
    popen: subprocess.Popen[bytes]
    started_at: float
    gen: int
    killed_at: float | None = None

    @property
    def alive(self) -> bool:
        return self.popen.poll() is None


class Fleet:
    def __init__(
        self,
        scenario: Scenario,
        seed: int,
        policy: str,
        speed: float,
        port: int | None = None,
        mission: str | None = None,
        listen_host: str = "127.0.0.1",
        stall: str | None = None,
        authority: Authority | None = None,
        journal: Path | None = None,
        moon: bool = False,
    ) -> None:
        """`moon`: this is the world service's own process (`field.moon`): it speaks as the
        world, and mission control, another process, takes the agents' reports."""
        check_field(scenario=scenario, policy=policy, speed=speed)  # before any process starts
        self.mission = mission or f"m{uuid.uuid4().hex[:10]}"
        self.port = port or free_port()
        self.endpoint = f"tcp/{listen_host}:{self.port}"
        self.speed = speed
        if stall is not None:
            Stalls.parse(stall)  # ValueError naming the option, before any process starts
        self.stall = stall  # injected starvation for every agent (`Stalls`, FOR@EVERY)
        self.session = open_session(listen=self.endpoint)
        # the mission's authority: only the processes it issues credentials to are heard
        self.authority = authority or Authority(self.mission)
        self.journal = journal
        self.world_link = Link(
            self.session, self.authority.issue(WORLD, WORLD), f"world {self.mission}"
        )
        self.link = (
            self.world_link
            if moon
            else Link(self.session, self.authority.control, f"mission {self.mission}")
        )
        self.intake = Intake(self.link)
        self._subs = [  # (heartbeats: who is alive, and where)
            Drain(
                self.session.declare_subscriber,
                messages_selector(self.mission),
                self.intake.on_message,
                "intake messages",
            )
        ]
        if not moon:  # the world's own process takes no reports: mission control does
            # (declared there, this lossless channel, fed faster than it was read, made the
            # world's network threads wait: no query answered, the mission stalled)
            self._subs.append(
                Drain(  # events and auction records: none may be lost
                    self.session.declare_subscriber,
                    f"{PREFIX}/{self.mission}/event/*",
                    self.intake.on_report,
                    "intake reports",
                    lossless=True,
                )
            )
        self.world = WorldService(
            self.world_link,
            scenario,
            seed,
            policy,
            speed,
            None if moon else self.intake.on_world_event,
            journal,
        )
        self.intake.on_heard = self.world.note_heard
        self.procs: dict[str, Proc] = {}
        self.history: list[Proc] = []
        self.operator: Proc | None = None
        self._counts: dict[str, int] = dict.fromkeys(ROBOT_TYPES, 0)
        self._settled: dict[str, float] = {}  # dead robots settled, and when (mission time)
        self._closing = threading.Event()
        self._watcher = threading.Thread(target=self._watch, name="fleet-deaths", daemon=True)
        self._watcher.start()

    def now(self) -> float:
        return self.world.clock.now()

    def spawn(self, name: str) -> Proc:
        rtype = robot_type(name)
        self._counts[rtype] = max(self._counts.get(rtype, 0), int(name.rsplit("-", 1)[1]))
        popen, gen = self._start(name)
        proc = Proc(name, popen, self.now(), gen)
        self.procs[name] = proc
        self.history.append(proc)
        self._settled.pop(name, None)
        return proc

    def credential(self, name: str) -> Credential:
        """A new credential for `name` (a new generation: the last one's stops counting),
        for an agent started here or on another machine (docs/field.md)."""
        return self.authority.issue(name, robot_type(name))

    def _start(self, name: str) -> tuple[subprocess.Popen[bytes], int]:
        """An agent process; its credential goes in on its standard input (no file, no
        command line, nothing another user of the machine can read)."""
        cred = self.credential(name)
        cmd = [
            sys.executable,
            "-m",
            "app.cli",
            "agent",
            "--name",
            name,
            "--mission",
            self.mission,
            "--connect",
            self.endpoint,
            "--credentials",
            "-",
            *(["--stall", self.stall] if self.stall else []),
            *(["--journal", str(self.journal)] if self.journal else []),
        ]
        popen = subprocess.Popen(  # its own process group: killed as a whole
            cmd,
            start_new_session=True,
            stdin=subprocess.PIPE,
            stdout=subprocess.DEVNULL,
            stderr=None,
        )
        assert popen.stdin is not None
        with contextlib.suppress(BrokenPipeError):
            popen.stdin.write(cred.to_json().encode() + b"\n")
        with contextlib.suppress(BrokenPipeError):
            popen.stdin.close()
        return popen, cred.gen

    def up(self, operator: bool = False) -> None:
        """One agent per robot of the roster and, with `operator`, the operator's console (an
        agent with no body that auctions operator tasks: `inject`)."""
        if operator:
            popen, gen = self._start(OPERATOR)
            self.operator = Proc(OPERATOR, popen, self.now(), gen)
        for name in self.world.roster:
            self.spawn(name)

    def inject(self, task_type: str, p: tuple[float, float], task_id: str) -> str:
        """Have the operator's console auction a task; its auction's id. ValueError when the
        console does not answer (not started, or gone)."""
        if self.operator is None or self.operator.popen.poll() is not None:
            raise ValueError("inject_task: this field mission has no operator console")
        return ask_console(self.link, task_type, p, task_id)

    def add(self, rtype: str) -> str:
        check_type(rtype)
        name = robot_name(rtype, self._counts[rtype] + 1)
        self.spawn(name)
        return name

    def kill(self, name: str) -> None:
        """SIGKILL: an abrupt failure, nothing said to anyone."""
        proc = self.procs.get(name)
        if proc is None or proc.popen.poll() is not None:
            raise ValueError(f"name: no running agent {name!r}")
        with contextlib.suppress(ProcessLookupError):
            os.killpg(proc.popen.pid, signal.SIGKILL)
        proc.popen.wait()
        proc.killed_at = self.now()
        self._lost(name)

    # --- deaths -------------------------------------------------------------------------------
    def _lost(self, name: str) -> None:
        if name not in self._settled:
            self._settled[name] = self.now()
            self.world.robot_lost(name)

    def _watch(self) -> None:
        """Notice dead robots and settle them (`WorldService.robot_lost`): an agent process of
        this fleet that exited, or any robot silent for the protocol's failure timeout whose
        body does not answer a look (an agent on another machine)."""
        timeout = self.world.scenario.protocol.failure_timeout_s
        while not self._closing.wait(0.1):
            for name, proc in list(self.procs.items()):
                if proc.popen.poll() is not None and not self._closing.is_set():
                    self._lost(name)
            now = self.now()
            for name, heard in list(self.world.heard.items()):
                if name in self._settled and heard > self._settled[name] and name not in self.procs:
                    del self._settled[name]  # an agent elsewhere is back: it may die again
                if name in self.procs or name in self._settled or now - heard < timeout:
                    continue
                if self.operator is not None and name == OPERATOR:
                    continue  # this fleet's own console carries nothing
                if not self._answers(name):
                    self._lost(name)

    def _answers(self, name: str) -> bool:
        with contextlib.suppress(Exception):
            req = {"op": "look", "args": {}}
            return self.link.ask(body_key(self.mission, name), req, name, 2.0) is not None
        return False

    def set_policy(self, policy: str) -> None:
        self.world.policy = policy
        self.link.put(command_key(self.mission), {"cmd": "set_policy", "policy": policy})

    def set_clock(self, paused: bool | None = None, speed: float | None = None) -> float:
        """Pause, resume or re-pace every agent at once: the world service's clock changes
        (its ground truth), then the new state goes out as a command; an agent that misses
        it adopts it from its next answer of the world (every one carries the clock). The
        mission time it changed at."""
        state = self.world.set_clock(paused=paused, speed=speed)
        self.speed = state["speed"]
        self.link.put(command_key(self.mission), {"cmd": "clock", "clock": state})
        return float(state["t"])

    def close(self) -> None:
        """Stop every agent (asked first, then SIGKILL to any group still there)."""
        self._closing.set()
        self._watcher.join(timeout=5.0)
        with contextlib.suppress(Exception):
            self.link.put(command_key(self.mission), {"cmd": "stop"})
        deadline = time.monotonic() + 3.0
        everyone = [*self.history, *([self.operator] if self.operator else [])]
        for proc in everyone:
            with contextlib.suppress(subprocess.TimeoutExpired):
                proc.popen.wait(timeout=max(0.0, deadline - time.monotonic()))
        for proc in everyone:
            if proc.popen.poll() is None:
                with contextlib.suppress(ProcessLookupError):
                    os.killpg(proc.popen.pid, signal.SIGKILL)
                proc.popen.wait()
        for sub in self._subs:
            sub.undeclare()
        self.world.close()
        with contextlib.suppress(Exception):
            self.session.close()  # type: ignore[no-untyped-call]

    def __enter__(self) -> Fleet:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()
