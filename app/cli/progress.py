"""`regolith run`'s and `regolith fleet run`'s progress line: simulated time, minerals and
sites, in place on a terminal.

A long mission (a lossy bus, a large scale) can take minutes; on a terminal stderr shows
where it is, rewritten at most `every_s` of wall time apart and erased at the end. Nothing is
printed when stderr is not a terminal (a pipe, a log file, CI) or with `--json`.

The mission is driven in steps of simulated time (`Mission.advance`, as the live server drives
it), which gives the same run, bit for bit, as running it in one go (`run_mission`).
"""

from __future__ import annotations

import time
from collections.abc import Iterable
from typing import Any, TextIO

from engine import Mission
from engine.collector import collector_paused
from engine.mission import PlannerKind
from engine.scenario import Scenario

STEP_S = 10.0  # simulated seconds per step between looks at the wall clock


def _clock(seconds: float) -> str:
    s = int(seconds)
    return f"{s // 3600}:{s % 3600 // 60:02d}:{s % 60:02d}"


class ProgressLine:
    """One status line on `out`, rewritten in place (carriage return, erase to line end)."""

    def __init__(self, out: TextIO, every_s: float = 0.2) -> None:
        self.out = out
        self.every_s = every_s
        self._start = time.monotonic()
        self._last = -float("inf")

    def show(self, m: Mission, force: bool = False) -> None:
        if force or self.due():
            c = m.counters()
            self.write(
                m.now,
                c["minerals_delivered"],
                c["minerals_total"],
                c["sites_found"],
                c["sites_total"],
            )

    def due(self) -> bool:
        """True (and the clock restarted) when the line may be rewritten."""
        now = time.monotonic()
        if now - self._last < self.every_s:
            return False
        self._last = now
        return True

    def write(
        self, t: float, minerals: int, minerals_total: int, sites: int, sites_total: int
    ) -> None:
        """What is known, and only that: the simulated time reached (the end is not known
        before the last delivery: the scenario's `max_time_s` is a timeout cap, not an
        estimate), minerals and sites against their totals, and the wall time so far."""
        line = (
            f"t {t:,.0f} s simulated"
            f" | minerals {minerals}/{minerals_total}"
            f" | sites {sites}/{sites_total}"
            f" | {_clock(time.monotonic() - self._start)} elapsed"
        )
        self.out.write(f"\r{line}\x1b[K")
        self.out.flush()

    def clear(self) -> None:
        self.out.write("\r\x1b[K")
        self.out.flush()


def run_with_progress(
    scenario: Scenario,
    seed: int,
    policy: str,
    actions: Iterable[dict[str, Any]],
    line: ProgressLine,
    planner: PlannerKind = "ompl",
) -> dict[str, Any]:
    """`engine.run_mission`, showing its progress on `line` as it goes."""
    m = Mission(scenario, seed, policy, planner, keep_events=False)
    try:
        try:
            with collector_paused():
                for action in sorted(actions, key=lambda a: float(a["t"])):
                    _advance(m, float(action["t"]), line)
                    m.apply(action)
                _advance(m, float("inf"), line)
        finally:
            line.clear()
        return m.metrics()
    finally:
        m.close()


def _advance(m: Mission, until: float, line: ProgressLine) -> None:
    while not m.done and m.now < until:
        m.advance(min(until, m.now + STEP_S))
        line.show(m)
