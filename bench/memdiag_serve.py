"""`regolith serve` that writes its memory's make-up to a file on a signal (diagnosis only).

    .venv/bin/python bench/memdiag_serve.py serve --port 8000 ...   (MEMDIAG_OUT=path)

SIGUSR1: the RSS, glibc's heap (`mallinfo2`, all arenas), CPython's small-object allocator
(pymalloc: its 1 MiB arenas, the bytes in allocated and available blocks, from
`sys._debugmallocstats`) and the objects the collector tracks by type, frozen ones included
(unfrozen for the count, frozen again). SIGHUP: the same after stopping the playback worker
and a full collection with `malloc_trim(0)`: what memory the process keeps once the
pool is gone. Used by `bench/playback_load.py --diag` (docs/benchmarks.md, Playback).
"""

from __future__ import annotations

import collections
import ctypes
import gc
import os
import signal
import sys
import threading
import time
from typing import Any

OUT = os.environ.get("MEMDIAG_OUT", "memdiag.txt")
_LIBC = ctypes.CDLL("libc.so.6")
_LOCK = threading.Lock()


class _MallInfo2(ctypes.Structure):
    _fields_ = [
        (n, ctypes.c_size_t)
        for n in (
            *("arena", "ordblks", "smblks", "hblks", "hblkhd"),
            *("usmblks", "fsmblks", "uordblks", "fordblks", "keepcost"),
        )
    ]


_LIBC.mallinfo2.restype = _MallInfo2


def _pymalloc() -> list[str]:
    """`sys._debugmallocstats()`'s totals (it writes to the C stderr: read through a pipe)."""
    r, w = os.pipe()
    saved = os.dup(2)
    os.dup2(w, 2)
    try:
        sys._debugmallocstats()
    finally:
        os.dup2(saved, 2)
        os.close(saved)
        os.close(w)
    chunks = []
    while chunk := os.read(r, 65536):
        chunks.append(chunk)
    os.close(r)
    keep = ("arenas allocated current", "bytes in allocated blocks", "bytes in available")
    lines = b"".join(chunks).decode().splitlines()
    return [" ".join(line.lstrip("# ").split()) for line in lines if any(k in line for k in keep)]


def dump(label: str) -> None:
    with open("/proc/self/statm") as f:
        rss = int(f.read().split()[1]) * os.sysconf("SC_PAGE_SIZE") / 2**20
    mi = _LIBC.mallinfo2()
    frozen = gc.get_freeze_count()
    gc.unfreeze()  # count the frozen objects too (no collection: only moved back, then frozen)
    try:
        objs = gc.get_objects()
        kinds = collections.Counter(type(o).__qualname__ for o in objs).most_common(12)
        total = len(objs)
        del objs
    finally:
        if frozen:
            gc.freeze()
    lines = [
        f"== {label} at {time.strftime('%H:%M:%S')}: RSS {rss:.0f} MB",
        f"glibc heap {mi.arena / 2**20:.1f} MB, in use {mi.uordblks / 2**20:.1f} MB, free "
        f"{mi.fordblks / 2**20:.1f} MB; mmapped {mi.hblkhd / 2**20:.1f} MB",
        *_pymalloc(),
        f"objects tracked {total}: " + ", ".join(f"{k} {v}" for k, v in kinds),
    ]
    with open(OUT, "a") as f:
        f.write("\n".join(lines) + "\n")


def _drop_pool() -> None:
    import asyncio

    from app.services.playback import Playback

    gc.unfreeze()
    stopped = 0
    for pb in [o for o in gc.get_objects() if isinstance(o, Playback)]:
        if pb.worker_pid is not None:  # (no scrub in flight: the bench sends this only when idle)
            stop = pb.stop_worker("was stopped by memdiag")
            asyncio.run_coroutine_threadsafe(stop, pb.loop).result()
            stopped += 1
    gc.collect()
    _LIBC.malloc_trim(0)
    gc.freeze()
    dump(f"playback worker stopped ({stopped}), full collection, malloc_trim")


def _on(signum: int, _frame: Any) -> None:
    work = _drop_pool if signum == signal.SIGHUP else lambda: dump("now")

    def run() -> None:
        with _LOCK:
            work()

    threading.Thread(target=run, daemon=True).start()


if __name__ == "__main__":
    signal.signal(signal.SIGUSR1, _on)
    signal.signal(signal.SIGHUP, _on)
    from app.cli import main

    main()
