"""A robot's nudge to look at its situation again (a task won, a bid to reconsider, an
operator's command): a nudge sent while the robot is busy waits for its next look, so none is
lost."""

from __future__ import annotations

import simpy


class Wake:
    """One pending nudge at most, and the event the robot's behaviour waits on."""

    __slots__ = ("_env", "_event", "_pending")

    def __init__(self, env: simpy.Environment) -> None:
        self._env = env
        self._event: simpy.Event | None = None
        self._pending = False

    def send(self) -> None:
        ev = self._event
        if ev is not None and not ev.triggered:
            ev.succeed()
        else:
            self._pending = True

    def wait(self) -> simpy.Event:
        """An event that fires at the next nudge, or at once if one came since the last wait."""
        ev = self._env.event()
        if self._pending:
            self._pending = False
            ev.succeed()
        self._event = ev
        return ev
