"""The event account of a scale-K mission: what the protocol must produce, against what the
engine executes to produce it.

    .venv/bin/python bench/event_account.py --scales 1,10,30
    .venv/bin/python bench/event_account.py --scales 100 --policy lookahead

"Must" is what a mission of the specified protocol produces or decides, whatever the code:
messages sent (each announcement round, bid, award, close, heartbeat...), the announcement
deliveries after which a robot sends something (a robot that only notes an auction, busy
or unable to win, could read it off a shared board when it next acts), the bids that can
win (finite), the robots' state changes.
"Executed" is what the engine runs for it: message handler calls, bidding looks
(`Bidder.consider_bids`), planner queries. Their ratio is the distance from the protocol's
own cost, the figure docs/benchmarks.md ("The event account") records. The counters wrap
engine methods in this process only (a fresh process per mission), never in the engine.
"""

from __future__ import annotations

import argparse
import multiprocessing as mp
import time
from collections import Counter
from typing import Any


def account(scale: int, policy: str, busy_bid: str, planner: str) -> dict[str, Any]:
    """Run one mission (seed 0) with counters around the engine's hot paths."""
    from engine import Mission, reference_scenario
    from engine.messages import Announce
    from engine.robots.base import Robot
    from engine.robots.bidder import Bidder
    from engine.scenario import Protocol

    handled: Counter[str] = Counter()
    announce = Counter[str]()
    looks = Counter[str]()
    states = [0]

    on_message = Robot.on_message

    def counted_on_message(self: Robot, msg: Any) -> None:
        kind = type(msg).__name__
        if not self.alive:
            handled[kind + " (dead)"] += 1
            return
        handled[kind] += 1
        if isinstance(msg, Announce):
            first = msg.auction_id not in self.rounds
            bids = self.ctx.observer.bids
            published = self.ctx.bus.published
            on_message(self, msg)
            announce["first hearing" if first else "again"] += 1
            if self.ctx.observer.bids != bids or self.ctx.bus.published != published:
                announce["acted"] += 1
            return
        on_message(self, msg)

    first_look = Robot.first_look

    def counted_first_look(self: Robot, msg: Any) -> bool:
        noted = first_look(self, msg)
        announce["first looks" if not noted else "first looks that sufficed"] += 1
        return noted

    consider = Bidder.consider_bids

    def counted_consider(self: Bidder) -> None:
        bids = self.ctx.observer.bids
        consider(self)
        looks["looks"] += 1
        if self.ctx.observer.bids != bids:
            looks["looks that bid"] += 1

    state_prop = Robot.state

    def set_state(self: Robot, value: str) -> None:
        if value != self.state:
            states[0] += 1
        assert state_prop.fset is not None
        state_prop.fset(self, value)

    Robot.on_message = counted_on_message  # type: ignore[method-assign]
    Robot.first_look = counted_first_look  # type: ignore[method-assign]
    Bidder.consider_bids = counted_consider  # type: ignore[method-assign]
    Robot.state = property(state_prop.fget, set_state)  # type: ignore[assignment,method-assign]

    scenario = reference_scenario().scaled(scale)
    protocol = Protocol.model_validate({**scenario.protocol.model_dump(), "busy_bid": busy_bid})
    scenario = scenario.model_copy(update={"protocol": protocol})
    m = Mission(scenario, 0, policy, planner, keep_events=False)  # type: ignore[arg-type]
    kinds: Counter[str] = Counter()
    messages: Counter[str] = Counter()
    finite = [0]

    def note(ev: Any) -> None:
        kinds[ev.kind] += 1
        if ev.kind == "message":
            messages[ev.data["type"]] += 1
        elif ev.kind == "bid" and ev.data["utility"] is not None:
            finite[0] += 1

    m.subscribe(note)
    t0 = time.perf_counter()
    m.run()
    wall = time.perf_counter() - t0
    robots = sum(1 for r in m.ctx.robots.values() if r.rtype != "operator")
    return {
        "scale": scale,
        "robots": robots,
        "policy": policy,
        "wall": wall,
        "sim": m.now,
        "delivered": f"{m.ctx.terrain.delivered}/{m.ctx.terrain.minerals_total}",
        "events": sum(kinds.values()),
        "kinds": kinds,
        "messages": messages,
        "handled": handled,
        "announce": announce,
        "looks": looks,
        "finite_bids": finite[0],
        "states": states[0],
        "auctions": len(m.auctions),
        "queries": m.ctx.planner.stats.queries,
    }


def _row(label: str, must: float, executed: float, note: str = "") -> str:
    ratio = f"{executed / must:,.1f}×" if must else "–"
    return f"| {label} | {must:,.0f} | {executed:,.0f} | {ratio} | {note} |"


def table(a: dict[str, Any]) -> str:
    msgs, handled, ann = a["messages"], a["handled"], a["announce"]
    first, again = ann["first hearing"], ann["again"]
    acted = ann["acted"]
    looked = ann["first looks"] + ann["first looks that sufficed"]
    hb = msgs["heartbeat"]
    lines = [
        f"scale {a['scale']} ({a['robots']} robots), {a['policy']}: {a['wall']:.1f} s wall, "
        f"{a['sim']:,.0f} simulated s, {a['delivered']} delivered, {a['events']:,} events, "
        f"{a['auctions']:,} auctions",
        "",
        "| what | must | executed | executed / must | how |",
        "| --- | --- | --- | --- | --- |",
        _row(
            "announcement deliveries",
            acted,
            first + again,
            f"must: hearings after which the robot sent something (a bid, mostly); "
            f"executed: hearings through the handler, of {msgs['announce']:,} "
            f"announcements (rounds included), {first:,} of them first hearings; "
            f"besides, {looked:,} first looks (`Robot.first_look`), "
            f"{ann['first looks that sufficed']:,} of which noted a round and stopped there",
        ),
        _row(
            "bidding looks",
            a["looks"]["looks that bid"],
            a["looks"]["looks"],
            f"must: looks that sent a bid; {msgs['bid']:,} bids sent, "
            f"{a['finite_bids']:,} of them finite",
        ),
        _row(
            "pricing (planner queries)",
            a["finite_bids"],
            a["queries"],
            "must: one path per finite bid; executed: every query",
        ),
        _row(
            "heartbeat deliveries",
            hb,
            hb,
            "one column write per heartbeat on the ideal bus",
        ),
        _row(
            "addressed deliveries",
            sum(msgs[k] for k in ("bid", "award", "ack")),
            sum(handled[k] for k in ("Bid", "Award", "Ack")),
            "bids, awards and acks: each to its one addressee",
        ),
        _row("robot state changes", a["states"], a["states"], ""),
        "",
        "messages sent: " + ", ".join(f"{k} {v:,}" for k, v in msgs.most_common()),
        "events: " + ", ".join(f"{k} {v:,}" for k, v in a["kinds"].most_common()),
        "handler calls: " + ", ".join(f"{k} {v:,}" for k, v in handled.most_common()),
    ]
    return "\n".join(lines)


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--scales", default="1,10", help="comma-separated scale factors")
    ap.add_argument("--policy", default="fcfs")
    ap.add_argument("--busy-bid", default="silent", choices=("once", "silent", "every_round"))
    ap.add_argument("--exact-from", type=int, default=30, help="scales >= this plan exactly")
    opts = ap.parse_args()
    ctx = mp.get_context("spawn")
    for scale in (int(s) for s in opts.scales.split(",")):
        planner = "exact" if scale >= opts.exact_from else "ompl"
        with ctx.Pool(1) as pool:
            a = pool.apply(account, (scale, opts.policy, opts.busy_bid, planner))
        print(table(a), end="\n\n", flush=True)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
