"""The centralized baseline: the oracle's assignment, on hand-made costs and in a mission."""

import numpy as np

from engine import Mission, reference_scenario, run_mission
from engine.central import FORBIDDEN, optimal_assignment
from engine.policies import Central, resolve_policy
from tests.engine.factories import quiet_scenario, small_scenario
from tests.engine.invariants import InvariantWatch


def test_central_is_policy_0_and_has_an_oracle():
    assert resolve_policy("0") == "central"
    assert Central().allocator() is not None


def test_optimal_assignment_beats_greedy_and_skips_forbidden_pairs():
    # greedy (cheapest pair first) would take (0,0)=3 then (1,1)=20: 23; the optimum is 17
    cost = np.array([[3.0, 5.0], [12.0, 20.0]])
    assert optimal_assignment(cost) == {0: 1, 1: 0}
    # more tasks than robots: one task stays unassigned
    assert optimal_assignment(np.array([[1.0], [2.0]])) == {0: 0}
    # a forbidden pairing is never chosen, even when nothing else is left
    assert optimal_assignment(np.array([[FORBIDDEN, 1.0], [FORBIDDEN, 2.0]])) in ({0: 1}, {1: 1})
    assert optimal_assignment(np.zeros((0, 3))) == {}


def test_the_oracle_awards_by_the_optimal_assignment_not_the_best_bid():
    m = Mission(quiet_scenario(), seed=1, policy="central")
    ax, ay = m.ctx.robots["excavator-1"].pos
    m.add_robot("excavator", (ax + 8.0, ay))  # excavator-2, 8 m east of excavator-1
    near = m.inject_task("excavate", (ax + 3.0, ay))  # 3 m from excavator-1, 5 m from -2
    far = m.inject_task("excavate", (ax - 12.0, ay))  # 12 m from excavator-1, 20 m from -2
    m.advance(30)
    first, second = (m.ctx.auctions_by_id[a] for a in (near, far))
    best_bid = max(first.bids, key=lambda b: b.utility)
    assert best_bid.bidder == "excavator-1"  # the nearer robot bid highest ...
    assert first.allocated_to == "excavator-2"  # ... but the optimum sends it to the far task
    assert second.allocated_to == "excavator-1"
    assert m.ctx.declines == 0


def test_with_policy_3_the_same_situation_goes_greedily():
    m = Mission(quiet_scenario(), seed=1, policy="nearest")
    ax, ay = m.ctx.robots["excavator-1"].pos
    m.add_robot("excavator", (ax + 8.0, ay))
    near = m.inject_task("excavate", (ax + 3.0, ay))
    far = m.inject_task("excavate", (ax - 12.0, ay))
    m.advance(30)
    assert m.ctx.auctions_by_id[near].allocated_to == "excavator-1"
    assert m.ctx.auctions_by_id[far].allocated_to == "excavator-2"


def test_a_task_waits_while_the_optimum_gives_it_no_robot():
    m = Mission(quiet_scenario(), seed=1, policy="central")  # one excavator, two tasks
    ax, ay = m.ctx.robots["excavator-1"].pos
    first = m.inject_task("excavate", (ax - 20.0, ay))
    second = m.inject_task("excavate", (ax + 3.0, ay))
    m.advance(3)
    assert m.ctx.auctions_by_id[second].allocated_to == "excavator-1"
    waiting = m.ctx.auctions_by_id[first]
    assert waiting.status == "open" and not waiting.awards
    m.advance(120)  # the second site is void (nothing there): the robot is free again
    assert waiting.status == "closed" and waiting.allocated_to == "excavator-1"


def test_invariants_hold_under_the_oracle_with_failures():
    for seed in (3, 1543):
        m = Mission(
            small_scenario(sites=3, minerals=9, team={"scouts": 2, "excavators": 2, "haulers": 3}),
            seed,
            "central",
        )
        watch = InvariantWatch(m)
        for t, name in [(98.0, "scout-1"), (155.0, "hauler-1"), (400.0, "excavator-2")]:
            m.advance(t)
            if not m.done:
                m.disable_robot(name, "abrupt")
        m.run()
        watch.final()
        assert m.status == "completed" and m.ctx.delivered == m.ctx.minerals_total


def test_the_oracle_run_is_deterministic():
    a, b = (run_mission(small_scenario(), 5, "central") for _ in range(2))
    assert a == b


def test_central_completes_the_reference_scenario_on_seeds_0_to_9():
    for seed in range(10):
        r = run_mission(reference_scenario(), seed, "central")
        assert r["completed"], seed
        assert (r["sites_found"], r["minerals_delivered"]) == (10, 64)
