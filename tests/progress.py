"""Waiting for work to finish on a machine of any speed.

A fixed wall-clock deadline fails a test on a loaded machine (two CPU hogs, a load average of
40) while the work is still going on, only slower. These helpers wait while the work makes
progress, and fail only when a progress measure (a mission's simulated time, a sweep's runs
done, deliveries so far) has not changed for `stall_s` seconds: a stuck test still fails,
with what it waited for and where its progress stopped, and a slow one passes.
pytest-timeout (pyproject.toml) stays as a generous backstop for a test that hangs outright.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from typing import Any, TypeVar

T = TypeVar("T")

#: Seconds without any change in the progress measure before a wait gives up.
STALL_S = 90.0
#: A server or process starting shows no progress to measure: it is waited for as long as it
#: is alive, up to this generous limit (a few seconds on an idle machine).
START_S = 300.0
#: A test's HTTP client gives up on one request after this long: a backstop for a server that
#: hangs, far past a busy server's slowest answer.
REQUEST_S = 120.0
#: A browser test's page shows what the test waits for within this long, or an action (a
#: click) finds its element: Playwright's own defaults (5 s for `expect`, 30 s for actions)
#: are deadlines a loaded machine misses while the page is only slower.
UI_S = 90.0


class Progress:
    """Watches a progress measure: `check(value)` raises once it has not changed for
    `stall_s` seconds (for loops that do their own polling)."""

    def __init__(self, what: str, stall_s: float = STALL_S) -> None:
        self.what = what
        self.stall_s = stall_s
        self._last: Any = object()
        self._since = time.monotonic()

    def check(self, measure: Any, detail: Callable[[], Any] | None = None) -> None:
        now = time.monotonic()
        if measure != self._last:
            self._last, self._since = measure, now
        elif now - self._since > self.stall_s:
            more = f"; {detail()}" if detail is not None else ""
            raise AssertionError(
                f"no progress for {self.stall_s:g} s waiting for {self.what} "
                f"(progress stuck at {measure!r}){more}"
            )


def wait_progress(
    probe: Callable[[], T | None],
    progress: Callable[[], Any],
    what: str,
    stall_s: float = STALL_S,
    every: float = 0.05,
    sleep: Callable[[float], Any] = time.sleep,
) -> T:
    """Poll `probe()` until it returns something truthy, for as long as `progress()` keeps
    changing; fail after `stall_s` seconds with no change in it."""
    watch = Progress(what, stall_s)
    while True:
        value = probe()
        if value:
            return value
        watch.check(progress())
        sleep(every)
