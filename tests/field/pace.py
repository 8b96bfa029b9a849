"""A field test's wall-clock speed, chosen for the CPU the machine has to spare.

A field mission runs against the wall clock: at 100x, the protocol's 30 s failure timeout is
0.3 s of wall time. On a machine already busy (two CPU hogs on two cores) the same speed
starved mission control and the agents alike, and the test measured the machine, not the
protocol. So a test measures how busy the machine is before it starts its agents and slows
the mission down, by half for each core's worth of other work, to a quarter at most: what is
checked is unchanged, only the pace.
"""

from __future__ import annotations

import os
import time


def _cpu_times() -> tuple[float, float]:
    with open("/proc/stat") as f:
        fields = [float(x) for x in f.readline().split()[1:]]
    idle = fields[3] + fields[4]  # idle + iowait
    return sum(fields), idle


def busy_cores(window_s: float = 1.0) -> float:
    """How many cores' worth of work ran during the last `window_s` seconds."""
    try:
        total0, idle0 = _cpu_times()
        time.sleep(window_s)
        total1, idle1 = _cpu_times()
    except (OSError, ValueError, IndexError):
        return 0.0
    spent = total1 - total0
    if spent <= 0:
        return 0.0
    return (1.0 - (idle1 - idle0) / spent) * (os.cpu_count() or 1)


def paced(nominal: float) -> float:
    """`nominal` on an idle machine; half with a core's worth of other work, a quarter with
    two or more."""
    busy = busy_cores()
    factor = 1 if busy < 0.5 else 2 if busy < 1.5 else 4
    if factor > 1:
        print(f"field test pace: {busy:.1f} cores busy before it starts: {nominal / factor:g}x")
    return nominal / factor
