"""Who has heard whom, and when: each robot's own view of its peers' heartbeats.

Heartbeats are broadcast like every message, but N robots each hearing N heartbeats is
N² handler calls per period, which dominates large missions. So heartbeat delivery writes
into this board instead: `heard[r, s]` is when receiver r last heard anything from sender s,
and r reads the content of the last heartbeat *it* received. Loss is still drawn per
receiver; latency and jitter are drawn once per heartbeat (shared by all its receivers).
"""

from __future__ import annotations

from collections import deque

import numpy as np

from engine.messages import Heartbeat

HISTORY = 64
"""Heartbeats kept per sender; a receiver that missed more than this sees none (safe: silent).
Scale 100 keeps 1,201 × 64 of them, 144 bytes each (a slotted message)."""


class Liveness:
    def __init__(self, capacity: int = 16) -> None:
        self.index: dict[str, int] = {}
        self.names: list[str] = []
        self.heard = _board(capacity, np.inf, np.float64)  # inf: never heard (never silent)
        self.hb_seen = _board(capacity, -1, np.int64)
        # floor[s] <= heard[r, s] for every receiver r: a column write sets it, a single
        # entry only grows. `_floor_min` is a (possibly stale, hence lower) bound of its
        # minimum, so `silent` answers "nobody" without a look at the row in the usual case.
        self.floor = np.full(capacity, np.inf)
        self._floor_min = np.inf
        self._history: dict[str, deque[tuple[int, Heartbeat]]] = {}
        self._hb_serial: dict[str, int] = {}

    def add(self, name: str) -> int:
        if name in self.index:
            return self.index[name]
        i = len(self.names)
        if i >= self.heard.shape[0]:
            self.reserve(self.heard.shape[0] * 2)
        self.index[name] = i
        self.names.append(name)
        self._history[name] = deque(maxlen=HISTORY)
        self._hb_serial[name] = -1
        return i

    def reserve(self, capacity: int) -> None:
        """Room for this many robots (a team known in advance is held exactly: doubling to
        1,201 robots took 2,048² entries, 64 MB for the two boards instead of 23)."""
        i = len(self.names)
        if capacity <= self.heard.shape[0]:
            return
        heard = _board(capacity, np.inf, np.float64)
        heard[:i, :i] = self.heard[:i, :i]
        seen = _board(capacity, -1, np.int64)
        seen[:i, :i] = self.hb_seen[:i, :i]
        floor = np.full(capacity, np.inf)
        floor[:i] = self.floor[:i]
        self.heard, self.hb_seen, self.floor = heard, seen, floor

    def introduce_all(self, t: float) -> None:
        """The team that starts together has 'heard' each other at the start (the roster)."""
        n = len(self.names)
        self.heard[:n, :n] = t
        self.floor[:n] = t
        self._floor_min = t if n else np.inf

    def record_heartbeat(self, hb: Heartbeat) -> int:
        """Store a sent heartbeat; returns its serial for delivery."""
        n = self._hb_serial[hb.sender] + 1
        self._hb_serial[hb.sender] = n
        self._history[hb.sender].append((n, hb))
        return n

    def deliver_heartbeat(
        self, sender: str, serial: int, receivers: np.ndarray | None, t: float
    ) -> None:
        """`receivers` None: everyone heard it (the ideal bus), a cheap column write."""
        s = self.index[sender]
        if receivers is None:
            n = len(self.names)
            self.heard[:n, s] = t
            self._column_heard(s, t)
            self.hb_seen[:n, s] = serial  # serials only grow, and this one reached all
            return
        self.heard[receivers, s] = t
        self._first_heard(s, t)
        self.hb_seen[receivers, s] = np.maximum(self.hb_seen[receivers, s], serial)

    def _column_heard(self, s: int, t: float) -> None:
        """Everyone heard `s` at `t`: its floor rises to `t`, or comes down from inf (its first
        hearing), and then the minimum must come down too."""
        self.floor[s] = t
        self._floor_min = min(self._floor_min, t)

    def _first_heard(self, s: int, t: float) -> None:
        """A single write can set an entry never heard before (inf) to `t`: the floor must
        come down to it (every other entry is at least the floor already)."""
        if t < self.floor[s]:
            self.floor[s] = t
            self._floor_min = min(self._floor_min, t)

    def heard_everywhere(self, sender: str, t: float) -> None:
        s = self.index.get(sender)
        if s is not None:
            self.heard[: len(self.names), s] = t
            self._column_heard(s, t)

    def heard_from(self, receiver: str, sender: str, t: float) -> None:
        r, s = self.index.get(receiver), self.index.get(sender)
        if r is not None and s is not None:
            self.heard[r, s] = t
            self._first_heard(s, t)

    def excuse(self, receiver: str, since: float, until: float) -> None:
        """`receiver` was not listening from `since` to `until` (in the field: its process got
        no CPU): that time does not count as its peers' silence. Every peer it has heard is
        heard `until - since` later (no later than `until`); entries only grow, so the
        floors stay lower bounds."""
        r, gap = self.index.get(receiver), until - since
        if r is None or gap <= 0:
            return
        row = self.heard[r, : len(self.names)]
        heard = np.isfinite(row)
        row[heard] = np.minimum(row[heard] + gap, until)

    def last_heard(self, receiver: str, sender: str) -> float:
        r, s = self.index.get(receiver), self.index.get(sender)
        if r is None or s is None:
            return -np.inf
        t: float = self.heard.item(r, s)
        return -np.inf if t == np.inf else t

    def last_heartbeat(self, receiver: str, sender: str) -> Heartbeat | None:
        """The last heartbeat of `sender` that `receiver` heard (asked 29 million times in a
        scale-100 mission, so the board is read without numpy scalars)."""
        r, s = self.index.get(receiver), self.index.get(sender)
        if r is None or s is None:
            return None
        want: int = self.hb_seen.item(r, s)
        if want < 0:
            return None
        history = self._history[sender]
        if history and history[-1][0] == want:  # the newest, nearly always
            return history[-1][1]
        for serial, hb in reversed(history):
            if serial == want:
                return hb
            if serial < want:
                break
        return None

    def last_heartbeat_about(self, receiver: str, sender: str, task_id: str) -> Heartbeat | None:
        """The latest heartbeat of `sender` up to the last one `receiver` heard that listed
        `task_id` (the holder's last word on a task, even if it has since come back without it)."""
        r, s = self.index.get(receiver), self.index.get(sender)
        if r is None or s is None:
            return None
        want = int(self.hb_seen[r, s])
        for serial, hb in reversed(self._history[sender]):
            if serial <= want and task_id in hb.tasks:
                return hb
        return None

    def holder_of(self, receiver: str, task_id: str, but: str | None = None) -> str | None:
        """The robot (other than `but`) whose last heartbeat `receiver` heard lists the task
        (the latest heard, if several): who holds it, as far as `receiver` knows."""
        best: tuple[float, str] | None = None
        for sender in self.names:
            hb = None if sender == but else self.last_heartbeat(receiver, sender)
            if hb is not None and task_id in hb.tasks and (best is None or hb.t > best[0]):
                best = (hb.t, sender)
        return None if best is None else best[1]

    def silent(self, receiver: str, now: float, timeout: float) -> list[str]:
        """Peers this receiver has heard at least once but not within `timeout`."""
        r = self.index[receiver]
        before = now - timeout
        if self._floor_min >= before:
            return []
        self._floor_min = float(self.floor[: len(self.names)].min())
        if self._floor_min >= before:
            return []
        idx = np.flatnonzero(self.heard[r, : len(self.names)] < before)
        return [self.names[i] for i in idx if i != r]


def _board(capacity: int, fill: float, dtype: type[np.generic]) -> np.ndarray:
    """A [receiver, sender] matrix stored column by column (order="F"): every message and
    every heartbeat on the ideal bus writes a sender's whole column, while a receiver's row is
    read only when some peer may be silent (at 1,200 robots a column write took 20 µs stored
    row by row, 2.6 µs column by column)."""
    return np.full((capacity, capacity), fill, dtype=dtype, order="F")
