"""The playback worker: a process of its own that holds the replay engines (`Pool`).

Started by the server (`app/services/playback.py`) on the first scrub and stopped when idle,
it reads requests from stdin and writes answers to stdout as frames
(`app/services/playback_wire.py`). Its engines and their garbage live in its own heap: the
server's allocator arenas are never pinned by them, and stopping it gives all of it back to
the system. It gets everything a replay needs in the request (scenario, seed, policy,
planner, the replayable actions up to the moment) and opens no database.

    request  {"id": n, "op": "state", "mission": {id, scenario, seed, policy, planner},
              "actions": [...], "t": t, "end": end}
    answer   {"id": n, "ok": {state, auctions, deliveries, events}, "stats": {...}}
             {"id": n, "error": "conflict" | "internal", "message": "...", "stats": {...}}
    counts   {"stats": {engines, fills, built, closed, parked}}  (whenever they change)
    stop     {"op": "stop"}, or the end of stdin (the server is gone)
"""

from __future__ import annotations

import argparse
import asyncio
import os
import sys
from typing import Any

from app.services.errors import Conflict
from app.services.playback_pool import Pool, Spec
from app.services.playback_wire import WireError, encode, read_frame
from experiments.lifeline import die_with

_STATS_EVERY_S = 0.1


class _Out:
    """Frames to the server, one whole frame at a time."""

    def __init__(self, writer: asyncio.StreamWriter) -> None:
        self.writer = writer
        self.lock = asyncio.Lock()

    async def send(self, message: dict[str, Any]) -> None:
        async with self.lock:
            self.writer.write(encode(message))
            await self.writer.drain()


async def _answer(pool: Pool, out: _Out, msg: dict[str, Any]) -> None:
    rid = msg.get("id")
    try:
        m = msg["mission"]
        spec = Spec(
            int(m["id"]), dict(m["scenario"]), int(m["seed"]), str(m["policy"]), str(m["planner"])
        )
        actions = [dict(a) for a in msg["actions"]]
        reply: dict[str, Any] = {
            "id": rid,
            "ok": await pool.state_at(spec, actions, float(msg["t"]), float(msg["end"])),
        }
    except Conflict as exc:
        reply = {"id": rid, "error": "conflict", "message": exc.message}
    except Exception as exc:  # a bug or a malformed request: said to the server, not fatal here
        reply = {"id": rid, "error": "internal", "message": f"{type(exc).__name__}: {exc}"}
    reply["stats"] = pool.stats()
    await out.send(reply)


async def _push_stats(pool: Pool, out: _Out) -> None:
    """The pool's counts whenever they change (checkpoint builds start and end between
    answers), so the server's metrics stay true."""
    last: dict[str, int] = {}
    while True:
        now = pool.stats()
        if now != last:
            await out.send({"stats": now})
            last = now
        await asyncio.sleep(_STATS_EVERY_S)


async def serve(capacity: int, per_mission: int, in_fd: int, out_fd: int) -> None:
    """Answer requests until told to stop or stdin ends."""
    loop = asyncio.get_running_loop()
    reader = asyncio.StreamReader(limit=2**20)
    await loop.connect_read_pipe(
        lambda: asyncio.StreamReaderProtocol(reader), os.fdopen(in_fd, "rb", buffering=0)
    )
    transport, protocol = await loop.connect_write_pipe(
        asyncio.streams.FlowControlMixin, os.fdopen(out_fd, "wb", buffering=0)
    )
    out = _Out(asyncio.StreamWriter(transport, protocol, None, loop))
    pool = Pool(capacity, per_mission)
    tasks: set[asyncio.Task[None]] = set()
    stats = asyncio.create_task(_push_stats(pool, out))
    try:
        while (msg := await read_frame(reader)) is not None:
            if msg.get("op") == "stop":
                break
            if msg.get("op") == "state":
                task = asyncio.create_task(_answer(pool, out, msg))
                tasks.add(task)
                task.add_done_callback(tasks.discard)
    except WireError as exc:
        print(f"playback worker: {exc}; stopping", file=sys.stderr)
    finally:
        stats.cancel()
        for task in list(tasks):
            task.cancel()
        await pool.aclose()


def main(argv: list[str] | None = None) -> None:
    ap = argparse.ArgumentParser(description="Regolith's playback worker (started by the server)")
    ap.add_argument("--cursors", type=int, required=True)
    ap.add_argument("--per-mission", type=int, required=True)
    args = ap.parse_args(argv)
    # the end of stdin stops it when the server goes; this also ends it if the server is killed
    # while another process holds that pipe open, or its loop is stuck
    die_with(os.getppid())
    # frames go to a private copy of stdout; anything printed (by native code too) goes to stderr
    out_fd = os.dup(1)
    os.dup2(2, 1)
    asyncio.run(serve(args.cursors, args.per_mission, 0, out_fd))


if __name__ == "__main__":
    main()
