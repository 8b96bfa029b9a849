"""Property tests of the protocol invariants over random seeds, scenarios and failures."""

from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from engine import POLICIES, Mission
from tests.engine.factories import small_scenario
from tests.engine.invariants import InvariantWatch, run_checked

# every registered policy, so a new one is held to the same invariants from its first run
ANY_POLICY = st.sampled_from(list(POLICIES))


@st.composite
def scenarios(draw):
    sites = draw(st.integers(1, 4))
    return small_scenario(
        width=draw(st.floats(25, 50)),
        height=draw(st.floats(25, 50)),
        sites=sites,
        minerals=draw(st.integers(sites, 12)),
        team={
            "scouts": draw(st.integers(1, 2)),
            "excavators": draw(st.integers(1, 3)),
            "haulers": draw(st.integers(1, 3)),
        },
        random_craters=draw(st.integers(0, 2)),
    )


@given(seed=st.integers(0, 10_000), scenario=scenarios(), policy=ANY_POLICY)
@settings(max_examples=25, deadline=None, suppress_health_check=[HealthCheck.too_slow])
def test_invariants_hold_at_every_event(seed, scenario, policy):
    m = Mission(scenario, seed, policy)
    run_checked(m)
    assert m.ctx.terrain.sites_found == len(m.ctx.terrain.sites)


@st.composite
def failure_plans(draw):
    """One to three robots fail abruptly at random times; one of each type survives."""
    team = {"scouts": 2, "excavators": 2, "haulers": 3}
    names = (
        [f"scout-{i}" for i in (1, 2)]
        + [f"excavator-{i}" for i in (1, 2)]
        + [f"hauler-{i}" for i in (1, 2, 3)]
    )
    chosen = draw(st.lists(st.sampled_from(names), min_size=1, max_size=3, unique=True))
    for rtype in ("scout", "excavator", "hauler"):
        alive = [n for n in names if n.startswith(rtype) and n not in chosen]
        if not alive:
            chosen.remove(next(n for n in chosen if n.startswith(rtype)))
    plan = sorted((draw(st.floats(1.0, 900.0)), n) for n in chosen)
    return team, plan


@given(seed=st.integers(0, 10_000), policy=ANY_POLICY, plan=failure_plans())
@settings(max_examples=25, deadline=None, suppress_health_check=[HealthCheck.too_slow])
def test_missions_survive_abrupt_failures(seed, policy, plan):
    team, failures = plan
    m = Mission(small_scenario(sites=3, minerals=9, team=team), seed, policy)
    watch = InvariantWatch(m)
    for t, name in failures:
        m.advance(t)
        if m.done:
            break
        m.disable_robot(name, "abrupt")
    m.run()
    watch.final()
    assert m.status == "completed", (failures, m.metrics())
    assert m.ctx.terrain.delivered == m.ctx.terrain.minerals_total
    assert m.ctx.terrain.sites_found == len(m.ctx.terrain.sites)


@given(
    seed=st.integers(0, 10_000),
    policy=ANY_POLICY,
    loss=st.sampled_from([0.1, 0.3]),
    latency=st.sampled_from([0.0, 0.5]),
)
@settings(max_examples=20, deadline=None, suppress_health_check=[HealthCheck.too_slow])
def test_invariants_hold_on_a_lossy_slow_bus(seed, policy, loss, latency):
    scenario = small_scenario(
        sites=3,
        minerals=9,
        team={"scouts": 2, "excavators": 2, "haulers": 3},
        bus={"loss": loss, "latency_s": latency, "jitter_s": latency},
    )
    run_checked(Mission(scenario, seed, policy))
