"""Time in state: every robot's seconds per state add up to the time it existed, and the
states that have a fixed duration (digging, transferring, unloading) add up to exactly that
duration times the work done."""

import pytest

from engine import POLICIES, Mission, run_mission
from engine.metrics import STATES
from tests.engine.factories import small_scenario


def _per_robot_sums_hold(m: Mission) -> None:
    now = m.now
    for r in m.ctx.robots.values():
        times = r.state_times()
        assert min(times.values()) >= 0.0, (r.name, times)
        assert sum(times.values()) == pytest.approx(now - r.born_at, abs=1e-6), r.name


@pytest.mark.parametrize("policy", list(POLICIES))
def test_time_in_state_adds_up_and_matches_the_work_done(policy):
    sc = small_scenario()
    m = Mission(sc, 3, policy)
    metrics = m.run()
    assert metrics["completed"]
    _per_robot_sums_hold(m)
    tis = metrics["time_in_state"]
    team = {"scout": sc.team.scouts, "excavator": sc.team.excavators, "hauler": sc.team.haulers}
    for rtype, states in STATES.items():
        assert set(states) <= set(tis[rtype])  # every state, 0 where never entered
        assert sum(tis[rtype].values()) == pytest.approx(team[rtype] * m.now, abs=1e-6)
    n, t = metrics["minerals_total"], sc.timing
    assert tis["excavator"]["digging"] == pytest.approx(n * t.dig_s)
    assert tis["excavator"]["loading"] == pytest.approx(n * t.transfer_s)
    assert tis["hauler"]["unloading"] == pytest.approx(n * t.unload_s)
    # a scout scans at its speed; a hauler carries at its speed: the time is the distance
    assert tis["scout"]["scanning"] >= metrics["distance"]["scout"] / sc.speeds.scout - 1e-6
    assert tis["excavator"]["failed"] == 0.0
    assert tis["excavator"]["waiting"] > 0.0  # a bucket waited for a hauler at least once


def test_robots_that_join_late_or_fail_are_timed_from_joining_and_until_now():
    m = Mission(small_scenario(), 5, "fcfs")
    m.advance(200.0)
    mid = m.metrics()["time_in_state"]
    assert sum(mid["hauler"].values()) == pytest.approx(2 * m.now)
    m.add_robot("hauler")
    m.advance(400.0)
    failed_at = m.now
    m.disable_robot("excavator-1", "abrupt")
    m.run()
    _per_robot_sums_hold(m)
    added = [r for r in m.ctx.robots.values() if r.born_at > 0.0]
    assert [r.rtype for r in added] == ["hauler"]
    assert added[0].born_at == pytest.approx(200.0, abs=1.0)
    tis = m.metrics()["time_in_state"]
    assert tis["excavator"]["failed"] == pytest.approx(m.now - failed_at)
    assert sum(tis["hauler"].values()) == pytest.approx(2 * m.now + m.now - added[0].born_at)


def test_time_in_state_is_deterministic_and_a_plain_number_per_state():
    a = run_mission(small_scenario(), 2, "coalition")["time_in_state"]
    b = run_mission(small_scenario(), 2, "coalition")["time_in_state"]
    assert a == b
    assert all(isinstance(v, float) for states in a.values() for v in states.values())
