"""A radio of limited range (docs/model.md#communication): who hears whom, and a protocol that
tells a robot out of range from a failed one."""

from __future__ import annotations

import numpy as np
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from engine import POLICIES, Mission
from engine.radio import BASE, _reach_of, hop_reach
from tests.engine.factories import small_scenario
from tests.engine.invariants import InvariantWatch, run_checked
from tests.engine.test_determinism import trace_digest
from tests.engine.test_realism import ENERGY

RADIO = {"enabled": True, "range_m": 14.0, "base_range_m": 18.0, "hops": 2}


def test_a_message_crosses_at_most_hops_links():
    # a chain 10 m apart: with a 12 m range each robot hears only its neighbours
    nodes = [(f"r{i}", (10.0 * i, 0.0), 12.0) for i in range(5)]
    for hops, far in ((1, 1), (2, 2), (4, 4)):
        reach = _reach_of(nodes, hops)
        assert reach[0].nonzero()[0].max() == far
    link = np.array([[False, True], [True, False]])
    assert hop_reach(link, 3).all()


def test_the_base_station_links_with_its_own_range():
    nodes = [(BASE, (0.0, 0.0), 50.0), ("a", (40.0, 0.0), 10.0), ("b", (-40.0, 0.0), 10.0)]
    reach = _reach_of(nodes, 2)
    assert reach[1, 2] and reach[2, 1]  # a and b are 80 m apart: the base relays
    assert not _reach_of(nodes, 1)[1, 2]


def test_radio_range_same_seed_same_run_and_messages_miss_robots_out_of_reach():
    sc = small_scenario(width=60.0, height=60.0, radio=RADIO)
    a, b = Mission(sc, 4, "fcfs"), Mission(sc, 4, "fcfs")
    for m in (a, b):
        m.run()
    assert a.status == "completed"
    assert trace_digest(a) == trace_digest(b)
    out = a.metrics()
    assert 0.0 < out["radio_reach"] < 1.0  # some messages missed some robots
    assert out["false_failures"] == 0


def test_a_robot_that_fails_out_of_reach_is_still_found_failed():
    """Its silence is first taken for distance; after radio.silent_timeout_s it is failed,
    its duties are adopted and the mission completes."""
    sc = small_scenario(
        width=60.0,
        height=60.0,
        radio={**RADIO, "silent_timeout_s": 600.0},
        team={"scouts": 2, "excavators": 2, "haulers": 2},
    )
    m = Mission(sc, 1, "fcfs")
    radio = m.ctx.radio
    assert radio is not None
    scout = m.robot("scout-1")
    while radio.in_contact(scout.name):
        assert not m.done
        m.advance(m.now + 5.0)
    failed_at = m.now
    m.disable_robot(scout.name, "abrupt")
    watch = InvariantWatch(m)
    m.run()
    watch.final()
    found = [
        e.t for e in m.events if e.kind == "failure_detected" and e.data["robot"] == scout.name
    ]
    assert found, "the silent scout was never taken for failed"
    assert m.status == "completed"
    assert m.metrics()["false_failures"] == 0
    assert min(found) - failed_at > sc.protocol.failure_timeout_s


@given(seed=st.integers(0, 10_000), policy=st.sampled_from(list(POLICIES)))
@settings(max_examples=8, deadline=None, suppress_health_check=[HealthCheck.too_slow])
def test_all_four_options_together_keep_the_invariants(seed, policy):
    sc = small_scenario(
        energy=ENERGY,
        docks={"enabled": True, "count": 1},
        uncertainty={"enabled": True, "work_cv": 0.3, "speed_cv": 0.1},
        radio={**RADIO, "range_m": 12.0, "base_range_m": 15.0},
    )
    out = run_checked(Mission(sc, seed, policy))
    assert out["radio_reach"] < 1.0
