"""Keep full garbage collections off the hot path while missions run.

A live mission accumulates hundreds of thousands of long-lived objects (its event log,
auctions, messages). CPython's full collection rescans all of them, which stalls every thread
for 100+ ms several times a second at "max" speed. While missions are live the runner
periodically moves the survivors into the permanent generation (`gc.freeze`), after a young
collection so little garbage goes with them; once the server is idle they are unfrozen and
collected in one pass. The stepping thread also needs the GIL handed back quickly, so the
switch interval is shortened for the server's lifetime.
"""

from __future__ import annotations

import gc
import sys
from time import perf_counter

SWITCH_INTERVAL_S = 0.0005


class GcPause:
    """Freeze old objects while busy; unfreeze and collect when idle."""

    def __init__(self, every_s: float = 1.0) -> None:
        self.every_s = every_s
        self._frozen = False
        self._last = perf_counter()
        self._switch = sys.getswitchinterval()

    def start(self) -> None:
        sys.setswitchinterval(SWITCH_INTERVAL_S)

    def tick(self, busy: bool) -> None:
        now = perf_counter()
        if busy and now - self._last >= self.every_s:
            gc.collect(1)
            gc.freeze()
            self._frozen = True
            self._last = now
        elif not busy and self._frozen:
            self.release()

    def release(self) -> None:
        if self._frozen:
            gc.unfreeze()
            gc.collect()
            self._frozen = False

    def stop(self) -> None:
        self.release()
        sys.setswitchinterval(self._switch)
