"""Checks of the protocol's invariants, run at every event of a mission."""

from __future__ import annotations

from collections import Counter

from engine import Mission
from engine.events import Event

OFFERS = {"scout": {"excavate"}, "excavator": {"transport"}, "hauler": set()}
"""What each robot type may offer (the operator's console offers either)."""


class InvariantWatch:
    """Subscribes to a mission and asserts the invariants after each event."""

    def __init__(self, m: Mission) -> None:
        self.m = m
        self.events = 0
        m.subscribe(self.check)

    def check(self, _event: Event) -> None:
        ctx = self.m.ctx
        self.events += 1
        where = ctx.minerals_in()
        assert sum(where.values()) == ctx.terrain.minerals_total, f"minerals not conserved: {where}"
        working = Counter()
        holders: Counter[str] = Counter()
        for r in ctx.robots.values():
            if not r.alive:
                continue
            tasks = [a.task_id for a in r.queue]
            if r.current is not None:
                tasks.append(r.current.task_id)
                if r.rtype == "excavator" and r.state in ("digging", "waiting", "loading"):
                    working[r.current.location] += 1
            holders.update(set(tasks))
        assert all(n == 1 for n in working.values()), f"two excavators on a site: {working}"
        assert all(n == 1 for n in holders.values()), f"a task held twice: {holders}"

    def final(self) -> None:
        robots = self.m.ctx.robots
        for rec in self.m.auctions:
            rtype = robots[rec.auctioneer].rtype if rec.auctioneer in robots else "operator"
            offers = OFFERS.get(rtype, {rec.task_type})
            assert rec.task_type in offers, f"a {rtype} offered a {rec.task_type}: {rec.id}"
            accepted = [a for a in rec.awards if a.outcome == "accepted"]
            if rec.status == "closed":
                assert rec.allocated_to is not None
                assert [a.winner for a in accepted] == [rec.allocated_to], rec.to_dict()
            else:
                assert rec.allocated_to is None
                assert not accepted, rec.to_dict()


def run_checked(m: Mission) -> dict:
    """Run `m` to its end with the invariants checked at every event; it must complete with
    every mineral delivered. Returns the run's metrics."""
    watch = InvariantWatch(m)
    out = m.run()
    watch.final()
    assert m.status == "completed", m.stall_report() if m.status == "stalled" else m.status
    assert out["minerals_delivered"] == out["minerals_total"]
    return out
