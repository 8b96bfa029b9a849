"""The centralized baseline: the oracle's assignment, on hand-made costs and in a mission."""

import numpy as np

from engine import Mission, run_mission
from engine.central import FORBIDDEN, optimal_assignment
from engine.policies import CentralGreedy, resolve_policy
from tests.engine.factories import quiet_scenario, run_with_failures, small_scenario


def test_central_is_policy_0_and_has_an_oracle():
    assert resolve_policy("0") == "central-greedy"
    assert resolve_policy("central") == "central-greedy"  # its former name still works
    assert CentralGreedy().allocator() is not None


def test_optimal_assignment_beats_greedy_and_skips_forbidden_pairs():
    # greedy (cheapest pair first) would take (0,0)=3 then (1,1)=20: 23; the optimum is 17
    cost = np.array([[3.0, 5.0], [12.0, 20.0]])
    assert optimal_assignment(cost) == {0: 1, 1: 0}
    # more tasks than robots: one task stays unassigned
    assert optimal_assignment(np.array([[1.0], [2.0]])) == {0: 0}
    # a forbidden pairing is never chosen, even when nothing else is left
    assert optimal_assignment(np.array([[FORBIDDEN, 1.0], [FORBIDDEN, 2.0]])) in ({0: 1}, {1: 1})
    assert optimal_assignment(np.zeros((0, 3))) == {}


def near_and_far(policy: str) -> tuple[Mission, str, str]:
    """Two excavators 8 m apart and two tasks: `near` 3 m from excavator-1 (5 m from
    excavator-2), `far` 12 m from excavator-1 (20 m from excavator-2). Greedy sends
    excavator-1 to `near` (3 + 20 = 23 m); the optimum sends it to `far` (12 + 5 = 17 m)."""
    m = Mission(quiet_scenario(), seed=1, policy=policy)
    ax, ay = m.ctx.robots["excavator-1"].pos
    m.add_robot("excavator", (ax + 8.0, ay))  # excavator-2, 8 m east of excavator-1
    near = m.inject_task("excavate", (ax + 3.0, ay))
    far = m.inject_task("excavate", (ax - 12.0, ay))
    m.advance(30)
    return m, near, far


def test_the_oracle_awards_by_the_optimal_assignment_not_the_best_bid():
    m, near, far = near_and_far("central-greedy")
    first, second = (m.ctx.observer.auctions_by_id[a] for a in (near, far))
    best_bid = max(first.bids, key=lambda b: b.utility)
    assert best_bid.bidder == "excavator-1"  # the nearer robot bid highest ...
    assert first.allocated_to == "excavator-2"  # ... but the optimum sends it to the far task
    assert second.allocated_to == "excavator-1"
    assert m.ctx.observer.declines == 0


def test_with_policy_3_the_same_situation_goes_greedily():
    m, near, far = near_and_far("nearest")
    assert m.ctx.observer.auctions_by_id[near].allocated_to == "excavator-1"
    assert m.ctx.observer.auctions_by_id[far].allocated_to == "excavator-2"


def test_a_task_waits_while_the_optimum_gives_it_no_robot():
    m = Mission(quiet_scenario(), seed=1, policy="central-greedy")  # one excavator, two tasks
    ax, ay = m.ctx.robots["excavator-1"].pos
    first = m.inject_task("excavate", (ax - 20.0, ay))
    second = m.inject_task("excavate", (ax + 3.0, ay))
    m.advance(3)
    assert m.ctx.observer.auctions_by_id[second].allocated_to == "excavator-1"
    waiting = m.ctx.observer.auctions_by_id[first]
    assert waiting.status == "open" and not waiting.awards
    m.advance(120)  # the second site is void (nothing there): the robot is free again
    assert waiting.status == "closed" and waiting.allocated_to == "excavator-1"


def test_invariants_hold_under_the_oracle_with_failures():
    for seed in (3, 1543):
        m = run_with_failures("central-greedy", seed)
        assert m.status == "completed" and m.ctx.terrain.delivered == m.ctx.terrain.minerals_total


def test_the_oracle_run_is_deterministic():
    a, b = (run_mission(small_scenario(), 5, "central-greedy") for _ in range(2))
    assert a == b
