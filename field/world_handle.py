"""Mission control's handle on a field mission whose world runs in a process of its own
(`field.world_process`): start it, or attach to one a previous server started, and from then
on hear the mission's key space, ask the world what it shows, and have it start and stop
agents.

What mission control missed — while it was stopped, or a report the bus lost — it reads back
from each life's journal (`field.journal`), and `Intake.offer` takes every report once, in
its life's order. A life that ended is read back from the files it left, through the world's
process.
"""

from __future__ import annotations

import contextlib
import logging
import os
import signal
import subprocess
import sys
import threading
import time
from pathlib import Path
from typing import Any

from engine.scenario import Scenario
from engine.team import robot_type
from field.drain import Drain
from field.fleet import ask_console, free_port
from field.intake import Intake
from field.link import Link
from field.refusals import check_field
from field.transport import open_session
from field.trust import MAX_REPORT, WORLD, Authority, Credential
from field.wire import (
    PREFIX,
    journal_key,
    messages_selector,
    supervisor_key,
)
from field.world_process import Settings
from field.world_view import AgentInfo, WorldView

log = logging.getLogger("regolith.field.world_handle")

ASK_S = 2.0
POLL_S = 0.2
"""How often (wall) mission control asks the world what it shows."""
SWEEP_S = 5.0
"""How often every life's journal is read past what was taken (a report lost on the way)."""
START_S = 60.0
"""How long a world process may take to answer for the first time."""


STOP_S = 15.0
"""How long the world's process may take to stop its agents and end."""


def running(pid: int) -> bool:
    """Whether a process (not necessarily a child of this one) is still there."""
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:
        return True
    return True


class AttachError(RuntimeError):
    """No world process answers for this mission (it ended, or never started)."""


class WorldHandle:
    def __init__(
        self,
        mission: str,
        endpoint: str,
        authority: Authority,
        scenario: Scenario,
        seed: int,
        policy: str,
        taken: dict[str, int] | None = None,
        preload: dict[str, dict[str, Any]] | None = None,
        wait_s: float = START_S,
    ) -> None:
        """Attach to the world process of `mission` at `endpoint` (AttachError if it does
        not answer within `wait_s`); a restarted server's: `taken`, each life's next report
        number already stored, read back from there; `preload`, the auctions as stored."""
        self.mission, self.endpoint, self.authority = mission, endpoint, authority
        self.pid: int | None = None  # the world's process
        self._popen: subprocess.Popen[bytes] | None = None  # the same, if started here
        self.session = open_session(connect=endpoint)
        self.link = Link(self.session, authority.control, f"mission {mission}")
        self.intake = Intake(self.link, world_on_bus=True)
        self.intake.next_rseq.update(taken or {})
        self.intake.auctions.update(preload or {})
        self.world = WorldView(scenario, seed, policy)
        self.procs: dict[str, AgentInfo] = {}
        self.operator: AgentInfo | None = None
        self.history: list[AgentInfo] = []
        self._lives: list[tuple[str, int, bool]] = []
        self._closing = threading.Event()
        self._lock = threading.Lock()
        self._subs = [
            Drain(
                self.session.declare_subscriber,
                messages_selector(mission),
                self.intake.on_message,
                "intake messages",
            ),
            Drain(
                self.session.declare_subscriber,
                f"{PREFIX}/{mission}/event/*",
                self.intake.on_report,
                "intake reports",
                lossless=True,
            ),
        ]
        deadline = time.monotonic() + wait_s
        while not self.refresh():
            if time.monotonic() > deadline:
                self._undeclare()
                raise AttachError(f"mission {mission}: no world process answers at {endpoint}")
            time.sleep(0.2)
        self.catch_up()
        self._swept = time.monotonic()
        self._poller = threading.Thread(target=self._poll, name="world view", daemon=True)
        self._poller.start()

    @classmethod
    def start(
        cls,
        scenario: Scenario,
        seed: int,
        policy: str,
        speed: float,
        folder: Path,
        stall: str | None = None,
        paused: bool = False,
    ) -> WorldHandle:
        """A new field mission: its world's process started (in a session of its own, so it
        outlives this one), then attached to."""
        check_field(scenario=scenario, policy=policy, speed=speed)  # before any process
        authority = Authority(f"m{os.urandom(5).hex()}")
        mission, port = authority.mission, free_port()
        journal = folder / mission
        journal.mkdir(parents=True, exist_ok=True, mode=0o700)
        settings = Settings(
            mission,
            authority.secret,
            scenario,
            seed,
            policy,
            speed,
            port,
            journal,
            stall=stall,
            paused=paused,
        )
        with (journal / "world.log").open("ab") as out:
            popen = subprocess.Popen(
                [sys.executable, "-m", "field.world_process"],
                start_new_session=True,
                stdin=subprocess.PIPE,
                stdout=out,
                stderr=out,
            )
        assert popen.stdin is not None
        popen.stdin.write(settings.to_json().encode() + b"\n")
        popen.stdin.close()
        try:
            handle = cls(mission, f"tcp/127.0.0.1:{port}", authority, scenario, seed, policy)
        except AttachError:
            with contextlib.suppress(ProcessLookupError):
                os.killpg(popen.pid, signal.SIGKILL)
            raise
        handle.pid, handle._popen = popen.pid, popen
        return handle

    # --- what the world's process says ------------------------------------------------------
    def ask(self, op: str, timeout: float = ASK_S, **args: Any) -> Any:
        """The world's process's answer (ValueError if it refused, None if it did not answer)."""
        req = {"op": op, "args": args}
        rep = self.link.ask(supervisor_key(self.mission), req, WORLD, timeout, MAX_REPORT)
        if rep is None:
            return None
        if not rep.get("ok"):
            raise ValueError(str(rep.get("error")))
        return rep["value"]

    def _must(self, op: str, **args: Any) -> Any:
        """As `ask`, for a change: no answer is an error (ValueError) the operator sees."""
        rep = self.link.ask(
            supervisor_key(self.mission), {"op": op, "args": args}, WORLD, 3 * ASK_S, MAX_REPORT
        )
        if rep is None:
            raise ValueError(f"{op}: the world service did not answer")
        if not rep.get("ok"):
            raise ValueError(str(rep.get("error")))
        return rep["value"]

    def refresh(self) -> bool:
        view = self.ask("view")
        if view is None:
            return False
        with self._lock:
            if self.world.show(view):
                self._agents(view["agents"])
        return True

    def _agents(self, agents: dict[str, Any]) -> None:
        self.procs = {d["name"]: AgentInfo.of(d) for d in agents["procs"]}
        op = agents.get("operator")
        self.operator = None if op is None else AgentInfo.of(op)
        self.history = [AgentInfo.of(d) for d in agents["lives"]]
        self._lives = [(p.name, p.gen, p.alive) for p in self.history]
        self._lives.append((WORLD, int(agents["world_gen"]), True))

    def _poll(self) -> None:
        while not self._closing.wait(POLL_S):
            with contextlib.suppress(Exception):  # (asked again next time)
                self.refresh()
                behind = self.intake.behind()
                if behind or time.monotonic() - self._swept > SWEEP_S:
                    self._swept = time.monotonic()
                    self.catch_up(set(behind) or None)

    def catch_up(self, only: set[str] | None = None) -> bool:
        """Read every life's journal past what was taken (or only those of `only`); True if
        every journal answered to its end."""
        complete = True
        for name, gen, alive in list(self._lives):
            src = f"{name}#{gen}"
            if only is not None and src not in only:
                continue
            complete &= self._read_back(name, gen, alive)
        return complete

    def _read_back(self, name: str, gen: int, alive: bool) -> bool:
        while not self._closing.is_set():
            after = self.intake.next_rseq.get(f"{name}#{gen}", 0) - 1
            page = None
            if alive:
                req = {"op": "after", "args": {"after": after}}
                rep = self.link.ask(journal_key(self.mission, name), req, name, ASK_S, MAX_REPORT)
                if rep is not None and rep.get("ok"):
                    page = rep["value"]
            if page is None:  # an ended life (or one not answering): from its files
                with contextlib.suppress(ValueError):
                    page = self.ask("journal", name=name, gen=gen, after=after)
            if page is None or page.get("gen") != gen:
                return False
            for entry in page["entries"]:
                self.intake.offer(name, gen, entry)
            if not page["entries"] or self.intake.next_rseq.get(f"{name}#{gen}", 0) >= page["next"]:
                return True
        return False

    def now(self) -> float:
        return self.world.now()

    def credential(self, name: str) -> Credential:
        """A credential for a robot that joins from another machine (docs/field.md); the
        world's process issues its own agents'."""
        return self.authority.issue(name, robot_type(name))

    # --- what mission control asks of it ----------------------------------------------------
    def spawn(self, name: str) -> AgentInfo:
        info = AgentInfo.of(self._must("spawn", name=name))
        self.refresh()
        return info

    def kill(self, name: str) -> None:
        self._must("kill", name=name)
        self.refresh()

    def add(self, rtype: str) -> str:
        name = str(self._must("add", type=rtype))
        self.refresh()
        return name

    def set_clock(self, paused: bool | None = None, speed: float | None = None) -> float:
        """Pause, resume or re-pace every agent at once (the world's process publishes the
        change); the mission time it changed at."""
        args: dict[str, Any] = {}
        if paused is not None:
            args["paused"] = paused
        if speed is not None:
            args["speed"] = speed
        state = self._must("clock", **args)
        self.world.clock.adopt(state)
        self.refresh()  # what the world shows from then on (a delivery count at a pause)
        # the time shown from now on: the world's, or this view's if it had shown a moment
        # past it while the request was on its way (a view's time never goes back)
        return self.world.clock.now()

    def set_policy(self, policy: str) -> None:
        self._must("set_policy", policy=policy)
        self.world.policy = policy

    def inject(self, task_type: str, p: tuple[float, float], task_id: str) -> str:
        """Have the operator's console auction a task; its auction's id (ValueError when the
        console does not answer)."""
        if self.operator is None or not self.operator.alive:
            raise ValueError("inject_task: this field mission has no operator console")
        return ask_console(self.link, task_type, p, task_id)

    def close(self, stop: bool = True) -> None:
        """Read back what is left, then (with `stop`) end the world's process and its agents;
        without it, only let go: the robots mine on (a server that stops)."""
        self._closing.set()
        if self._poller.is_alive() and self._poller is not threading.current_thread():
            self._poller.join(ASK_S + 1.0)
        if stop:
            self._closing.clear()
            with contextlib.suppress(Exception):
                self.catch_up()
            self._closing.set()
            with contextlib.suppress(Exception):
                self.ask("stop")
            self._wait_world()
        self._undeclare()

    def _wait_world(self) -> None:
        """The world's process ends once it has stopped its agents (reaped, if ours)."""
        if self._popen is not None:
            try:
                self._popen.wait(timeout=STOP_S)
            except subprocess.TimeoutExpired:
                with contextlib.suppress(ProcessLookupError):
                    os.killpg(self._popen.pid, signal.SIGKILL)
                self._popen.wait()
            return
        deadline = time.monotonic() + STOP_S
        while self.pid and time.monotonic() < deadline and running(self.pid):
            time.sleep(0.1)

    def _undeclare(self) -> None:
        for sub in self._subs:
            sub.undeclare()
        with contextlib.suppress(Exception):
            self.session.close()  # type: ignore[no-untyped-call]
