"""The plant's docks (docs/model.md#plant): at most `count` haulers unload at once; the others
wait in a first-come-first-served queue beside the plant."""

from __future__ import annotations

from typing import Any, Protocol

import simpy


class Unloader(Protocol):
    """What the docks see of a hauler: its state (queued, unloading)."""

    @property
    def state(self) -> str: ...
    @state.setter
    def state(self, value: str) -> None: ...


class Plant:
    def __init__(self, env: simpy.Environment, docks: int) -> None:
        self.env = env
        self.docks = docks
        self._res = simpy.Resource(env, capacity=docks)
        self.waits: list[float] = []  # one per hauler that was served, in order
        self.queued = 0  # haulers that found every dock busy

    def expected_wait_s(self, unload_s: float) -> float:
        """What a hauler arriving now would wait (on average), from the queue it sees."""
        ahead = len(self._res.queue) + len(self._res.users) - self.docks + 1
        return max(0, ahead) * unload_s / self.docks

    def unload(self, hauler: Unloader, unload_s: float) -> Any:
        """Take a dock (waiting for one if all are busy), unload, free the dock. A hauler that
        fails while it waits leaves the queue (its request is cancelled)."""
        t0 = float(self.env.now)
        with self._res.request() as req:
            if not req.triggered:
                self.queued += 1
                hauler.state = "queued"
            yield req
            self.waits.append(float(self.env.now) - t0)
            hauler.state = "unloading"
            yield self.env.timeout(unload_s)

    def metrics(self) -> dict[str, Any]:
        w = self.waits
        return {
            "dock_wait_s": sum(w),
            "dock_wait_mean_s": sum(w) / len(w) if w else 0.0,
            "dock_wait_max_s": max(w) if w else 0.0,
            "dock_queued": self.queued,
        }
