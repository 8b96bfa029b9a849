"""WebSocket fan-out: each message is serialized once and handed to every viewer of a mission.

A viewer owns a bounded queue of ordered messages (snapshot, events, auctions, status) and a
single slot for its next frame. Frames are deltas (`app/live/frames.py`): one that arrives
while the previous is still unsent is merged into it, so a slow viewer gets fewer, larger
frames and misses no change. A viewer whose queue fills (it stopped reading) is dropped;
nothing here ever waits on a client.
"""

from __future__ import annotations

import asyncio
import contextlib
import json
import logging
import time
from collections import deque
from typing import Any

from starlette.websockets import WebSocket, WebSocketDisconnect

from app.live.frames import FrameStream, Json, Pending

log = logging.getLogger("regolith.live")

CLOSE_TOO_SLOW = 1013  # "try again later": the client fell behind its queue
CLOSE_BAD_DATA = 1003
CLOSE_TOO_BIG = 1009
CLOSE_POLICY = 1008


def encode(message: dict[str, Any]) -> str:
    """Compact JSON, NaN/inf refused (the engine's JSON-ready dicts never hold them)."""
    return json.dumps(message, separators=(",", ":"), allow_nan=False)


class FanoutStats:
    """Server-side figures for /api/metrics: frame age when handed to the socket, drops."""

    def __init__(self) -> None:
        self.frame_delays: deque[float] = deque(maxlen=5000)
        self.frames_sent = 0
        self.frames_dropped = 0
        self.viewers_dropped = 0


STATS = FanoutStats()


class Viewer:
    """One connected client: an ordered bounded queue plus a slot for its next frame."""

    def __init__(self, ws: WebSocket, max_queue: int, stream: FrameStream) -> None:
        self.ws = ws
        self.frame_at = 0.0
        self.max_queue = max_queue
        self.stream = stream
        self.queue: deque[str] = deque()
        self.frame: Pending | None = None
        self.want_full = False  # the client asked for a full frame (`resync`)
        self.overflowed = False
        self.gone = asyncio.Event()  # set when the viewer fell too far behind
        self.frames_sent = 0
        self.frames_dropped = 0
        self._wake = asyncio.Event()

    def push(self, text: str) -> None:
        """Queue an ordered message; a full queue marks the viewer for dropping."""
        if self.overflowed:
            return
        if len(self.queue) >= self.max_queue:
            self.overflowed = True
            self.queue.clear()
            self.gone.set()
        else:
            self.queue.append(text)
        self._wake.set()

    def push_frame(self, message: Json, text: str) -> None:
        """The next delta: merged into the unsent one if there is one."""
        if self.frame is not None:
            self.frames_dropped += 1
            STATS.frames_dropped += 1
            self.frame.add(message, self.stream)
        else:
            self.frame = Pending(message, text)
        self.frame_at = time.perf_counter()
        self._wake.set()

    def flush_frame(self) -> None:
        """Queue the unsent frame (or the full one asked for) in order with the messages: what
        is published next must not overtake it."""
        text = self._next_frame()
        if text is not None:
            self.push(text)

    def resync(self) -> None:
        """The client lost track (a gap in `seq`): its next frame is a full one."""
        self.want_full = True
        self._wake.set()

    def _next_frame(self) -> str | None:
        if self.want_full and self.stream.seq > 0:  # before any frame there is nothing to send
            self.want_full, self.frame = False, None
            return encode({"type": "frame", "wall": time.time(), **self.stream.full()})
        if self.frame is None:
            return None
        pending, self.frame = self.frame, None
        return pending.text if pending.text is not None else encode(pending.final(self.stream))

    async def pump(self) -> None:
        """Send queued messages in order, then the newest frame; return when dropped."""
        while True:
            await self._wake.wait()
            self._wake.clear()
            while self.queue and not self.overflowed:
                await self.ws.send_text(self.queue.popleft())
            if self.overflowed:
                return
            text = self._next_frame()
            if text is not None:
                STATS.frame_delays.append(time.perf_counter() - self.frame_at)
                await self.ws.send_text(text)
                self.frames_sent += 1
                STATS.frames_sent += 1


class Hub:
    """The viewers of one mission."""

    def __init__(self, max_queue: int) -> None:
        self.max_queue = max_queue
        self.viewers: set[Viewer] = set()
        self.stream = FrameStream()

    def __len__(self) -> int:
        return len(self.viewers)

    def join(self, ws: WebSocket, first: str) -> Viewer:
        """Register a viewer whose first message is `first` (its snapshot)."""
        viewer = Viewer(ws, self.max_queue, self.stream)
        viewer.push(first)
        self.viewers.add(viewer)
        return viewer

    def leave(self, viewer: Viewer) -> None:
        self.viewers.discard(viewer)

    def publish(self, message: dict[str, Any]) -> None:
        """An ordered message (event, auction, status) for every viewer."""
        if self.viewers:
            text = encode(message)
            for v in self.viewers:
                v.push(text)

    def publish_frame(
        self, frame: dict[str, Any], last: bool = False, ordered: bool = False
    ) -> None:
        """The delta from the last frame to the engine's `frame`, stamped with the server's
        wall clock so clients can measure delay; nothing if nothing changed.

        An `ordered` frame is queued like an event, merged with any unsent delta: a message
        published next must not overtake it (the moment a mission paused comes before the word
        "paused"). The `last` frame of a mission is ordered, and sent even if nothing changed:
        it must not be dropped.
        """
        delta = self.stream.advance(frame)
        if self.viewers and (delta is not None or last):
            body = delta if delta is not None else {**self.stream.full()}
            message = {"type": "frame", "wall": time.time(), **body}
            text = encode(message)
            for v in self.viewers:
                v.push_frame(message, text)
        if last or ordered:
            for v in self.viewers:
                v.flush_frame()

    def sync(self, frame: dict[str, Any]) -> Json:
        """Bring the stream up to `frame` (its delta goes to the current viewers) and return
        the full state at the new `seq`, for a joining viewer's snapshot."""
        self.publish_frame(frame)
        return self.stream.full()


async def _read_until_closed(ws: WebSocket, viewer: Viewer, max_message: int) -> int | None:
    """Consume client input (`{"type": "resync"}` asks for a full frame); return a close code
    for bad input, None on a clean disconnect."""
    while True:
        msg = await ws.receive()
        if msg["type"] == "websocket.disconnect":
            return None
        text, data = msg.get("text"), msg.get("bytes")
        size = len(text.encode()) if text is not None else len(data or b"")
        if size > max_message:
            return CLOSE_TOO_BIG
        if text is None:
            return CLOSE_BAD_DATA
        try:
            message = json.loads(text)
        except (ValueError, RecursionError):  # 4 KB of '[' is deeper than the parser goes
            return CLOSE_BAD_DATA
        if isinstance(message, dict) and message.get("type") == "resync":
            viewer.resync()


async def serve_viewer(ws: WebSocket, hub: Hub, viewer: Viewer, max_message: int) -> None:
    """Run one viewer until it leaves, misbehaves or falls behind; always unregister it."""
    pump = asyncio.create_task(viewer.pump())
    reader = asyncio.create_task(_read_until_closed(ws, viewer, max_message))
    gone = asyncio.create_task(viewer.gone.wait())
    tasks = (pump, reader, gone)
    code: int | None = None
    try:
        done, _ = await asyncio.wait(tasks, return_when=asyncio.FIRST_COMPLETED)
        if reader in done and not reader.cancelled() and reader.exception() is None:
            code = reader.result()
        elif gone in done or (pump in done and not pump.cancelled() and not pump.exception()):
            code = CLOSE_TOO_SLOW
            STATS.viewers_dropped += 1
            log.info("dropped a websocket viewer that fell %d messages behind", hub.max_queue)
    finally:
        hub.leave(viewer)
        for task in tasks:
            task.cancel()
        for task in tasks:
            with contextlib.suppress(asyncio.CancelledError, WebSocketDisconnect, Exception):
                await task
    if code is not None:
        with contextlib.suppress(Exception):
            await asyncio.wait_for(ws.close(code=code), timeout=1.0)
