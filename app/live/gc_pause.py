"""Keep full garbage collections off the hot path while missions run, with bounded garbage.

A live mission accumulates hundreds of thousands of long-lived objects (its event log,
auctions, messages). CPython's full collection rescans all of them, which stalls every thread
for 100+ ms several times a second at "max" speed. While missions are live the runner
periodically moves the survivors into the permanent generation (`gc.freeze`), after a young
collection so little garbage goes with them; once the server is idle they are unfrozen and
collected in one pass. The stepping thread also needs the GIL handed back quickly, so the
switch interval is shortened for the server's lifetime.

A frozen object is still freed when its reference count drops to zero, but garbage held in
reference cycles is only found by a full collection, which freezing skips. Playback's replay
engines are full of cycles (simpy processes and their environment), so every engine dropped
while a mission was live stayed in memory until the server went idle: hundreds of scrubs
beside one live mission grew the server by gigabytes. So a full collection (unfreeze, collect,
freeze again) also runs while busy when

- `DROP_LIMIT` engines were dropped since the last one (`dropped()`; playback called it while
  its engines were in the server: they are now in the playback worker process, so nothing
  does at present), at
  most one per `MIN_GAP_S` (or per `COST_RATIO` times the last one's duration, so a big
  heap's collections never take more than a tenth of the time), and any fewer `LATE_S`
  after the last one, so the garbage of
  dropped engines is bounded and gone within seconds of the last scrub; or
- the frozen objects doubled since the last one (anything else frozen as garbage): the cost of
  full collections stays proportional to the heap's growth, as CPython's own rule for its
  oldest generation.
"""

from __future__ import annotations

import ctypes
import ctypes.util
import gc
import sys
import threading
from time import perf_counter

SWITCH_INTERVAL_S = 0.0005
#: dropped engines that call for a full collection while busy
DROP_LIMIT = 4
#: the least time between two full collections asked for by dropped engines, and at least
#: `COST_RATIO` times the last one's duration (a big heap: at most a tenth of the time)
MIN_GAP_S = 2.0
COST_RATIO = 9.0
#: fewer dropped engines than `DROP_LIMIT` are collected this long after the last collection
LATE_S = 10.0
#: frozen objects below which growth never calls for a full collection
FLOOR = 200_000


def _trimmer() -> ctypes._CFuncPtr | None:  # type: ignore[name-defined]
    """glibc's `malloc_trim`, which hands freed heap pages back to the system (elsewhere
    None: the memory is then reused by the process, not returned)."""
    try:
        return ctypes.CDLL(ctypes.util.find_library("c") or "libc.so.6").malloc_trim  # type: ignore[no-any-return]
    except (OSError, AttributeError):
        return None


_TRIM = _trimmer()


class GcPause:
    """Freeze old objects while busy; collect in full when idle, or when garbage builds up."""

    def __init__(self, every_s: float = 1.0) -> None:
        self.every_s = every_s
        self._frozen = False
        self._last = perf_counter()
        self._last_full = perf_counter()
        self._switch = sys.getswitchinterval()
        self._drops = 0
        self._lock = threading.Lock()
        self._base = 0  # frozen objects after the last full collection
        self._count = 0  # frozen objects at the last freeze
        self.full = 0  # full collections run while busy (for tests and metrics)
        self.full_seconds = 0.0  # and the time they took
        self._took = 0.0

    def start(self) -> None:
        sys.setswitchinterval(SWITCH_INTERVAL_S)

    def dropped(self, engines: int = 1) -> None:
        """Engines were let go (any thread): their cycles need a full collection."""
        with self._lock:
            self._drops += engines

    @property
    def pending(self) -> int:
        """Dropped engines not yet collected."""
        return self._drops

    def tick(self, busy: bool) -> None:
        now = perf_counter()
        if busy and self._due(now):
            self._collect_all(now)
            gc.freeze()
            self._frozen = True
            self._base = self._count = gc.get_freeze_count()
            self.full += 1
            self._last = now
        elif busy and now - self._last >= self.every_s:
            gc.collect(1)
            gc.freeze()
            self._frozen = True
            self._last = now
            # counting the frozen objects walks them all: once per freeze, never per tick
            self._count = gc.get_freeze_count()
        elif not busy and self._frozen:
            self.release()
        elif not busy and self._drops:
            self.dropped(-self._drops)  # nothing frozen: CPython's own collections reclaim them

    def _due(self, now: float) -> bool:
        gap = now - self._last_full
        least = max(MIN_GAP_S, COST_RATIO * self._took)
        if (self._drops >= DROP_LIMIT and gap >= least) or (
            self._drops and gap >= max(LATE_S, least)
        ):
            return True
        return self._frozen and self._count > max(FLOOR, 2 * self._base)

    def _collect_all(self, now: float) -> None:
        with self._lock:
            self._drops = 0
        gc.unfreeze()
        t0 = perf_counter()
        gc.collect()
        if _TRIM is not None:
            _TRIM(0)  # the dropped engines' pages back to the system: RSS falls after a load
        self._took = perf_counter() - t0
        self.full_seconds += self._took
        self._last_full = now

    def release(self) -> None:
        self._collect_all(perf_counter())
        self._frozen = False
        self._base = self._count = 0

    def stop(self) -> None:
        self.release()
        sys.setswitchinterval(self._switch)
