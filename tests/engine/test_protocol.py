"""Each protocol step and each policy's rule, on small hand-built situations in a real run."""

import math

from engine import Mission, reference_scenario
from tests.engine.factories import events_of, quiet_scenario

WEST, EAST = (40.0, 50.0), (60.0, 50.0)


def two_tasks(policy: str, far_excavator: bool = True) -> Mission:
    """excavator-1 starts beside the plant (nearer to WEST than EAST); excavator-2 far away."""
    m = Mission(quiet_scenario(), seed=1, policy=policy)
    if far_excavator:
        assert m.add_robot("excavator", (90.0, 90.0)) == "excavator-2"
    m.inject_task("excavate", WEST)
    m.inject_task("excavate", EAST)
    return m


def bids_for(m: Mission, auction_id: str) -> list[dict]:
    return [b for b in events_of(m, "bid") if b["auction_id"] == auction_id]


def test_announcement_bid_award_ack_close_in_order():
    m = two_tasks("fcfs")
    m.advance(60)
    rec = m.ctx.observer.auctions_by_id["operator/1"]
    assert rec.status == "closed" and rec.allocated_to == "excavator-1"
    kinds = [
        e.data["type"]
        for e in m.events
        if e.kind == "message" and e.data.get("auction_id") == "operator/1"
    ]
    first = {k: kinds.index(k) for k in ("announce", "bid", "award", "ack", "close")}
    assert first["announce"] < first["bid"] < first["award"] < first["ack"] < first["close"]
    assert [a.outcome for a in rec.awards] == ["accepted"]
    assert rec.closed_at - rec.opened_at >= m.scenario.protocol.bid_window_s


def test_policy_1_bids_go_only_to_the_first_auction_until_it_closes():
    m = two_tasks("fcfs")
    m.advance(120)
    first = m.ctx.observer.auctions_by_id["operator/1"]
    second_bids = bids_for(m, "operator/2")
    assert bids_for(m, "operator/1"), "nobody bid in the first auction"
    assert second_bids, "nobody bid in the second auction after the first closed"
    assert all(b["t"] >= first.closed_at for b in second_bids)
    assert m.ctx.observer.auctions_by_id["operator/2"].allocated_to == "excavator-2"


def test_policy_3_winner_of_two_keeps_the_nearer_and_the_other_goes_to_the_next_bidder():
    m = Mission(quiet_scenario(), seed=1, policy="nearest")
    m.add_robot("excavator", (90.0, 90.0))
    m.inject_task("excavate", EAST)  # the farther task is auctioned (and awarded) first
    m.inject_task("excavate", WEST)
    m.advance(60)
    east, west = (m.ctx.observer.auctions_by_id[a] for a in ("operator/1", "operator/2"))
    # excavator-1 is the best bidder in both auctions and is awarded both
    assert west.awards[0].winner == "excavator-1" and east.awards[0].winner == "excavator-1"
    assert west.awards[0].outcome == "accepted"
    assert east.awards[0].outcome == "declined"
    # the declined auction goes to its next-highest bidder
    assert east.allocated_to == "excavator-2"
    assert m.ctx.observer.declines >= 1


def test_busy_robot_bids_minus_inf_and_the_auction_is_reannounced_until_someone_can():
    m = two_tasks("fcfs", far_excavator=False)  # a lone excavator, two tasks
    m.advance(200)
    second = m.ctx.observer.auctions_by_id["operator/2"]
    infinite = [b for b in bids_for(m, "operator/2") if b["utility"] is None]
    assert infinite, "a busy robot must bid -inf"
    assert second.reannouncements >= 1
    assert second.status == "closed" and second.allocated_to == "excavator-1"
    # never awarded to a -inf bid
    for award in second.awards:
        latest = [b for b in second.bids if b.bidder == award.winner and b.t <= award.t][-1]
        assert math.isfinite(latest.utility)


def test_policy_2_paired_haulers_carry_their_excavators_minerals_without_auctions():
    m = Mission(reference_scenario(), seed=2, policy="coalition")
    m.run()
    assert m.status == "completed"
    paired = {f"hauler-{k}" for k in range(1, 5)}
    # a paired hauler bids only while its partner has no site to work
    working: dict[str, list[tuple[float, float]]] = {}
    starts = {}
    for e in m.events:
        if e.data.get("task_type") == "excavate" and e.kind == "task_started":
            starts[e.data["robot"]] = e.t
        elif e.kind == "task_ended" and e.data["task_id"].startswith("excavate@"):
            working.setdefault(e.data["robot"], []).append((starts.pop(e.data["robot"]), e.t))
    for b in events_of(m, "bid"):
        if b["bidder"] in paired:
            partner = "excavator-" + b["bidder"].split("-")[1]
            assert not any(t0 < b["t"] < t1 for t0, t1 in working.get(partner, [])), b
    coalition = events_of(m, "coalition_delivery")
    assert coalition, "no mineral went through a coalition"
    assert all(e["robot"][-1] == e["excavator"][-1] for e in coalition)
    auctioned = [
        a
        for a in m.auctions
        if a.kind == "excavator_hauler" and a.status == "closed" and a.reauction_of is None
    ]
    assert len(coalition) + len(auctioned) == m.ctx.terrain.minerals_total


def test_operator_switches_policy_mid_mission_and_it_is_recorded():
    m = Mission(reference_scenario(), seed=0, policy="fcfs")
    m.advance(500)
    m.set_policy(3)
    m.run()
    assert m.status == "completed"
    changes = events_of(m, "policy_changed")
    assert changes == [{"old": "fcfs", "new": "nearest", "t": 500.0}]
    assert m.actions == [{"t": 500.0, "kind": "set_policy", "args": {"policy": "nearest"}}]
    later = [a for a in m.auctions if a.opened_at > 500]
    assert later and all(a.policy == "nearest" for a in later)
