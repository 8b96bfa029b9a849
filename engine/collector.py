"""The cyclic garbage collector, paused while a headless mission runs.

A mission makes no cyclic garbage worth collecting: its objects are freed by their reference
counts (a scale-30 mission ran to its end with the collector off, then `gc.collect()` found
a few hundred objects; peak memory was the same). Yet CPython's collector traverses every
container a mission allocates, and rescans the whole heap (hundreds of MB at scale) in each
full collection: a quarter of a scale-30 mission's CPU. So headless runs (`run_mission`,
the CLI, the bench) advance with it paused; it runs again, as it was, once they end.

The service does not use this: its runner keeps full collections off the hot path on its
own terms (`app/live/gc_pause.py`), since its threads share one collector with the web
server.
"""

from __future__ import annotations

import gc
import threading
from collections.abc import Iterator
from contextlib import contextmanager

_lock = threading.Lock()
_holders = 0
_was_enabled = False


@contextmanager
def collector_paused() -> Iterator[None]:
    """Pause the collector for the block; the last of several nested or concurrent holders
    restores it as it was."""
    global _holders, _was_enabled
    with _lock:
        if _holders == 0:
            _was_enabled = gc.isenabled()
            gc.disable()
        _holders += 1
    try:
        yield
    finally:
        with _lock:
            _holders -= 1
            if _holders == 0 and _was_enabled:
                gc.enable()
