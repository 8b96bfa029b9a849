"""A field test's wall-clock speed, chosen for the CPU the machine has to spare.

A field mission runs against the wall clock: at 100x, the protocol's 30 s failure timeout is
0.3 s of wall time. A machine that cannot keep up with the fleet's messages reads heartbeats
late, every robot declares its peers failed, the takeovers and auctions again add messages,
and the mission seizes up: the test then measures the machine, not the protocol. Two things
make a machine unable to keep up, and both are measured before a test starts its agents:

- other work already running (`busy_cores`: two CPU hogs on two cores);
- a slow core (`message_cost_s`: one protocol message as every agent pays for it, encoded,
  signed, verified and decoded: 0.19-0.30 ms on one idle machine of this project's type in
  one afternoon, where the engine's scale-10 benchmark took 4.1-4.9 s against 2.9 s on
  another of the same type the day before).

The fleet's CPU at a speed is then `speed * FLEET_LOAD * message_cost_s()` cores, and the
speed is lowered step by step (`SLOWER`), to a quarter at most, until that fits in the spare
cores with headroom (`HEADROOM`). What is checked is unchanged, only the pace.
"""

from __future__ import annotations

import json
import os
import time

from cryptography.hazmat.primitives.asymmetric.ed25519 import Ed25519PrivateKey

# Messages a second of mission time that the reference team's processes handle between
# them, counted in `message_cost_s` units. Measured: at 100x, twelve agents and the world
# kept 2.6 cores busy where one such message cost 0.2 ms (2.6 / (100 * 0.0002) = 130).
FLEET_LOAD = 130.0
# The share of the spare cores the fleet may take. Measured on that machine: at 100x the
# fleet wanted 1.3 times its two cores and seized up as above; at 50x (0.65 of them) the
# same chaos seed finished.
HEADROOM = 0.7
# The nominal speed divided by each in turn; a quarter at most, so a test's length stays
# bounded. Steps finer than halving: a machine just too slow for 50x runs at 33x, not 25x.
SLOWER = (1.0, 1.5, 2.0, 3.0, 4.0)

_HEARTBEAT = {
    "v": 1,
    "sender": "hauler-1",
    "t": 1234.5,
    "state": "idle",
    "route": [[i * 0.5, i * 0.25] for i in range(60)],  # ~2 KB, as a heartbeat with its route
    "tasks": ["excavate@12.500,40.250"] * 3,
}


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


def message_cost_s(messages: int = 100, tries: int = 5) -> float:
    """Seconds this machine takes, now, for one protocol message as the agents handle it
    (the best of `tries`: the floor, not a moment's noise)."""
    key = Ed25519PrivateKey.generate()
    public = key.public_key()
    best = float("inf")
    for _ in range(tries):
        start = time.perf_counter()
        for _ in range(messages):
            body = json.dumps(_HEARTBEAT).encode()
            public.verify(key.sign(body), body)
            json.loads(body)
        best = min(best, time.perf_counter() - start)
    return best / messages


def paced(nominal: float) -> float:
    """The fastest of `nominal / f` (f in `SLOWER`) at which the fleet's CPU fits the
    machine's spare cores with headroom (the slowest if none does)."""
    spare = max((os.cpu_count() or 1) - busy_cores(), 0.25)
    cost = message_cost_s()
    fits = [f for f in SLOWER if nominal / f * FLEET_LOAD * cost <= HEADROOM * spare]
    speed = round(nominal / (fits[0] if fits else SLOWER[-1]), 1)
    if speed < nominal:
        print(
            f"field test pace: {spare:.1f} cores spare, {cost * 1e3:.2f} ms a message: {speed:g}x"
        )
    return speed
