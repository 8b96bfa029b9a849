"""Policy 4 (lookahead): each rule on a small hand-built situation, then whole missions."""

import math

import pytest

from engine import Mission, reference_scenario
from engine.policies import Lookahead, resolve_policy
from engine.robots.excavator import transports_due
from tests.engine.factories import events_of, quiet_scenario, run_with_failures, small_scenario
from tests.engine.invariants import run_checked

PLANT = (50.0, 50.0)


def one_site(policy: str, haulers: int = 3) -> Mission:
    """Seed 1's lone site holds 3 minerals 37 m from the plant; the operator points an
    excavator at it at t=0, with `haulers` haulers near the plant."""
    m = Mission(quiet_scenario(minerals=3), seed=1, policy=policy)
    for i in range(haulers - 1):
        m.add_robot("hauler", (50.0 + 2 * i, 45.0))
    site = m.world.sites[0]
    m.inject_task("excavate", (site.x, site.y))
    return m


def transport_auctions(m: Mission) -> list:
    return [a for a in m.auctions if a.kind == "excavator_hauler"]


def test_lookahead_is_policy_4():
    assert resolve_policy("4") == "lookahead"
    p = Lookahead()
    assert p.transport_lead_s(haul_s=40.0, dig_s=20.0) == 60.0
    assert p.early_transports() and p.time_bids
    assert p.queue_limit("hauler") == 1 and p.queue_limit("scout") == 0


def test_transports_fall_due_one_lead_before_each_bucket_fills():
    # dig 20 s, transfer 5 s: mineral j fills after 20 + 25 j seconds
    now, later = transports_due(pile=3, opened=0, dig_s=20, transfer_s=5, lead_s=66.8)
    assert now == 2 and later == pytest.approx(3.2)  # minerals 0 and 1 now, 2 in 3.2 s
    assert transports_due(pile=3, opened=2, dig_s=20, transfer_s=5, lead_s=66.8)[0] == 0
    assert transports_due(pile=3, opened=3, dig_s=20, transfer_s=5, lead_s=66.8) == (0, None)
    assert transports_due(pile=2, opened=0, dig_s=20, transfer_s=5, lead_s=66.8) == (2, None)
    assert transports_due(pile=5, opened=0, dig_s=20, transfer_s=5, lead_s=10.0) == (0, 10.0)
    assert transports_due(pile=5, opened=1, dig_s=20, transfer_s=5, lead_s=10.0) == (0, None)
    assert transports_due(pile=1, opened=1, dig_s=20, transfer_s=5, lead_s=100.0) == (0, None)


def test_every_mineral_leaves_as_its_bucket_fills():
    m = one_site("lookahead")
    m.advance(400)
    dug = [e["t"] for e in events_of(m, "dug")]
    pickups = [e["t"] for e in events_of(m, "pickup")]
    assert len(dug) == len(pickups) == 3
    transfer = m.scenario.timing.transfer_s
    assert [round(p - d, 6) for d, p in zip(dug, pickups, strict=True)] == [transfer] * 3
    # every transport was auctioned before its bucket filled, the first one on the way there
    opened = sorted(a.opened_at for a in transport_auctions(m))
    assert len(opened) == 3 and all(o < d for o, d in zip(opened, dug, strict=True))
    arrived = dug[0] - m.scenario.timing.dig_s
    assert opened[0] < arrived


def test_without_a_lead_the_excavator_waits_for_its_hauler():
    m = one_site("fcfs")
    m.advance(600)
    dug = [e["t"] for e in events_of(m, "dug")]
    opened = sorted(a.opened_at for a in transport_auctions(m))
    assert opened == dug  # Policy 1 auctions a transport when the bucket is full
    pickups = [e["t"] for e in events_of(m, "pickup")]
    assert all(p - d > 30 for d, p in zip(dug, pickups, strict=True))


def test_bids_are_expected_arrival_times_and_a_busy_hauler_queues_one_more_task():
    m = one_site("lookahead")
    m.advance(400)
    first, second, third = sorted(transport_auctions(m), key=lambda a: a.opened_at)
    # idle haulers bid minus their drive time (seconds), straight here: no craters
    site = m.world.sites[0]
    for b in first.bids:
        assert b.utility < 0 and math.isfinite(b.utility)
    speed = m.scenario.speeds.hauler
    h2 = next(b for b in first.bids if b.bidder == "hauler-2")
    assert h2.utility == pytest.approx(-math.dist((50.0, 45.0), (site.x, site.y)) / speed)
    # the first winner, busy, still bids finitely on the next one: later than an idle hauler
    winner = first.allocated_to
    busy_bid = next(b for b in second.bids if b.bidder == winner)
    assert math.isfinite(busy_bid.utility)
    assert busy_bid.utility < min(b.utility for b in second.bids if b.bidder != winner)
    assert {first.allocated_to, second.allocated_to, third.allocated_to} == {
        "hauler-1",
        "hauler-2",
        "hauler-3",
    }


def test_a_lone_hauler_chains_trips_through_its_queue():
    m = one_site("lookahead", haulers=1)
    m.advance(800)
    assert m.ctx.terrain.delivered == 3
    auctions = sorted(transport_auctions(m), key=lambda a: a.opened_at)
    assert all(a.allocated_to == "hauler-1" for a in auctions)
    assert auctions[1].reannouncements == 0  # won at once, by a hauler already busy
    assert auctions[2].reannouncements > 0  # with one task queued it had no room: -inf
    started = {e["task_id"]: e["t"] for e in events_of(m, "task_started")}
    ended = {e["task_id"]: e["t"] for e in events_of(m, "task_ended")}
    t1, t2, _ = (a.task_id for a in auctions)
    assert started[t2] < ended[t1]  # won while busy with the first: it waited in the queue
    # holding one task beside the current, it bid -inf (withdrew) in the third auction
    held_two = [b for b in auctions[2].bids if not math.isfinite(b.utility)]
    assert held_two and held_two[0].t < ended[t1]


def test_a_hauler_that_arrives_first_waits_for_its_excavator():
    m = Mission(quiet_scenario(minerals=1), seed=1, policy="lookahead")
    site = m.world.sites[0]
    m.add_robot("hauler", (site.x - 8.0, site.y))  # next to the site, far ahead of the excavator
    m.inject_task("excavate", (site.x, site.y))
    m.advance(400)
    first = min(transport_auctions(m), key=lambda a: a.opened_at)
    assert first.allocated_to == "hauler-2"
    waited = [e for e in events_of(m, "task_ended") if e["robot"] == "hauler-2"]
    assert waited and waited[0]["outcome"] == "done"
    assert m.ctx.terrain.delivered == 1


@pytest.mark.parametrize("seed", [3, 11, 1543])
def test_invariants_hold_under_lookahead_with_failures(seed):
    m = run_with_failures("lookahead", seed)
    assert m.status == "completed" and m.ctx.terrain.delivered == m.ctx.terrain.minerals_total


def test_invariants_hold_under_lookahead_on_small_worlds():
    for seed in range(4):
        run_checked(Mission(small_scenario(), seed, "lookahead"))


def test_switching_to_and_from_lookahead_mid_pipeline_loses_nothing():
    m = Mission(reference_scenario(), 2, "fcfs")
    m.advance(400)
    m.set_policy(4)
    m.advance(900)
    m.set_policy("coalition")
    m.run()
    assert m.status == "completed" and m.ctx.terrain.delivered == 64
