"""The per-run makespan lower bound (the run's own site discovery times) and the a-priori one
never exceed a fault-free run's makespan, under every registered policy."""

from __future__ import annotations

from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from engine import reference_scenario, run_mission
from engine.policies import POLICIES
from experiments.bound import bound_world, lower_bound, run_bound
from tests.engine.factories import small_scenario


@settings(
    max_examples=40, deadline=None, suppress_health_check=[HealthCheck.too_slow], derandomize=True
)
@given(
    seed=st.integers(0, 100_000),
    sites=st.integers(1, 5),
    minerals=st.integers(5, 12),
    team=st.tuples(st.integers(1, 3), st.integers(1, 3), st.integers(1, 4)),
    craters=st.integers(0, 5),
    speeds=st.tuples(
        st.sampled_from([0.5, 1.0, 2.0]),
        st.sampled_from([0.3, 0.5, 1.0]),
        st.sampled_from([0.3, 0.5, 1.0]),
    ),
    timing=st.tuples(st.sampled_from([5.0, 20.0]), st.sampled_from([0.0, 1.0, 5.0])),
)
def test_makespan_is_at_least_both_bounds_under_every_policy(
    seed: int,
    sites: int,
    minerals: int,
    team: tuple[int, int, int],
    craters: int,
    speeds: tuple[float, float, float],
    timing: tuple[float, float],
) -> None:
    scenario = small_scenario(
        sites=sites,
        minerals=max(minerals, sites),
        team={"scouts": team[0], "excavators": team[1], "haulers": team[2]},
        random_craters=craters,
        speeds={"scout": speeds[0], "excavator": speeds[1], "hauler": speeds[2]},
        timing={"dig_s": timing[0], "transfer_s": timing[1], "unload_s": timing[1]},
    )  # no faults, no operator actions, the ideal bus: what the bound assumes
    assert scenario.bus.loss == 0 and scenario.bus.latency_s == 0 == scenario.bus.jitter_s
    world = bound_world(scenario, seed)
    apriori = lower_bound(world)
    assert apriori.value > 0
    for policy in POLICIES:
        m = run_mission(scenario, seed, policy)
        assert m["status"] == "completed", (policy, m["status"])
        found = m["sites_found_at"]
        assert len(found) == len(world.sites) and None not in found
        assert max(found) <= m["makespan_s"]
        per_run = run_bound(world, found)
        assert per_run is not None
        ms = m["makespan_s"]
        assert per_run.value <= ms, (policy, per_run.terms, ms)
        assert apriori.value <= ms, (policy, apriori.terms, ms)
        # the actual discovery times are never earlier than the a-priori earliest ones
        assert all(a <= f + 1e-6 for a, f in zip(apriori.found_s, found, strict=True)), policy


def test_per_run_bound_is_tighter_on_the_reference_scenario() -> None:
    scenario = reference_scenario()
    world = bound_world(scenario, 1)
    m = run_mission(scenario, 1, "lookahead")
    per_run, apriori = run_bound(world, m["sites_found_at"]), lower_bound(world)
    assert per_run is not None
    assert apriori.value < per_run.value <= m["makespan_s"]
    assert m["makespan_s"] / per_run.value < 1.3  # the search no longer collapses


def test_no_per_run_bound_without_every_discovery_time() -> None:
    world = bound_world(small_scenario(sites=2), 0)
    assert run_bound(world, [1.0, None]) is None
    assert run_bound(world, [1.0]) is None
    assert run_bound(world, None) is None
    assert run_bound(world, [1.0, 2.0]) is not None
