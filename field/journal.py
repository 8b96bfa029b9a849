"""What one process of a field mission reported, numbered and kept on its own disk.

Every report an agent or the world service sends mission control (an event, an auction
record, a pose) gets the next number of its *life* (the process's name and credential
generation: `hauler-2#3`) and is written to the journal before it is sent. Mission control
takes each life's reports in number order, once (`field.intake.Sources`); what it missed —
while it was stopped, or a report the bus lost — it reads back from the journal
(`regolith/<m>/journal/<name>`), so nothing a robot did is lost while nobody listens.

Bounded: the newest `JOURNAL_ENTRIES` reports stay (in memory, and in two files on disk that
take turns); a mission control away for longer than that misses the oldest, and says so
(`first` in the answer is past what it asked for).
"""

from __future__ import annotations

import contextlib
import itertools
import json
import threading
from collections import deque
from pathlib import Path
from typing import Any

JOURNAL_ENTRIES = 200_000
"""Reports kept per life: a robot of the reference mission reports ~3,000 in a whole run."""
PAGE_BYTES = 256 * 1024
"""What one answer carries at most (a larger report goes alone)."""


def source_of(name: str, gen: int) -> str:
    """One life of a process: the name and the generation of its credential."""
    return f"{name}#{gen}"


class Journal:
    def __init__(self, name: str, gen: int, folder: Path | None, limit: int = JOURNAL_ENTRIES):
        self.source = source_of(name, gen)
        self.gen = gen
        self.limit = limit
        self._kept: deque[tuple[int, bytes]] = deque(maxlen=limit)
        self._next = 0
        self._lock = threading.Lock()
        self._path: Path | None = None
        self._file: Any = None
        self._in_file = 0
        if folder is not None:
            folder.mkdir(parents=True, exist_ok=True, mode=0o700)
            self._path = folder / f"{name}-{gen}.jsonl"
            self._file = self._path.open("ab")

    def record(self, data: dict[str, Any]) -> dict[str, Any]:
        """`data` numbered (`rseq`) and kept; what to send."""
        with self._lock:
            out = {**data, "rseq": self._next}
            self._next += 1
            line = json.dumps(out, separators=(",", ":"), allow_nan=False).encode()
            self._kept.append((out["rseq"], line))
            self._write(line)
        return out

    def _write(self, line: bytes) -> None:
        if self._file is None or self._path is None:
            return
        try:
            if self._in_file >= self.limit // 2:  # the older half goes: bounded on disk too
                self._file.close()
                self._path.replace(self._path.with_suffix(".jsonl.1"))
                self._file, self._in_file = self._path.open("ab"), 0
            self._file.write(line + b"\n")
            self._file.flush()
            self._in_file += 1
        except OSError:  # a full disk does not stop the robot: memory still holds it
            self._file = None

    @property
    def next(self) -> int:
        return self._next

    def after(self, rseq: int, budget: int = PAGE_BYTES) -> dict[str, Any]:
        """The reports numbered above `rseq`, oldest first, up to `budget` bytes; `next` is
        the number the next report will get, `first` the oldest still kept."""
        out: list[Any] = []
        used = 0
        with self._lock:
            first = self._kept[0][0] if self._kept else self._next
            for _n, line in itertools.islice(self._kept, max(0, rseq + 1 - first), None):
                if out and used + len(line) > budget:
                    break
                out.append(line)
                used += len(line)
            nxt = self._next
        entries = [json.loads(line) for line in out]
        return {"gen": self.gen, "first": first, "next": nxt, "entries": entries}

    def close(self) -> None:
        with contextlib.suppress(OSError):
            if self._file is not None:
                self._file.close()
        self._file = None


def serve(link: Any, journal: Journal, key: str, query: Any) -> None:
    """Answer mission control's read of `journal` (a query on `key`; only mission control may
    read it back: the reports went to it alone)."""
    got = link.take_control_query(query, key, "journal")
    if got is None:
        return
    _opened, req = got
    after = (req.get("args") or {}).get("after")
    if type(after) is not int or not -1 <= after < 2**53:
        link.reply(query, key, req, {"ok": False, "error": "after: an integer >= -1"})
        return
    link.reply(query, key, req, {"ok": True, "value": journal.after(after)})


def read_file(
    folder: Path, name: str, gen: int, after: int, budget: int = PAGE_BYTES
) -> dict[str, Any]:
    """`Journal.after` of a life that has ended, from the files it left on this disk (the
    world service's process reads back its dead agents' journals for mission control)."""
    base = folder / f"{name}-{gen}.jsonl"
    entries: list[Any] = []
    first: int | None = None
    used = 0
    nxt = 0
    full = False
    for path in (base.with_suffix(".jsonl.1"), base):
        with contextlib.suppress(OSError), path.open("rb") as f:
            for line in f:
                try:
                    d = json.loads(line)
                except ValueError:
                    break  # a line cut short by the process's death: the end
                n = int(d.get("rseq", -1))
                first = n if first is None else first
                nxt = n + 1
                full = full or bool(entries and used + len(line) > budget)
                if n > after and not full:
                    entries.append(d)
                    used += len(line)
    return {"gen": gen, "first": nxt if first is None else first, "next": nxt, "entries": entries}
