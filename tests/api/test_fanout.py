"""Fan-out rules without a network: order kept, stale frames replaced, laggards dropped."""

from __future__ import annotations

import asyncio
import json
from concurrent.futures import ThreadPoolExecutor
from typing import Any

from app.live.hub import CLOSE_BAD_DATA, CLOSE_TOO_BIG, CLOSE_TOO_SLOW, Hub, Viewer, serve_viewer
from tests.progress import STALL_S


class FakeSocket:
    """A client: `stalled` never lets a send finish; `inbox` is what it sends us."""

    def __init__(self, stalled: bool = False, inbox: list[dict[str, Any]] | None = None) -> None:
        self.stalled = stalled
        self.sent: list[dict[str, Any]] = []
        self.inbox = list(inbox or [])
        self.closed: int | None = None
        self._never = asyncio.Event()
        self._sent_more = asyncio.Event()

    async def send_text(self, text: str) -> None:
        if self.stalled:
            await self._never.wait()
        self.sent.append(json.loads(text))
        self._sent_more.set()

    async def wait_sent(self, n: int) -> None:
        """Until `n` messages have been sent (`_run`'s timeout bounds the wait)."""
        while len(self.sent) < n:
            self._sent_more.clear()
            await self._sent_more.wait()

    async def receive(self) -> dict[str, Any]:
        if self.inbox:
            return self.inbox.pop(0)
        await self._never.wait()
        raise AssertionError

    async def close(self, code: int = 1000) -> None:
        self.closed = code


def _run(coro: Any) -> Any:
    """On a thread of its own: under pytest-xdist a worker may have run a Playwright test
    before, whose event loop still runs on the main thread."""
    with ThreadPoolExecutor(1) as pool:
        return pool.submit(asyncio.run, asyncio.wait_for(coro, timeout=STALL_S)).result()


def _drained(viewer: Viewer) -> bool:
    """Nothing left to send: no queued message and no pending frame."""
    return not viewer.queue and viewer.frame is None


def _kinds(ws: FakeSocket) -> list[tuple[str, Any]]:
    """What was sent, in order: each message's type and its `n` (or a frame's time)."""
    return [(m["type"], m.get("n", m.get("t"))) for m in ws.sent]


def _frame(t: float, x: float = 0.0, state: str = "idle") -> dict[str, Any]:
    """An engine frame of one robot (the fields `Mission.frame()` has)."""
    robot = {"name": "scout-1", "type": "scout", "state": state, "x": x, "y": 1.0}
    robot |= {"heading": 0.0, "load": 0, "alive": True}
    counters = {"sites_found": int(t)}
    head = {"t": t, "status": "running", "policy": "fcfs", "robots": [robot]}
    return head | {"scanned": "AA==", "scanned_count": 0, "counters": counters}


def test_ordered_messages_keep_order_and_unsent_frames_are_merged() -> None:
    async def scenario() -> FakeSocket:
        hub = Hub(max_queue=100)
        ws = FakeSocket()
        viewer = hub.join(ws, json.dumps({"type": "snapshot"}))  # type: ignore[arg-type]
        hub.publish_frame(_frame(0, x=1.0))
        hub.publish_frame(_frame(1, x=2.0, state="scanning"))
        hub.publish({"type": "event", "n": 1})
        hub.publish_frame(_frame(2, x=3.0, state="scanning"))
        task = asyncio.create_task(serve_viewer(ws, hub, viewer, 4096))  # type: ignore[arg-type]
        await ws.wait_sent(3)  # the snapshot, the event and one merged frame ...
        assert _drained(viewer)  # ... and nothing else is waiting to go
        hub.publish_frame(_frame(9, x=4.0), last=True)
        await ws.wait_sent(4)
        assert _drained(viewer)
        task.cancel()
        return ws

    ws = _run(scenario())
    assert _kinds(ws) == [("snapshot", None), ("event", 1), ("frame", 2), ("frame", 9)]
    merged, last = ws.sent[2], ws.sent[3]
    # three deltas not yet sent went as one: from the first's base to the last's seq, the
    # robot whole (its state changed) at its newest pose, the newest counters
    assert (merged["base"], merged["seq"], last["base"], last["seq"]) == (0, 3, 3, 4)
    assert merged["robots"] == [_frame(2, x=3.0, state="scanning")["robots"][0]]
    assert merged["counters"] == {"sites_found": 2} and "poses" not in merged
    assert last["robots"] == [_frame(9, x=4.0)["robots"][0]]  # state changed back
    assert all("wall" in m for m in ws.sent if m["type"] == "frame")


def test_an_ordered_frame_is_not_overtaken_by_the_message_after_it() -> None:
    """A pause: the viewer told "paused" has already seen the mission at the pause (its
    counters), even with a delta unsent before it, or none to send at all."""

    async def scenario() -> FakeSocket:
        hub = Hub(max_queue=100)
        ws = FakeSocket()
        viewer = hub.join(ws, json.dumps({"type": "snapshot"}))  # type: ignore[arg-type]
        # three pauses: the first with a delta unsent before its own; the second with only an
        # unsent one (nothing new at the pause); the third with nothing to send at all
        hub.publish_frame(_frame(1, x=1.0))
        for n, frame in enumerate([_frame(2, x=2.0), _frame(3, x=3.0), _frame(3, x=3.0)], 1):
            if n == 2:
                hub.publish_frame(frame)
            hub.publish_frame(frame, ordered=True)
            hub.publish({"type": "status", "n": n})
        task = asyncio.create_task(serve_viewer(ws, hub, viewer, 4096))  # type: ignore[arg-type]
        await ws.wait_sent(6)
        assert _drained(viewer)
        task.cancel()
        return ws

    ws = _run(scenario())
    assert _kinds(ws) == [
        ("snapshot", None),
        ("frame", 2),
        ("status", 1),
        ("frame", 3),
        ("status", 2),
        ("status", 3),
    ]
    assert ws.sent[1]["counters"] == {"sites_found": 2}  # the two deltas as one
    assert ws.sent[3]["counters"] == {"sites_found": 3}


def test_a_viewer_that_stops_reading_is_dropped_and_others_are_not_slowed() -> None:
    async def scenario() -> tuple[FakeSocket, FakeSocket, Hub]:
        hub = Hub(max_queue=50)
        stuck, fine = FakeSocket(stalled=True), FakeSocket()
        tasks = []
        for ws in (stuck, fine):
            viewer = hub.join(ws, "{}")  # type: ignore[arg-type]
            tasks.append(asyncio.create_task(serve_viewer(ws, hub, viewer, 4096)))  # type: ignore[arg-type]
        for i in range(200):
            hub.publish({"type": "event", "n": i})
            await asyncio.sleep(0)
        await asyncio.wait_for(tasks[0], timeout=STALL_S)  # the stuck one is gone
        await fine.wait_sent(1 + 200)  # the other got its snapshot and every event
        tasks[1].cancel()
        return stuck, fine, hub

    stuck, fine, hub = _run(scenario())
    assert stuck.closed == CLOSE_TOO_SLOW
    assert len(hub) == 0
    assert [m.get("n") for m in fine.sent[1:]] == list(range(200))


def test_bad_client_input_closes_that_socket_with_a_proper_code() -> None:
    cases = [
        ({"type": "websocket.receive", "text": "not json"}, CLOSE_BAD_DATA),
        ({"type": "websocket.receive", "bytes": b"\x00"}, CLOSE_BAD_DATA),
        ({"type": "websocket.receive", "text": json.dumps({"x": "y" * 5000})}, CLOSE_TOO_BIG),
    ]
    for message, code in cases:
        ws = FakeSocket(inbox=[{"type": "websocket.receive", "text": "{}"}, message])
        hub = Hub(max_queue=10)
        viewer = hub.join(ws, "{}")  # type: ignore[arg-type]
        _run(serve_viewer(ws, hub, viewer, 4096))  # type: ignore[arg-type]
        assert ws.closed == code and len(hub) == 0


def test_a_resync_is_answered_with_a_full_frame_once_there_is_one() -> None:
    async def scenario() -> FakeSocket:
        hub = Hub(max_queue=10)
        resync = {"type": "websocket.receive", "text": json.dumps({"type": "resync"})}
        ws = FakeSocket(inbox=[resync])
        viewer = hub.join(ws, json.dumps({"type": "snapshot"}))  # type: ignore[arg-type]
        task = asyncio.create_task(serve_viewer(ws, hub, viewer, 4096))  # type: ignore[arg-type]
        await ws.wait_sent(1)
        await asyncio.sleep(0.05)  # the resync was read: nothing streamed yet, nothing sent
        assert len(ws.sent) == 1 and viewer.want_full
        hub.publish_frame(_frame(1, x=2.0))
        await ws.wait_sent(2)
        hub.publish_frame(_frame(2, x=3.0))
        await ws.wait_sent(3)
        task.cancel()
        return ws

    ws = _run(scenario())
    full, delta = ws.sent[1], ws.sent[2]
    assert full["full"] is True and full["seq"] == 1 and "base" not in full
    assert full["robots"] == [_frame(1, x=2.0)["robots"][0]] and full["scanned"] == "AA=="
    assert (delta["base"], delta["seq"], delta["poses"]) == (1, 2, [0, 3.0, 1.0, 0.0])
