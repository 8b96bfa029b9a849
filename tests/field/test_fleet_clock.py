"""The mission clock with real agent processes over Zenoh (docs/field.md, "The mission
clock"): mission control pauses a running field mission and no robot acts — no delivery, no
heartbeat, the world's time standing — for a stretch of wall time in which several deliveries
would have been made; after the resume the mission goes on. Then the speed is halved and every
agent's heartbeats advance at the new rate, in step with the world's clock; the mission
completes with every mineral delivered.

Waits are on progress (tests/progress.py), never on a fixed deadline: the stretches watched
are measured in mission time at the speed the test runs at (tests/field/pace.py)."""

from __future__ import annotations

import time
from collections.abc import Iterator

import pytest

from engine.scenario import reference_scenario
from field.fleet import Fleet
from tests.field.pace import paced
from tests.field.serial import one_field_mission_at_a_time
from tests.progress import Progress

SPEED = 100.0
WORK = ("delivered", "sites_found", "scanned", "ground", "aboard")
PAUSE_SIM_S = 400.0
"""Mission time the pause is watched for, at the speed it would have run: ~10 deliveries."""
GRACE_S = 5.0
"""Wall time an agent that missed the pause command may take to hear of it (an answer of the
world, or its status poll: `field.clock.FOLLOW_POLL_S`, `field.agent.PRESENCE_POLL_S`)."""
RATE_SIM_S = 300.0
"""Mission time over which each agent's heartbeat rate is measured."""


@pytest.fixture
def fleet() -> Iterator[Fleet]:
    with one_field_mission_at_a_time():
        f = Fleet(reference_scenario(), 0, "nearest", paced(SPEED))
        try:
            yield f
        finally:
            f.close()
            for p in f.history:
                assert p.popen.poll() is not None, f"{p.name} outlived its fleet"


def _work(fleet: Fleet) -> list[object]:
    status = fleet.world.status()
    return [status[k] for k in WORK]


def _run_until(fleet: Fleet, done: object, what: str) -> None:
    watch = Progress(what)
    while not done():  # type: ignore[operator]
        assert not fleet.world.clock.paused
        watch.check(_work(fleet), lambda: fleet.world.status())
        time.sleep(0.05)


def _beats(fleet: Fleet) -> dict[str, float]:
    with fleet.intake.lock:
        return {n: hb.t for n, hb in fleet.intake.heartbeats.items()}


@pytest.mark.slow
@pytest.mark.fleet
def test_pause_holds_every_agent_and_a_new_speed_reaches_them_all(fleet: Fleet) -> None:
    speed = fleet.speed
    fleet.up()
    delivered = lambda: fleet.world.status()["delivered"]  # noqa: E731
    _run_until(fleet, lambda: delivered() >= 4, "the first deliveries")

    # --- pause: nothing moves for as long as ~10 deliveries would take -------------------
    t_paused = fleet.set_clock(paused=True)
    d0 = delivered()
    with fleet.intake.lock:
        n_events = len(fleet.intake.events)
    start = time.monotonic()
    stretch = max(PAUSE_SIM_S / speed, GRACE_S + 3.0)
    settled: dict[str, float] | None = None
    while time.monotonic() - start < stretch:
        assert fleet.now() == t_paused, "the world's clock moved while paused"
        assert delivered() == d0, "a delivery while paused"
        if settled is None and time.monotonic() - start >= GRACE_S:
            settled = _beats(fleet)  # every agent heard of the pause by now
        elif settled is not None:
            assert _beats(fleet) == settled, "an agent's heartbeat while paused"
        time.sleep(0.05)
    with fleet.intake.lock:
        said = fleet.intake.events[n_events:]
    assert not [e for e in said if e.get("event") in ("delivered", "mineral_delivered")], said
    assert fleet.world.status()["t"] == t_paused

    # --- resume: deliveries go on ---------------------------------------------------------
    fleet.set_clock(paused=False)
    _run_until(fleet, lambda: delivered() >= d0 + 3, "deliveries after the resume")

    # --- re-pace at half the speed: every agent's heartbeats follow ----------------------
    new = speed / 2
    t_changed = fleet.set_clock(speed=new)
    first = _beats(fleet)
    since = {n: (time.monotonic(), t) for n, t in first.items()}
    rates: dict[str, float] = {}
    drift: dict[str, float] = {}
    watch = Progress("every agent's heartbeats at the new speed")
    while len(rates) < len(first):
        watch.check(sorted(_beats(fleet).items()))
        now_wall, now_world = time.monotonic(), fleet.now()
        for name, t in _beats(fleet).items():
            if name not in since or name in rates or t < t_changed + 20.0:
                continue  # (heartbeats sent before it heard of the change: 10 s apart)
            if since[name][1] < t_changed + 20.0:
                since[name] = (now_wall, t)  # measured from its first beat at the new pace
            elif t - since[name][1] >= RATE_SIM_S:
                rates[name] = (t - since[name][1]) / (now_wall - since[name][0])
                drift[name] = now_world - t
        time.sleep(0.02)
    assert abs(fleet.world.clock.speed - new) < 1e-9 and fleet.speed == new
    slow = {n: r for n, r in rates.items() if not 0.6 * new <= r <= 1.3 * new}
    assert not slow, f"heartbeat rates (mission s per wall s) off {new:g}x: {slow}"
    # one still on the old pace would be RATE_SIM_S / 2 ahead of the world by now
    apart = {n: d for n, d in drift.items() if abs(d) > 0.2 * RATE_SIM_S}
    assert not apart, f"agents' mission time apart from the world's: {apart}"

    # --- to the end --------------------------------------------------------------------
    fleet.set_clock(speed=speed)
    _run_until(fleet, lambda: fleet.world.terrain.finished.triggered, "the mission to finish")
    status = fleet.world.status()
    assert status["delivered"] == status["minerals_total"] == 64
    assert status["ground"] == 0 and status["sites_remaining"] == 0 and status["aboard"] == 0
    assert fleet.intake.malformed == 0
    assert fleet.world.status()["clock"]["version"] == 4
