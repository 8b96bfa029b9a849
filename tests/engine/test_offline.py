"""The clairvoyant reference: the optimizer's schedules are valid, and the executor carries
them out in the simulator, repairs when the team changes and never loses a mineral."""

from __future__ import annotations

import itertools
import math

from hypothesis import given, settings
from hypothesis import strategies as st

from engine import Mission, reference_scenario, run_mission
from engine.geometry import dist
from engine.policies import Offline, resolve_policy
from engine.schedule import Job, Problem, Schedule, Unit, _Matrix, construct, decode, optimize
from tests.engine.factories import events_of, run_with_failures, small_scenario
from tests.engine.invariants import InvariantWatch

DIG, TRANSFER, UNLOAD = 20.0, 5.0, 5.0


def problem(jobs: list[tuple[float, float, int, float]], excavators: int, haulers: int) -> Problem:
    plant = (50.0, 50.0)
    return Problem(
        plant=plant,
        jobs=tuple(Job(f"site-{i + 1}", (x, y), m, r) for i, (x, y, m, r) in enumerate(jobs)),
        excavators=tuple(Unit(f"excavator-{i + 1}", plant, 0.0) for i in range(excavators)),
        haulers=tuple(Unit(f"hauler-{i + 1}", plant, 0.0) for i in range(haulers)),
        v_excavator=0.5,
        v_hauler=0.8,
        dig_s=DIG,
        transfer_s=TRANSFER,
        unload_s=UNLOAD,
        dist=dist,
    )


def check_valid(p: Problem, s: Schedule) -> None:
    """Every mineral carried once; one excavator per site and one site at a time per
    excavator; nothing dug before its release; each hauler one trip at a time; each
    transfer after its hauler's arrival and its bucket's fill; the makespan is the last
    delivery (or the last release)."""
    jobs = {j.key: j for j in p.jobs}
    hauls = [h for seq in s.hauls.values() for h in seq]
    assert sorted((h.job, h.k) for h in hauls) == sorted(
        (j.key, k) for j in p.jobs for k in range(j.minerals)
    )
    dug = [d.job for seq in s.digs.values() for d in seq]
    assert sorted(dug) == sorted(jobs)  # each site by exactly one excavator
    for seq in s.digs.values():
        for a, b in itertools.pairwise(seq):
            assert b.arrive >= a.end - 1e-9  # one site at a time
        for d in seq:
            assert d.start >= max(d.arrive, jobs[d.job].release) - 1e-9
    by_site: dict[str, list[float]] = {}
    for h in hauls:
        assert h.transfer >= max(h.arrive, h.fill) - 1e-9
        by_site.setdefault(h.job, []).append(h.transfer)
    for key, starts in by_site.items():
        starts.sort()
        first = next(d for seq in s.digs.values() for d in seq if d.job == key)
        assert starts[0] >= first.start + DIG - 1e-9
        for a, b in itertools.pairwise(starts):
            assert b >= a + TRANSFER + DIG - 1e-9  # the next dig starts once the bucket is empty
    for seq in s.hauls.values():
        for a, b in itertools.pairwise(seq):
            assert b.depart >= a.delivered - 1e-9 and b.arrive > b.depart
    last = max([h.delivered for h in hauls] + [j.release for j in p.jobs])
    assert math.isclose(s.makespan, last)


REF = [(20, 30, 5, 100), (70, 80, 8, 400), (30, 75, 3, 650), (80, 20, 6, 900), (55, 40, 2, 10)]


def test_a_hand_made_schedule_is_valid_and_the_search_never_worsens_the_construction():
    p = problem(REF, excavators=2, haulers=3)
    s = optimize(p, 300)
    check_valid(p, s)
    mat = _Matrix(p)
    start = decode(p, construct(p, mat), [0.0] * len(p.jobs), mat)
    check_valid(p, start)
    assert s.cost <= start.cost
    assert optimize(p, 300).cost == s.cost  # deterministic: a count, not a clock


def test_a_lone_pile_is_dug_as_fast_as_physics_allows():
    # one site at the plant's side, released at 0, plenty of haulers: every mineral leaves
    # one dig + one transfer after the last, and the makespan is the chain
    p = problem([(52.0, 50.0, 4, 0.0)], excavators=1, haulers=4)
    s = optimize(p, 50)
    check_valid(p, s)
    drive = 2.0 / 0.5
    back = 2.0 / 0.8 + UNLOAD
    assert math.isclose(s.makespan, drive + 4 * (DIG + TRANSFER) + back)


@settings(max_examples=40, deadline=None, derandomize=True)
@given(
    jobs=st.lists(
        st.tuples(st.floats(0, 100), st.floats(0, 100), st.integers(1, 6), st.floats(0, 1500)),
        min_size=1,
        max_size=7,
    ),
    excavators=st.integers(1, 3),
    haulers=st.integers(1, 4),
)
def test_random_problems_give_valid_schedules(jobs, excavators, haulers):
    p = problem(jobs, excavators, haulers)
    check_valid(p, optimize(p, 40))


def test_offline_is_policy_6_a_baseline_with_its_own_planner():
    assert resolve_policy("6") == "offline"
    pol = Offline()
    assert not pol.decentralized and pol.allocator() is pol.allocator()


def test_the_reference_run_follows_its_plan_and_digs_nothing_before_it_is_found():
    m = Mission(reference_scenario(), 0, "offline")
    watch = InvariantWatch(m)
    m.run()
    watch.final()
    (plan,) = events_of(m, "offline_planned")
    assert plan["reason"] == "start" and plan["t"] == 0.0 and plan["minerals"] == 64
    # the schedule's paths and discovery times are the run's own: it ends when predicted
    assert m.status == "completed"
    assert math.isclose(m.ctx.terrain.finished_at, plan["makespan_s"], abs_tol=1e-6)
    found = {e["site"]: e["t"] for e in events_of(m, "site_found")}
    assert all(e["t"] >= found[e["site"]] + DIG for e in events_of(m, "dug"))
    # excavators stood at their sites before the scouts found them: awarded in one bid window
    excavations = [a for a in m.auctions if a.task_type == "excavate"]
    assert all(a.open_time == 1.0 for a in excavations)
    lookahead = run_mission(reference_scenario(), 0, "lookahead")["makespan_s"]
    assert m.ctx.terrain.finished_at < lookahead


def test_failures_make_it_plan_again_and_it_still_finishes():
    for seed in (3, 1543):
        m = run_with_failures("offline", seed)
        assert m.status == "completed"
        assert m.ctx.terrain.delivered == m.ctx.terrain.minerals_total
        assert [e["reason"] for e in events_of(m, "offline_planned")][1:2] == ["team changed"]


def test_live_switches_to_and_from_offline_and_an_injected_task_finish():
    m = Mission(small_scenario(sites=3, minerals=9), 4, "fcfs")
    watch = InvariantWatch(m)
    m.advance(150.0)
    m.set_policy("offline")
    m.advance(151.0)
    (plan,) = events_of(m, "offline_planned")
    assert plan["t"] >= 150.0  # planned from the moment of the switch
    m.inject_task("transport", (5.0, 5.0))
    m.add_robot("hauler")
    m.advance(400.0)
    m.set_policy("nearest")
    m.run()
    watch.final()
    assert m.status == "completed" and m.ctx.terrain.delivered == m.ctx.terrain.minerals_total


def test_the_offline_run_is_deterministic():
    a, b = (run_mission(small_scenario(), 5, "offline") for _ in range(2))
    assert a == b and a["completed"]
