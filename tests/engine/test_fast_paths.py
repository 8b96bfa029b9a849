"""The engine's shortcuts give the very run the plain code they stand for gives.

Each shortcut is switched back to its brute-force form and the event logs compared, over
random scenarios, policies, operator actions (failures, returns, newcomers, policy switches,
injected tasks) and buses (ideal, lossy, late):

- an announcement reaches only the robots that can act on it (`EmbeddedBus._audience`),
  not every robot; a broadcast goes down the list of subscribers made when the last one
  subscribed (`EmbeddedBus._everyone_now`), not a copy made per message;
- on the ideal bus a robot's first look at an announcement notes a re-announcement's round
  itself when that is all the handler would do (`Robot.first_look`, `Bidder.stays_quiet`),
  instead of every announcement going through `on_message`;
- on the ideal bus a later round reaches only the robots it may change something for, and
  the board of rounds notes it for the rest (`engine.round_board`);
- a busy robot that said -inf in every target (or anything at all, under a policy whose
  busy robots never withdraw a bid: `Policy.busy_bids_once`) skips the bidding rules
  (`engine.bidding.refused_all`, `KnownAuctions.unsaid`), one that bids in every auction is
  asked only about those it may still bid in (`KnownAuctions.unsaid_in_order`), and under a
  policy whose targets come from the auction list alone it is not asked again until the list
  or its bids change (`Bidder._note_quiet`);
- a robot's auctions in opening order are kept up to date as auctions come and go
  (`KnownAuctions.note_auction`, `KnownAuctions.forget_auction`), not sorted again;
- the liveness board answers "nobody is silent" from a lower bound (`Liveness.silent`);
- on the ideal bus a bidder looks for missed Closes only among the auctions that ended
  without one (`EmbeddedBus.closes_reach_all`, `Bidder.missed_closes`), not among all it
  knows;
- the crater index looks only at the buckets a segment passes through (`CraterIndex`).
"""

from __future__ import annotations

import hashlib
import json
import math
from collections import deque
from collections.abc import Iterator
from contextlib import contextmanager
from types import SimpleNamespace
from typing import Any

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import engine.robots.bidder
import engine.tangent_planner
from engine import POLICIES, Mission, reference_scenario
from engine.bidding import BidMemory, OpenAuction, distance_bids, refused_all, time_bids
from engine.bus import EmbeddedBus
from engine.geometry import segment_point_distance
from engine.liveness import HISTORY, Liveness
from engine.policies import FirstComeFirstServed, check_policy
from engine.robots.base import Robot
from engine.robots.bidder import Bidder
from engine.robots.known_auctions import KnownAuctions
from engine.scenario import Crater
from engine.world import CLEARANCE, CraterIndex
from tests.engine.factories import play_actions, small_scenario


def _brute_silent(self: Liveness, receiver: str, now: float, timeout: float) -> list[str]:
    r = self.index[receiver]
    return [n for i, n in enumerate(self.names) if i != r and self.heard[r, i] < now - timeout]


def _plain_note(self: KnownAuctions, info: OpenAuction) -> None:
    self.biddable[info.auction_id] = info
    self.in_order = None


def _plain_forget(self: KnownAuctions, auction_id: str) -> OpenAuction | None:
    info = self.biddable.pop(auction_id, None)  # (the bidder forgot its round just before)
    if info is not None:
        self.in_order = None
    return info


def _play(scenario: Any, seed: int, policy: str, actions: list[tuple[float, str, Any]]) -> str:
    m = Mission(scenario, seed, policy)
    play_actions(m, actions)
    m.run()
    return _digest(m)


def _digest(m: Mission) -> str:
    h = hashlib.sha256()
    for e in m.events:
        h.update(json.dumps(e.to_dict(), sort_keys=True).encode())
    return f"{m.status} {len(m.events)} {h.hexdigest()}"


ROBOTS = ["scout-1", "scout-2", "excavator-1", "excavator-2", "hauler-1", "hauler-2"]
ACTION = st.one_of(
    st.tuples(st.sampled_from(["fail", "leave", "enable"]), st.sampled_from(ROBOTS)),
    st.tuples(st.just("add"), st.sampled_from(["scout", "excavator", "hauler"])),
    st.tuples(st.just("policy"), st.sampled_from(list(POLICIES))),
    st.tuples(st.just("inject"), st.sampled_from(["excavate", "transport"])),
)


@given(
    seed=st.integers(0, 10_000),
    policy=st.sampled_from(list(POLICIES)),
    bus=st.sampled_from([{}, {"loss": 0.1}, {"latency_s": 0.3, "jitter_s": 0.2}]),
    busy_bid=st.sampled_from(["once", "every_round", "silent"]),
    actions=st.lists(st.tuples(st.floats(1.0, 600.0), ACTION), max_size=4),
)
@settings(max_examples=16, deadline=None, suppress_health_check=[HealthCheck.too_slow])
def test_shortcuts_change_nothing(seed, policy, bus, busy_bid, actions):
    scenario = small_scenario(
        sites=3,
        minerals=6,
        team={"scouts": 2, "excavators": 2, "haulers": 2},
        bus=bus,
        protocol={"busy_bid": busy_bid},
    )
    plan = [(t, kind, arg) for t, (kind, arg) in sorted(actions, key=lambda a: a[0])]
    fast = _play(scenario, seed, policy, plan)
    with _plain_engine():
        plain = _play(scenario, seed, policy, plan)
    assert fast == plain


@contextmanager
def _plain_engine() -> Iterator[None]:
    """Every shortcut above switched back to its plain form."""
    with pytest.MonkeyPatch.context() as mp:
        mp.setattr(EmbeddedBus, "_audience", lambda self, msg: list(self._subscribers.items()))
        mp.setattr(EmbeddedBus, "_everyone_now", lambda self: list(self._subscribers.items()))
        mp.setattr(engine.robots.bidder, "refused_all", lambda *args: False)
        mp.setattr(KnownAuctions, "unsaid", lambda self, once: {""})  # never "nothing left to say"
        mp.setattr(KnownAuctions, "unsaid_in_order", lambda self, once: self.auctions_in_order())
        mp.setattr(Liveness, "silent", _brute_silent)
        mp.setattr(engine.robots.bidder.Bidder, "_note_quiet", lambda self, auctions, policy: None)
        mp.setattr(KnownAuctions, "note_auction", _plain_note)
        mp.setattr(KnownAuctions, "forget_auction", _plain_forget)
        mp.setattr(Robot, "first_look", lambda self, msg: False)
        mp.setattr(EmbeddedBus, "rounds_on_board", False)
        mp.setattr(EmbeddedBus, "closes_reach_all", False)
        yield


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_switches_between_policy_2_and_policy_4_change_nothing(seed: int) -> None:
    """Later rounds leave Policy 2's quiet haulers and excavators be, so those do not look at
    their situation then; Policy 4's bids read whether it changed since their last look
    (`BidMemory.changed`). Switching back and forth at scale 3 gives the plain engine's run."""
    scenario = reference_scenario().scaled(3)
    protocol = scenario.protocol.model_copy(update={"busy_bid": "silent"})
    scenario = scenario.model_copy(update={"protocol": protocol})
    plan = [(600.0 * k, "policy", ("lookahead", "coalition")[k % 2]) for k in range(1, 6)]
    fast = _play(scenario, seed, "coalition", plan)
    with _plain_engine():
        plain = _play(scenario, seed, "coalition", plan)
    assert fast == plain


@pytest.mark.parametrize("seed", [0, 1, 2, 3])
def test_an_auctioneer_back_before_it_is_missed_ends_its_auctions_as_the_plain_scan_does(
    seed: int,
) -> None:
    """The one way a bidder on the ideal bus misses a Close: the auctioneer failed with the
    auction open (no Close is sent) and came back before its peers judged it down, so its
    new heartbeats no longer list the auction. The bidder that knew it must forget it, as the
    scan of every auction it knows does."""
    scenario = small_scenario(team={"scouts": 1, "excavators": 2, "haulers": 1})
    probe, t = Mission(scenario, seed, "fcfs"), 0.0
    while not _knows_an_auction_of(probe, "hauler-1", "excavator-1"):
        assert not probe.done, "excavator-1 never had an auction that hauler-1 knew"
        t += 1.0
        probe.advance(t)
    known = set(probe.ctx.robots["hauler-1"].bidder.biddable)
    plan = [(t, "fail", "excavator-1"), (t + 5.0, "enable", "excavator-1")]
    fast = Mission(scenario, seed, "fcfs")
    play_actions(fast, plan)
    fast.advance(t + 40.0)  # the hauler's next heartbeats, before any failure verdict
    hauler = fast.ctx.robots["hauler-1"]
    ended = known & fast.ctx.bus.unclosed
    assert ended and not ended & set(hauler.bidder.biddable)
    fast.run()
    with _plain_engine():
        plain = _play(scenario, seed, "fcfs", plan)
    assert _digest(fast) == plain


def _knows_an_auction_of(m: Mission, bidder: str, auctioneer: str) -> bool:
    known = m.ctx.robots[bidder].bidder.biddable.values()
    return m.ctx.robots[auctioneer].alive and any(a.auctioneer == auctioneer for a in known)


@given(
    ops=st.lists(
        st.tuples(
            st.sampled_from(["add", "hb_all", "hb_some", "heard", "introduce", "excuse"]),
            st.integers(0, 40),
            st.floats(0.0, 5.0),
        ),
        max_size=60,
    ),
    timeout=st.floats(0.5, 20.0),
)
@settings(max_examples=300, deadline=None)
def test_silent_peers_match_a_look_at_every_entry(ops, timeout):
    """The floor never hides a silent peer: `silent` answers as a scan of the row does."""
    board = Liveness(capacity=2)
    now, rng = 0.0, np.random.default_rng(0)
    for op, k, dt in ops:
        now += dt
        names = board.names
        if op == "add" or not names:
            board.add(f"r{len(names)}")
        elif op == "introduce":
            board.introduce_all(now)
        elif op == "excuse":  # a receiver deaf for the last dt (a field agent's starved process)
            board.excuse(names[k % len(names)], now - dt, now)
        else:
            sender = names[k % len(names)]
            if op == "heard":
                board.heard_from(names[(k // 2) % len(names)], sender, now)
            else:
                from engine.messages import Heartbeat

                hb = Heartbeat(sender=sender, rtype="scout", t=now, x=0.0, y=0.0, state="idle")
                serial = board.record_heartbeat(hb)
                some = rng.choice(len(names), size=len(names) // 2, replace=False)
                board.deliver_heartbeat(sender, serial, None if op == "hb_all" else some, now)
        for r in board.names:
            assert board.silent(r, now, timeout) == _brute_silent(board, r, now, timeout)


@given(
    beats=st.lists(
        st.tuples(
            st.integers(0, 2),  # sender
            st.lists(st.sampled_from(["t1", "t2", "t3"]), max_size=2, unique=True),
            st.lists(st.tuples(st.floats(0, 99), st.floats(0, 99)), max_size=3),
            st.sets(st.integers(0, 3)),  # who hears it
        ),
        max_size=2 * HISTORY + 10,
    )
)
@settings(max_examples=100, deadline=None)
def test_the_kept_history_answers_with_the_heartbeats_sent(beats):
    """`Liveness` keeps a heartbeat as its field values; what it hands back is the heartbeat
    that was sent (each receiver's last one, and the last one it heard naming a task), as a
    plain list of every heartbeat sent, kept whole, gives."""
    from engine.messages import Heartbeat

    board, names = Liveness(), ["a", "b", "c", "d"]
    for name in names:
        board.add(name)
    sent: dict[str, list[tuple[int, Heartbeat]]] = {n: [] for n in names}
    seen = {(r, s): -1 for r in names for s in names}
    for t, (k, tasks, path, hearers) in enumerate(beats):
        sender = names[k]
        hb = Heartbeat(
            sender=sender, rtype="hauler", t=float(t), x=1.0, y=2.0, state="moving",
            tasks=tuple(tasks), path=tuple(path), load=len(path),
        )  # fmt: skip
        serial = board.record_heartbeat(hb)
        sent[sender].append((serial, hb))
        receivers = np.array(sorted(hearers), dtype=np.int64)
        board.deliver_heartbeat(sender, serial, receivers, float(t))
        for r in hearers:
            seen[names[r], sender] = serial
    for (r, s), want in seen.items():
        kept = sent[s][-HISTORY:]
        last = next((hb for n, hb in kept if n == want), None)
        got = board.last_heartbeat(r, s)
        assert got == last and (got is None or got.to_dict() == last.to_dict())
        for task in ("t1", "t2", "t3"):
            about = next((hb for n, hb in reversed(kept) if n <= want and task in hb.tasks), None)
            assert board.last_heartbeat_about(r, s, task) == about


def test_time_a_receiver_was_deaf_is_not_its_peers_silence():
    board = Liveness()
    for name in ("me", "a", "b"):
        board.add(name)
    board.introduce_all(0.0)
    board.heard_from("me", "a", 95.0)
    board.heard_from("me", "b", 90.0)
    board.excuse("me", 100.0, 400.0)  # no CPU from 100 to 400: heard nothing, listened to nothing
    assert board.silent("me", 400.0, 30.0) == []
    assert board.last_heard("me", "a") == 395.0 and board.last_heard("me", "b") == 390.0
    assert board.silent("me", 421.0, 30.0) == ["b"]  # silent after it woke: silent indeed
    assert board.silent("a", 400.0, 30.0) == ["me", "b"]  # others' views are their own


COORD = st.one_of(st.floats(0.0, 300.0), st.integers(0, 15).map(lambda k: 20.0 * k))
"""Anywhere, or exactly on a bucket boundary (20 m), where rounding would bite."""


@given(
    craters=st.lists(st.tuples(COORD, COORD, st.floats(0.5, 30.0)), max_size=25),
    segments=st.lists(st.tuples(COORD, COORD, COORD, COORD), min_size=1, max_size=25),
)
@settings(max_examples=150, deadline=None)
def test_crater_index_answers_as_a_look_at_every_crater(craters, segments):
    """The index visits only the buckets a segment passes through; it never misses a crater."""
    cs = tuple(Crater(x=x, y=y, r=r) for x, y, r in craters)
    index = CraterIndex(cs)
    for x0, y0, x1, y1 in segments:
        a, b = (x0, y0), (x1, y1)
        brute = all(segment_point_distance(a, b, (c.x, c.y)) > c.r + CLEARANCE for c in cs)
        assert index.segment_free(a, b) == brute
        assert index.point_free(x0, y0) == all(
            math.hypot(x0 - c.x, y0 - c.y) > c.r + CLEARANCE for c in cs
        )


def test_a_policy_that_bids_otherwise_must_say_again_its_targets_come_from_the_list():
    """A busy robot is not asked again while its list and bids stay as they are only under
    a policy that declares it; a subclass that changes how targets or bids are chosen (a
    coalition hauler looks at its partner) must state it again, or the registry refuses it."""

    class ByPartner(FirstComeFirstServed):
        def bid_targets(self, view: Any, auctions: Any) -> Any:
            return []

    class Restated(FirstComeFirstServed):
        targets_from_list = True

        def bid_targets(self, view: Any, auctions: Any) -> Any:
            return list(auctions)[-1:]

    class TimeBids(Restated):
        targets_from_list = True

        def bids(self, view: Any, targets: Any, mem: Any) -> Any:
            return time_bids(view, targets, mem)

    class TimeBidsAnswered(TimeBids):
        def busy_bids_once(self) -> bool:
            return False

    assert FirstComeFirstServed.targets_from_list
    with pytest.raises(ValueError, match="ByPartner: overrides bid_targets"):
        check_policy(ByPartner)
    check_policy(Restated)
    # `busy_bids_once` is a promise about `bids`: time bids withdraw a finite bid
    with pytest.raises(ValueError, match="TimeBids overrides bids but busy_bids_once"):
        check_policy(TimeBids)
    check_policy(TimeBidsAnswered)
    assert not POLICIES["coalition"].targets_from_list
    assert POLICIES["lookahead"].targets_from_list


_AUCTIONS = [
    OpenAuction(f"a{k}", "excavator-1", "transport", (k, 0.0), f"t{k}", k) for k in range(4)
]


@settings(max_examples=200, deadline=None)
@given(
    rule=st.sampled_from([distance_bids, time_bids]),
    targets=st.lists(st.sampled_from(_AUCTIONS), unique=True, max_size=4),
    rounds=st.lists(st.integers(0, 3), min_size=4, max_size=4),
    sent_rounds=st.lists(st.integers(0, 3), min_size=4, max_size=4),
)
def test_a_busy_robot_that_refused_every_target_sends_nothing_whatever_changed(
    rule: Any, targets: list[OpenAuction], rounds: list[int], sent_rounds: list[int]
) -> None:
    """What `targets_from_list` promises of `bids` (Policy 4 relies on it: its time bids read
    `BidMemory.changed`): a busy robot that has bid -inf in every target sends nothing, new
    round or not, its situation changed or not. Then later rounds may leave it be until its
    list or its bids change."""
    sent = {a.auction_id: (r, -math.inf) for a, r in zip(_AUCTIONS, sent_rounds, strict=True)}
    latest = {a.auction_id: r for a, r in zip(_AUCTIONS, rounds, strict=True)}
    view = SimpleNamespace(eta_to=lambda a: 1.0, cost_to=lambda a: 1.0)
    for changed in (False, True):
        mem = BidMemory(busy=True, sent=sent, rounds=latest, changed=changed, every_round=False)
        assert refused_all(sent, targets)
        assert rule(view, targets, mem) == []
    # the promise is about refusals only: one finite bid, withdrawn once the situation changed
    if targets and rule is time_bids:
        finite = {**sent, targets[0].auction_id: (latest[targets[0].auction_id], -5.0)}
        mem = BidMemory(busy=True, sent=finite, rounds=latest, changed=True, every_round=False)
        assert rule(view, targets, mem) == [(targets[0], latest[targets[0].auction_id], -math.inf)]


@settings(max_examples=300, deadline=None)
@given(
    rule=st.sampled_from([distance_bids, time_bids]),
    targets=st.lists(st.sampled_from(_AUCTIONS), unique=True, max_size=4),
    rounds=st.lists(st.integers(0, 3), min_size=4, max_size=4),
    said=st.lists(
        st.one_of(st.none(), st.tuples(st.integers(0, 3), st.sampled_from([-math.inf, -5.0]))),
        min_size=4,
        max_size=4,
    ),
    changed=st.booleans(),
)
def test_a_busy_robot_is_asked_only_about_the_targets_it_has_not_refused(
    rule: Any,
    targets: list[OpenAuction],
    rounds: list[int],
    said: list[tuple[int, float] | None],
    changed: bool,
) -> None:
    """The per-target form of that promise (`Bidder.consider_bids` relies on it): a busy
    robot's bids are the same whether its refused targets are asked about or left out, so a
    quiet robot that bids in every auction is asked only about the few it has not refused
    (thousands of open auctions at scale 100, most of them refused long ago)."""
    sent = {a.auction_id: s for a, s in zip(_AUCTIONS, said, strict=True) if s is not None}
    latest = {a.auction_id: r for a, r in zip(_AUCTIONS, rounds, strict=True)}
    view = SimpleNamespace(eta_to=lambda a: a.location[0], cost_to=lambda a: a.location[0])
    mem = BidMemory(busy=True, sent=sent, rounds=latest, changed=changed, every_round=False)
    open_ones = [a for a in targets if sent.get(a.auction_id, (0, 0.0))[1] != -math.inf]
    assert rule(view, targets, mem) == rule(view, open_ones, mem)
    if rule is distance_bids:  # `Policy.busy_bids_once`: nor about those it bid in at all
        unbid = [a for a in targets if a.auction_id not in sent]
        assert rule(view, targets, mem) == rule(view, unbid, mem)
        assert refused_all(sent, unbid, once=True) == (rule(view, targets, mem) == [])


def test_a_policy_below_one_that_answers_per_robot_must_answer_again():
    """Policy 2's excavators, and its haulers without a partner or with one not alive, bid as
    Policy 1, so a busy one that sent nothing is not asked again (`targets_from_list_for`):
    the earliest auction is the most a hauler's targets can be, so its partner coming back
    only takes targets away. A hauler with a live partner reads it. A subclass that chooses
    targets otherwise must answer again, as for the flag."""
    coalition = POLICIES["coalition"]

    def view(rtype: str, partner: bool, alive: bool = True) -> Any:
        return SimpleNamespace(
            rtype=rtype, has_partner=lambda: partner, paired=lambda: partner and alive
        )

    assert coalition().targets_from_list_for(view("excavator", True))
    assert coalition().targets_from_list_for(view("hauler", False))
    assert coalition().targets_from_list_for(view("hauler", True, alive=False))
    assert not coalition().targets_from_list_for(view("hauler", True))

    class NoAnswer(coalition):  # type: ignore[misc,valid-type]
        def bid_targets(self, view: Any, auctions: Any) -> Any:
            return []

    class Answers(coalition):  # type: ignore[misc,valid-type]
        def targets_from_list_for(self, view: Any) -> bool:
            return False

        def no_targets_until(self, view: Any) -> float | None:
            return None

        def bid_targets(self, view: Any, auctions: Any) -> Any:
            return []

    with pytest.raises(
        ValueError, match="NoAnswer: overrides bid_targets but inherits targets_from_list_for"
    ):
        check_policy(NoAnswer)
    check_policy(Answers)


EXCAVATORS = ["excavator-1", "excavator-2", "excavator-3", "excavator-4"]


@given(
    seed=st.integers(0, 10_000),
    ops=st.lists(
        st.tuples(
            st.floats(50.0, 900.0),
            st.sampled_from(["fail", "leave", "enable"]),
            st.sampled_from(EXCAVATORS),
        ),
        min_size=1,
        max_size=5,
    ),
)
@settings(max_examples=8, deadline=None, suppress_health_check=[HealthCheck.too_slow])
def test_a_partners_departure_and_return_change_nothing_for_a_quiet_hauler(
    seed: int, ops: list[tuple[float, str, str]]
) -> None:
    """Policy 2, excavators failing, leaving and coming back: a busy hauler whose partner is
    not alive is quiet as a Policy 1 robot is (`targets_from_list_for`), and its partner's
    return, which can only take its targets away, changes no event against the plain
    engine."""
    plan = sorted((t, kind, name) for t, kind, name in ops)
    fast = _play(reference_scenario(), seed, "coalition", plan)
    with _plain_engine():
        plain = _play(reference_scenario(), seed, "coalition", plan)
    assert fast == plain


def test_a_busy_hauler_whose_partner_is_not_on_the_team_is_quiet() -> None:
    """What the answer above is for: the reference team has six haulers and four excavators,
    so hauler-5 and hauler-6 name partners that never come; busy, they are quiet (as Policy
    1's haulers are) instead of being asked again at every round of every transport."""
    quiet: set[str] = set()
    note = Bidder._note_quiet

    def noted(self: Bidder, auctions: list[OpenAuction], policy: Any) -> None:
        note(self, auctions, policy)
        if self._quiet_on is auctions:
            quiet.add(self.robot.name)

    with pytest.MonkeyPatch.context() as mp:
        mp.setattr(Bidder, "_note_quiet", noted)
        m = Mission(reference_scenario(), 0, "coalition")
        m.run()
    assert m.status == "completed"
    assert {"hauler-5", "hauler-6"} <= quiet, quiet


@pytest.mark.parametrize(("policy", "expected"), [("nearest", True), ("lookahead", False)])
def test_a_busy_policy_3_excavator_with_finite_bids_left_is_quiet(
    policy: str, expected: bool
) -> None:
    """Policy 3's free excavators bid in every open site, win one and keep their finite bids
    in the others (distance bids never withdraw: `Policy.busy_bids_once`). Busy, they have
    nothing more to say there, so they are quiet instead of being asked at every round of
    every site they bid in (hundreds at scale 100); Policy 4's time bids withdraw, so its
    robots with a finite bid left are not."""
    quiet_with_finite: set[str] = set()
    note = Bidder._note_quiet

    def noted(self: Bidder, auctions: list[OpenAuction], policy: Any) -> None:
        note(self, auctions, policy)
        if self._quiet_on is auctions and any(
            math.isfinite(self.my_bids.get(a.auction_id, (0, -math.inf))[1]) for a in auctions
        ):
            quiet_with_finite.add(self.robot.name)

    with pytest.MonkeyPatch.context() as mp:
        mp.setattr(Bidder, "_note_quiet", noted)
        m = Mission(reference_scenario().scaled(2), 0, policy)  # at scale 1 no site waits
        m.advance(1500.0)
        m.close()
    assert bool(quiet_with_finite) == expected, quiet_with_finite


def test_a_quiet_robot_is_quiet_no_more_once_it_has_room():
    """`Bidder.stays_quiet` (the first look's shortcut) holds only while `consider_bids` would
    return at once: a robot freed since its quiet look must be asked again. Random missions
    rarely catch this (a freed robot bids at once, which clears the cache itself), so it is
    checked on a robot caught quiet."""
    m = Mission(reference_scenario(), 0, "fcfs")
    quiet = None
    while quiet is None and not m.done:
        m.advance(m.now + 25.0)
        quiet = next(
            (r for r in m.robots.values() if r.bidder is not None and r.bidder.stays_quiet()),
            None,
        )
    assert quiet is not None and quiet.bidder is not None
    bidder = quiet.bidder
    held = (quiet.current, quiet.queue, bidder.reserved)
    quiet.current, quiet.queue, bidder.reserved = None, deque(), None
    assert bidder.has_room() and not bidder.stays_quiet()
    quiet.current, quiet.queue, bidder.reserved = held
    assert bidder.stays_quiet()
    m.close()


def test_an_exact_path_forgotten_is_found_again_the_same() -> None:
    """The exact planner keeps only so many solved paths, goal fields and start fans
    (`TangentPlanner.cache_limit`, `_FIELDS` and `_FIELD_BYTES`, `_FANS`): its answers are
    functions of the query alone, so a run that keeps almost nothing is the very run that keeps
    it all."""
    from tests.engine.digests import Case, digest, pinned

    case = Case("fcfs", "silent", 3, planner="exact")
    with pytest.MonkeyPatch.context() as mp:
        mp.setattr(engine.tangent_planner.TangentPlanner, "cache_limit", 8)
        mp.setattr(engine.tangent_planner, "_FIELDS", 1)
        mp.setattr(engine.tangent_planner, "_FIELD_BYTES", 0)
        mp.setattr(engine.tangent_planner, "_FANS", 2)
        assert digest(case) == pinned()[case.key]
