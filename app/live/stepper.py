"""The stepping thread: the only place missions advance, one short `advance` at a time.

Each `advance` covers an adaptive span of simulated time sized to take about
`slice_ms` of wall time, and happens under the engine gate; between two of them the event
loop can take the gate for commands, frames and fan-out. While an operator request is in
flight the stepper stays off the GIL (up to 100 ms at a time), so control calls are served
at once even at "max" speed. A mission at a finite speed follows the wall clock from its
last anchor; at "max" it runs whenever the database keeps up.
"""

from __future__ import annotations

import logging
import math
import threading
import time
from collections.abc import Callable, Iterable
from time import perf_counter
from typing import TYPE_CHECKING

from app.live.gate import Gate

if TYPE_CHECKING:
    from app.live.mission import LiveMission

log = logging.getLogger("regolith.stepper")
_MIN_CHUNK, _MAX_CHUNK = 1e-3, 600.0
_MAX_YIELD_S = 0.1  # a stream of requests slows missions down but never stops them


class Stepper:
    """Advances every runnable live mission from one thread."""

    def __init__(
        self,
        missions: Callable[[], Iterable[LiveMission]],
        gate: Gate,
        slice_s: float,
        max_lag_s: float,
    ) -> None:
        self._missions = missions
        self._gate = gate
        self._slice = slice_s
        self._max_lag = max_lag_s
        self._wake = threading.Event()
        self._stop = threading.Event()
        self.operators = 0  # operator requests in flight (changed on the loop thread only)
        self._thread = threading.Thread(target=self._run, name="regolith-step", daemon=True)

    def start(self) -> None:
        self._thread.start()

    def stop(self) -> None:
        self._stop.set()
        self._wake.set()
        self._thread.join()

    def wake(self) -> None:
        """A mission became runnable (created, resumed, sped up): stop idling."""
        self._wake.set()

    def _yield_to_operators(self) -> None:
        """Operator requests go first: stay off the GIL while one is in flight (bounded)."""
        deadline = perf_counter() + _MAX_YIELD_S
        while self.operators > 0 and perf_counter() < deadline and not self._stop.is_set():
            time.sleep(0.0005)

    def _run(self) -> None:
        while not self._stop.is_set():
            behind = False
            for lm in [lm for lm in self._missions() if lm.runnable]:
                self._yield_to_operators()
                with self._gate.stepping():
                    if not lm.runnable:  # changed while we waited for the gate
                        continue
                    try:
                        behind |= self._advance(lm)
                    except Exception as exc:  # an engine bug ends that mission, not the server
                        log.exception(
                            "mission %s failed while stepping", lm.id, extra={"mission_id": lm.id}
                        )
                        lm.crashed = f"{type(exc).__name__}: {exc}"
            if not behind:
                self._wake.wait(0.005)
                self._wake.clear()

    def _advance(self, lm: LiveMission) -> bool:
        """One bounded `advance` towards the mission's target; True if still behind it."""
        m = lm.mission
        target = lm.target(perf_counter(), self._max_lag)
        if m.now >= target:
            return False
        t0 = perf_counter()
        m.advance(min(target, m.now + lm.chunk))
        took = perf_counter() - t0
        if took > self._slice:
            lm.chunk = max(lm.chunk / 2, _MIN_CHUNK)
        elif took < self._slice / 4:
            lm.chunk = min(lm.chunk * 2, _MAX_CHUNK)
        return m.now < target and not m.done and math.isfinite(lm.chunk)
