"""The server's handle on one playback worker process (`app/services/playback_worker.py`):
requests out and answers in over its pipes (`app/services/playback_wire.py`), matched by id,
each answer checked for its shape; when the process ends, every request it still held fails
with why. Started, watched and stopped by `app/services/playback.py`.
"""

from __future__ import annotations

import asyncio
import contextlib
import itertools
import signal
from typing import Any

from app.services.errors import Conflict, Unavailable
from app.services.playback_wire import WireError, encode, read_frame

#: How long a worker told to stop may take before it is killed.
STOP_S = 10.0
_STATS = ("engines", "fills", "built", "closed", "parked")


def _checked_answer(ok: Any) -> dict[str, Any]:
    """The worker's answer, if it has the shape of one (else WireError)."""
    if not (
        isinstance(ok, dict)
        and isinstance(ok.get("state"), dict)
        and isinstance(ok.get("auctions"), list)
        and isinstance(ok.get("deliveries"), list)
        and type(ok.get("events")) is int
    ):
        raise WireError("an answer without state, auctions, deliveries and events")
    return ok


def _checked_stats(stats: Any) -> dict[str, int]:
    if not (isinstance(stats, dict) and all(type(stats.get(k)) is int for k in _STATS)):
        raise WireError("counts without " + ", ".join(_STATS))
    return {k: stats[k] for k in _STATS}


def _how(code: int) -> str:
    if code < 0:
        with contextlib.suppress(ValueError):
            return f"was killed by {signal.Signals(-code).name}"
        return f"was killed by signal {-code}"
    return f"exited with status {code}"


class Worker:
    """One worker process and the requests it holds; `gone` says why it ended, once it has."""

    def __init__(self, proc: asyncio.subprocess.Process) -> None:
        self.proc = proc
        self.pid = proc.pid
        self.pending: dict[int, asyncio.Future[dict[str, Any]]] = {}
        self.stats = dict.fromkeys(_STATS, 0)
        self.gone: str | None = None
        self._stopping: str | None = None
        self._ids = itertools.count(1)
        self._write = asyncio.Lock()
        self.done = asyncio.create_task(self._read())

    async def ask(self, message: dict[str, Any]) -> dict[str, Any]:
        """Send one request and wait for its answer (Conflict, or Unavailable if it dies)."""
        if self.gone is not None:
            raise Unavailable(f"the playback worker (pid {self.pid}) {self.gone}; try again")
        rid = next(self._ids)
        try:
            frame = encode({**message, "id": rid})
        except WireError as exc:  # a mission with more actions than a frame holds
            raise Conflict(f"this mission cannot be played back: {exc}") from exc
        future: asyncio.Future[dict[str, Any]] = asyncio.get_running_loop().create_future()
        self.pending[rid] = future
        try:
            async with self._write:
                assert self.proc.stdin is not None
                # a dead worker's pipe refuses (ConnectionError, or RuntimeError once asyncio has
                # closed it): `_read` answers the future with why it died
                with contextlib.suppress(ConnectionError, RuntimeError):
                    self.proc.stdin.write(frame)
                    await self.proc.stdin.drain()
            return await future
        finally:
            self.pending.pop(rid, None)

    async def stop(self, why: str) -> None:
        """Ask the worker to stop, kill it if it has not within `STOP_S`; wait for its end."""
        self._stopping = why
        assert self.proc.stdin is not None
        with contextlib.suppress(ConnectionError, RuntimeError):
            self.proc.stdin.write(encode({"op": "stop"}))
            self.proc.stdin.close()
        try:
            await asyncio.wait_for(asyncio.shield(self.done), STOP_S)
        except TimeoutError:
            with contextlib.suppress(ProcessLookupError):
                self.proc.kill()
            await self.done

    async def _read(self) -> None:
        """Take frames until the worker's stdout ends; then fail whatever it still held."""
        assert self.proc.stdout is not None
        why = None
        try:
            while (msg := await read_frame(self.proc.stdout)) is not None:
                self._take(msg)
        except Exception as exc:  # WireError, or anything a broken frame could cause in `_take`
            why = f"sent a malformed frame ({exc}) and was stopped"
            with contextlib.suppress(ProcessLookupError):
                self.proc.kill()
        code = await self.proc.wait()
        self.gone = self._stopping or why or _how(code)
        self.stats["engines"] = self.stats["fills"] = self.stats["parked"] = 0
        for future in self.pending.values():
            if not future.done():
                future.set_exception(
                    Unavailable(
                        f"the playback worker (pid {self.pid}) {self.gone} while this scrub "
                        "was waiting for it; try again: the next scrub starts a new worker"
                    )
                )

    def _take(self, msg: dict[str, Any]) -> None:
        if "stats" in msg:
            self.stats = _checked_stats(msg["stats"])
        rid = msg.get("id")
        if rid is None:
            return
        future = self.pending.get(rid) if type(rid) is int else None
        if future is None or future.done():
            return  # its caller went away (the answer is dropped)
        if "ok" in msg:
            future.set_result(_checked_answer(msg["ok"]))
        elif msg.get("error") == "conflict":
            future.set_exception(Conflict(str(msg.get("message"))))
        else:
            future.set_exception(
                Unavailable(f"the playback worker failed on this scrub: {msg.get('message')}")
            )
