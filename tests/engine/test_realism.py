"""The realism options (docs/model.md): docks, uncertain work and energy, each on its own and
together, held to the protocol's invariants; with every option off the reference is untouched
(the golden traces of test_determinism.py)."""

from __future__ import annotations

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from engine import POLICIES, Mission, ScenarioError, parse_scenario
from tests.engine.factories import small_scenario
from tests.engine.invariants import InvariantWatch, run_checked
from tests.engine.test_determinism import trace_digest

ENERGY = {
    "enabled": True,
    "scout": {"capacity_kj": 60.0, "drive_kj_per_m": 0.5, "work_kw": 0.1},
    "excavator": {"capacity_kj": 180.0, "drive_kj_per_m": 0.8, "work_kw": 2.0},
    "hauler": {"capacity_kj": 70.0, "drive_kj_per_m": 0.4, "work_kw": 1.0},
    "charge_kw": 5.0,
}


def _watch_energy(m: Mission) -> list[str]:
    """Assert at every event that no living robot's battery has gone below empty (the watch
    stops a robot the moment it runs dry); returns the robots that ran dry."""
    dry: list[str] = []

    def check(ev) -> None:
        now = m.now
        for r in m.ctx.robots.values():
            bat = r.battery
            if bat is None:
                continue
            unclamped = bat.level - bat.rate * (now - bat.since)
            assert unclamped >= -1e-6 or not r.alive, (r.name, unclamped)
            assert 0.0 <= bat.level <= bat.capacity + 1e-9
        if ev.kind == "robot_failed" and ev.data.get("cause") == "energy":
            dry.append(ev.data["robot"])

    m.subscribe(check)
    return dry


@pytest.mark.parametrize(
    "section, message",
    [
        ({"docks": {"enabled": True, "count": 0}}, "docks.count"),
        ({"uncertainty": {"distribution": "normal"}}, "uncertainty.distribution"),
        ({"uncertainty": {"work_cv": -1}}, "uncertainty.work_cv"),
        ({"energy": {"enabled": True, "hauler": {"capacity_kj": 5}}}, "energy.hauler.capacity_kj"),
        ({"energy": {"enabled": True, "chargers": [[500, 1]]}}, "energy.chargers[0]"),
        ({"radio": {"enabled": True, "silent_timeout_s": 10}}, "radio.silent_timeout_s"),
        ({"radio": {"hops": 0}}, "radio.hops"),
        ({"energy": {"charge_kw": 0}}, "energy.charge_kw"),
    ],
)
def test_bad_realism_settings_name_the_field(section, message):
    with pytest.raises(ScenarioError, match=message.replace("[", r"\[").replace("]", r"\]")):
        parse_scenario(section)


def test_uncertain_work_same_seed_same_run_and_differs_from_fixed_work():
    sc = small_scenario(uncertainty={"enabled": True, "work_cv": 0.5, "speed_cv": 0.2})
    a, b = Mission(sc, 3, "lookahead"), Mission(sc, 3, "lookahead")
    fixed = Mission(small_scenario(), 3, "lookahead")
    for m in (a, b, fixed):
        m.run()
    assert a.status == "completed"
    assert trace_digest(a) == trace_digest(b)
    assert a.metrics()["work_draws"] > 0
    assert a.metrics()["makespan_s"] != fixed.metrics()["makespan_s"]
    assert "work_draws" not in fixed.metrics()  # an option off adds nothing


def test_docks_never_serve_more_haulers_than_they_have():
    sc = small_scenario(
        team={"scouts": 1, "excavators": 3, "haulers": 4},
        timing={"unload_s": 40.0},
        docks={"enabled": True, "count": 1},
    )
    m = Mission(sc, 1, "central-greedy")
    most = 0

    def check(_ev) -> None:
        nonlocal most
        unloading = sum(1 for r in m.ctx.robots.values() if r.state == "unloading")
        most = max(most, unloading)
        assert unloading <= 1

    m.subscribe(check)
    out = m.run()
    assert m.status == "completed" and most == 1
    assert out["dock_queued"] > 0 and out["dock_wait_s"] > 0  # some hauler did queue
    # with the docks off the same mission unloads haulers side by side and never waits
    off = Mission(small_scenario(team=sc.team.model_dump(), timing={"unload_s": 40.0}), 1, 0)
    assert "dock_wait_s" not in off.run()


@given(seed=st.integers(0, 10_000), policy=st.sampled_from(list(POLICIES)))
@settings(max_examples=14, deadline=None, suppress_health_check=[HealthCheck.too_slow])
def test_energy_docks_and_uncertain_work_keep_the_invariants(seed, policy):
    sc = small_scenario(
        energy=ENERGY,
        docks={"enabled": True, "count": 1},
        uncertainty={"enabled": True, "work_cv": 0.4, "speed_cv": 0.1},
    )
    m = Mission(sc, seed, policy)
    dry = _watch_energy(m)
    out = run_checked(m)
    assert out["charges"] > 0  # the batteries are small: every run charges
    assert out["ran_dry"] == len(dry)


def test_a_robot_that_runs_dry_is_recovered_like_a_failed_one():
    sc = small_scenario(energy=ENERGY, team={"scouts": 1, "excavators": 2, "haulers": 3})
    m = Mission(sc, 2, "fcfs")
    dry = _watch_energy(m)
    watch = InvariantWatch(m)
    while not any(r.rtype == "hauler" and r.bin for r in m.ctx.robots.values()):
        assert not m.done
        m.advance(m.now + 1.0)
    carrier = next(r for r in m.ctx.robots.values() if r.rtype == "hauler" and r.bin)
    assert carrier.battery is not None
    carrier.battery.settle(m.now)
    carrier.battery.level = 0.5  # a leak: it has half a kJ left, not enough to get home
    carrier.motion_changed()
    out = m.run()
    watch.final()
    assert dry == [carrier.name] and not carrier.alive
    kinds = [(e.kind, e.data.get("robot")) for e in m.events]
    assert ("failure_detected", carrier.name) in kinds
    assert out["minerals_dropped"] >= 1 and out["minerals_recovered"] >= 1
    assert m.status == "completed" and out["minerals_delivered"] == out["minerals_total"]
    assert out["ran_dry"] == 1 and out["failures"] == 1


def test_a_robot_never_accepts_a_task_it_could_not_finish():
    """Every task a robot started, it started with the energy for it (the feasibility test
    at bid, award and start): with estimates this conservative no robot runs dry."""
    sc = small_scenario(energy=ENERGY, width=50.0, height=50.0)
    for policy in ("fcfs", "lookahead", "central-greedy"):
        m = Mission(sc, 5, policy)
        dry = _watch_energy(m)
        out = m.run()
        assert m.status == "completed" and dry == [] and out["charges"] > 0
        assert all(
            r.battery is None or r.battery.level > 0 for r in m.ctx.robots.values() if r.alive
        )
