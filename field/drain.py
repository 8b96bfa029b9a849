"""Subscribers and queryables whose network threads never wait for Python.

A Python callback handed to Zenoh runs on a thread of zenoh-python's, fed through a bounded
channel; when the callback falls behind, the channel fills and Zenoh's network thread waits
on it, and that thread is the one that reads every other link of the session too. A callback
falls behind easily: it needs the GIL, which an agent's clock loop holds most of the time at
100x. Seen in field chaos runs: mission control's two network threads parked on its
intake's full channel, every socket's receive queue full, the agents' puts and queries
waiting on mission control, the world service unasked, and the whole mission stalled for
good, with every process idle.

So each subscriber and queryable of field mode is declared with a ring channel, which never
makes a network thread wait (when full, its oldest item goes, as on a lossy bus: the protocol
re-sends, an asker asks again), and is drained by a thread of ours. What must not be lost (an
agent's reports) gets a deep FIFO channel instead, which waits only once that is full.

A draining thread must have ended before the interpreter finalizes: one still waiting in
Zenoh's `recv` then wakes (the session is dropped), cannot have the GIL back, and the thread
exit that CPython forces on it unwinds through Rust frames that catch it, which aborts the
whole process ("FATAL: exception not rethrown", seen as `regolith fleet run` exiting with
SIGABRT after a completed mission). So `undeclare` waits for the thread, and every drain
still declared at exit is undeclared by an `atexit` hook, which runs before finalization.
"""

from __future__ import annotations

import atexit
import contextlib
import logging
import threading
import weakref
from collections.abc import Callable
from typing import Any

import zenoh

log = logging.getLogger("regolith.field.drain")

#: Items waiting for the draining thread before the oldest go (a ring) or the network
#: thread waits (a FIFO): seconds of a mission's traffic at 100x, and with each message
#: capped by the session (`field.transport.open_session`), a bounded amount of memory
#: whatever a hostile sender floods.
RING = 1024
FIFO = 1024
#: how long `undeclare` waits for the draining thread to finish the item in hand
JOIN_S = 2.0

_declared: weakref.WeakSet[Drain] = weakref.WeakSet()


class Drain:
    """`declare(key, channel, **options)` (a session's `declare_subscriber` or
    `declare_queryable`, or a liveliness one), with `work` called on every item it takes
    in, one at a time, on a thread of its own. `undeclare` ends the thread."""

    def __init__(
        self,
        declare: Callable[..., Any],
        key: str,
        work: Callable[[Any], None],
        name: str,
        lossless: bool = False,
        **options: Any,
    ) -> None:
        channel: Any = (
            zenoh.handlers.FifoChannel(FIFO) if lossless else zenoh.handlers.RingChannel(RING)
        )
        self.declared = declare(key, channel, **options)
        self._handler = self.declared.handler
        self._work = work
        self._thread = threading.Thread(target=self._run, name=f"drain {name}", daemon=True)
        self._thread.start()
        _declared.add(self)

    def _run(self) -> None:
        while True:
            try:
                item = self._handler.recv()
            except Exception:  # the channel is closed: undeclared, or the session ended
                return
            try:
                self._work(item)
            except Exception:
                log.exception("%s: an item could not be handled", self._thread.name)
            # let it go before waiting for the next: a query is answered as done (its asker
            # stops waiting) only once its object is gone
            del item

    def undeclare(self) -> None:
        """Undeclare, and wait for the draining thread to end (its channel closes)."""
        _declared.discard(self)
        with contextlib.suppress(Exception):  # the session may be gone already
            self.declared.undeclare()
        if threading.current_thread() is not self._thread:
            self._thread.join(JOIN_S)


@atexit.register
def _undeclare_all() -> None:
    """Every drain still declared at exit, undeclared while the interpreter still runs."""
    for drain in list(_declared):
        drain.undeclare()
