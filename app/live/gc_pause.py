"""Keep full garbage collections off the hot path while missions run, with bounded garbage.

A live mission accumulates hundreds of thousands of long-lived objects (its event log,
auctions, messages). CPython's full collection rescans all of them, which stalls every thread
for 100+ ms several times a second at "max" speed. While missions are live the runner
periodically moves the survivors into the permanent generation (`gc.freeze`), after a young
collection so little garbage goes with them; once the server is idle they are unfrozen and
collected in one pass. The stepping thread also needs the GIL handed back quickly, so the
switch interval is shortened for the server's lifetime.

A frozen object is still freed when its reference count drops to zero, but garbage held in
reference cycles is only found by a full collection, which freezing skips. So a full
collection (unfreeze, collect, freeze again) also runs while busy when the frozen objects
doubled since the last one: the cost of full collections stays proportional to the heap's
growth, as CPython's own rule for its oldest generation, and garbage frozen with the heap is
bounded by the heap it came with. (Playback's replay engines, full of cycles, were the big
source of such garbage; they now live in the playback worker process.)
"""

from __future__ import annotations

import ctypes
import ctypes.util
import gc
import sys
from time import perf_counter

SWITCH_INTERVAL_S = 0.0005
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
        self._switch = sys.getswitchinterval()
        self._base = 0  # frozen objects after the last full collection
        self._count = 0  # frozen objects at the last freeze
        self.full = 0  # full collections run while busy (for tests and metrics)
        self.full_seconds = 0.0  # and the time they took

    def start(self) -> None:
        sys.setswitchinterval(SWITCH_INTERVAL_S)

    def tick(self, busy: bool) -> None:
        now = perf_counter()
        if busy and self._due():
            self._collect_all()
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

    def _due(self) -> bool:
        return self._frozen and self._count > max(FLOOR, 2 * self._base)

    def _collect_all(self) -> None:
        gc.unfreeze()
        t0 = perf_counter()
        gc.collect()
        if _TRIM is not None:
            _TRIM(0)  # freed pages back to the system: RSS falls after a load
        self.full_seconds += perf_counter() - t0

    def release(self) -> None:
        self._collect_all()
        self._frozen = False
        self._base = self._count = 0

    def stop(self) -> None:
        self.release()
        sys.setswitchinterval(self._switch)
