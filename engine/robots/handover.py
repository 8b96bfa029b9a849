"""A hauler's side of the hand-over exchange (`engine.robots.rendezvous`): whether it stands
by to be loaded, whether a bucket is being emptied into its bin, and the move itself.

    apart ──wait()──▶ waiting ──Loading──▶ loading ──Transfer, can receive, witnessed──▶ full
      ▲                  │                    │
      └──── stop() ──────┴──── Transfer refused (it left, failed or is full) ───────────┘

`can_receive` only looks; the mineral moves on `Transfer` alone, and only once the witness
(the world service, in field mode) has recorded the move: a bin takes one mineral at most,
and a refused transfer leaves it in the bucket.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Protocol

import simpy

from engine.geometry import Point, dist
from engine.robots.core import Assignment
from engine.robots.rendezvous import (
    Handover,
    Here,
    Loading,
    Ready,
    Sight,
    Transfer,
    Witness,
)
from engine.terrain import NEAR

if TYPE_CHECKING:
    from engine.context import MissionContext


class TakingRobot(Protocol):
    """What the hauler's side of a hand-over needs of its robot."""

    ctx: MissionContext
    alive: bool
    bin: int
    current: Assignment | None

    @property
    def pos(self) -> Point: ...
    def wake(self) -> None: ...
    def tasks_changed(self) -> None: ...


class Taking:
    """The hauler's hand-over state: waiting (standing by to be loaded), loading (a bucket is
    being emptied into its bin), and the exchange's messages it answers."""

    def __init__(self, robot: TakingRobot) -> None:
        self.robot = robot
        self.loaded: simpy.Event | None = None  # set while it stands by; fires once loaded
        self.loading_s: float | None = None  # a bucket is being emptied into the bin

    @property
    def state(self) -> str:
        if self.robot.bin:
            return "full"
        if self.loaded is None:
            return "apart"
        return "waiting" if self.loading_s is None else "loading"

    def wait(self) -> simpy.Event:
        """Stand by to be loaded: the event fires once a mineral is in the bin."""
        self.loaded = self.robot.ctx.env.event()
        return self.loaded

    def stop(self) -> None:
        """No longer standing by (loaded, gave up, left, failed)."""
        self.loaded = None

    def can_receive(self, giver: Point) -> bool:
        """Alive, still waiting to be loaded beside the giver, with an empty bin (a hauler
        that failed and came back mid-transfer is not waiting). Only a check."""
        r = self.robot
        return r.alive and r.bin == 0 and self.loaded is not None and dist(r.pos, giver) <= NEAR

    def ready(self, giver: Point, *, free: bool) -> bool:
        """Standing by this giver with an empty bin (`free`: and holding no task)?"""
        return self.can_receive(giver) and (not free or self.robot.current is None)

    def on_handover(self, sender: Sight, msg: Handover, witness: Witness) -> bool:
        """A giver's message: its answer."""
        if isinstance(msg, Here):
            self.robot.wake()
            return True
        if isinstance(msg, Ready):
            return self.ready(sender.pos, free=msg.free)
        if isinstance(msg, Loading):
            self.loading_s = msg.transfer_s
            return True
        if isinstance(msg, Transfer):
            self.loading_s = None
            if not self.can_receive(sender.pos) or not witness():
                return False
            self._receive(sender, msg.task_id)
            return True
        return False  # (a taker's own messages are not for it)

    def _receive(self, giver: Sight, task_id: str) -> None:
        """The bucket is emptied into the bin; a coalition hand-over is my task now."""
        r = self.robot
        r.bin = 1
        if r.current is None:
            r.current = Assignment(
                f"{giver.name}/coalition", giver.name, "transport", task_id, giver.pos
            )
            r.tasks_changed()
        if self.loaded is not None and not self.loaded.triggered:
            self.loaded.succeed()
