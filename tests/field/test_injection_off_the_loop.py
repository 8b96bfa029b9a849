"""A field mission's operator task is a query to its console, which may take seconds while
the console is busy. The server must keep serving meanwhile: the round trip runs on a worker
thread, without the engine gate (every live mission's stepping) and off the event loop
(every request and frame). The mission here has `FieldMission`'s three injection steps and a
console that takes a second; the commands layer is the real one."""

from __future__ import annotations

import asyncio
import threading
import time
from types import SimpleNamespace
from typing import Any

from app.services.commands import RobotCommands
from engine.placement import TaskPlacement
from tests import aio

CONSOLE_S = 1.0


class SlowConsoleMission:
    mode = "field"

    def __init__(self, gate: threading.Lock) -> None:
        self.gate = gate
        self.actions: list[dict[str, Any]] = []
        self.gate_free_while_sending: bool | None = None

    def world_map(self) -> dict[str, Any]:
        return {"width": 100.0, "height": 100.0}

    def plan_injection(self, task_type: str, location: Any) -> TaskPlacement:
        assert self.gate.locked()  # checked against the mission's state: under the gate
        return TaskPlacement(task_type, float(location[0]), float(location[1]), "transport@1,2")

    def send_injection(self, injection: TaskPlacement) -> str:
        self.gate_free_while_sending = self.gate.acquire(timeout=0.5)
        if self.gate_free_while_sending:
            self.gate.release()
        time.sleep(CONSOLE_S)  # the console is busy
        return "operator/1"

    def record_injection(self, injection: TaskPlacement, auction_id: str) -> str:
        assert self.gate.locked()
        self.actions.append({"kind": "inject_task", "args": {"type": injection.task_type}})
        return auction_id


def test_an_injection_waits_for_the_console_off_the_gate_and_the_event_loop() -> None:
    gate = threading.Lock()
    mission = SlowConsoleMission(gate)
    lm = SimpleNamespace(id=1, mission=mission)
    committed: list[dict[str, Any]] = []

    async def live(_id: int) -> Any:
        return lm

    async def record_action(_id: int, action: dict[str, Any], *_: Any) -> None:
        committed.append(action)

    service = SimpleNamespace(
        gate=gate,
        live=live,
        store=SimpleNamespace(record_action=record_action),
        engine_action=lambda lm: dict(lm.mission.actions[-1]),
    )
    commands = RobotCommands(service)  # type: ignore[arg-type]

    async def scenario() -> tuple[str, int]:
        ticks = 0
        task = asyncio.create_task(commands.inject_task(1, "transport", (1.0, 2.0)))
        while not task.done():
            await asyncio.sleep(0.01)
            ticks += 1
        return task.result(), ticks

    auction_id, ticks = aio.run(scenario())
    assert auction_id == "operator/1"
    assert mission.gate_free_while_sending is True
    assert ticks >= 20  # the loop ran on while the console took its second (0 if blocked)
    assert committed == [{"kind": "inject_task", "args": {"type": "transport"}}]
