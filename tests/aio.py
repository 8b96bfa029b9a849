"""`asyncio.run` for tests that may share a pytest worker with the browser tests.

pytest-playwright's sync API keeps an event loop running in the main thread for the rest of
the worker's session once a browser test has run there, and `asyncio.run` refuses to start
under a running loop ("cannot be called from a running event loop"): which tests failed then
depended on how xdist shared them out. A coroutine here runs on a thread of its own.
"""

from __future__ import annotations

import asyncio
import threading
from collections.abc import Coroutine
from typing import Any, TypeVar

T = TypeVar("T")


def run(coro: Coroutine[Any, Any, T]) -> T:
    out: list[T] = []
    failed: list[BaseException] = []

    def main() -> None:
        try:
            out.append(asyncio.run(coro))
        except BaseException as exc:  # re-raised on the caller's thread
            failed.append(exc)

    thread = threading.Thread(target=main, name="asyncio.run")
    thread.start()
    thread.join()
    if failed:
        raise failed[0]
    return out[0]
