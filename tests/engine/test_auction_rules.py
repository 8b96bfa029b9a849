"""The protocol's pure decisions (docs/spec.md §6, §8) on hand-made inputs."""

import math
from dataclasses import dataclass

import pytest

from engine.auction_rules import rank_bids
from engine.bidding import OpenAuction
from engine.policies import (
    AnticipatoryCoalitions,
    FirstComeFirstServed,
    NearestFirst,
    PendingAward,
    RelaxedCoalitions,
    coalition_partner,
    resolve_policy,
    unused_number,
)


def auction(aid: str, opened: float, task: str = "transport") -> OpenAuction:
    return OpenAuction(aid, "excavator-1", task, (1.0, 2.0), f"t-{aid}", opened)  # type: ignore[arg-type]


def test_highest_utility_wins_and_minus_inf_never_does():
    assert rank_bids({"a": -math.inf, "b": -math.inf}) == []
    assert rank_bids({"a": -10.0, "b": -3.0, "c": -math.inf}) == ["b", "a"]


def test_declined_bidders_are_skipped_and_ties_break_by_name():
    assert rank_bids({"a": -3.0, "b": -3.0}) == ["a", "b"]
    assert rank_bids({"a": -3.0, "b": -3.0}, excluded={"a"}) == ["b"]
    assert rank_bids({"a": -3.0}, excluded={"a"}) == []


def test_the_tie_hook_decides_among_exact_ties_at_the_top_only():
    asked: list[list[str]] = []

    def last(tied):
        asked.append(list(tied))
        return tied[-1]

    bids = {"c": -3.0, "a": -3.0, "b": -3.0, "d": -5.0}
    assert rank_bids(bids, (), last) == ["c", "a", "b", "d"] and asked == [["a", "b", "c"]]
    assert rank_bids({"a": -3.0, "b": -4.0}, (), last) == ["a", "b"]  # no tie: not asked
    assert rank_bids(bids, {"c"}, last) == ["b", "a", "d"]
    assert rank_bids(bids, (), lambda tied: tied[0]) == rank_bids(bids)  # the default rule
    with pytest.raises(ValueError, match="not one of the tied"):
        rank_bids(bids, (), lambda tied: "d")


@dataclass
class View:
    """A robot as a policy sees it (engine.bidding.RobotView), set by hand."""

    rtype: str = "hauler"
    pair: bool = False
    working: bool = False
    stranded: bool = False

    def paired(self) -> bool:
        return self.pair

    def partner_working(self) -> bool:
        return self.working

    def transports_stranded(self) -> bool:
        return self.stranded

    def cost_to(self, a: OpenAuction) -> float:
        return 1.0

    def eta_to(self, a: OpenAuction) -> float:
        return 1.0


def test_policy_1_bids_only_in_the_auction_that_opened_first():
    first, later = auction("y/1", 2.0), auction("x/2", 5.0)
    assert FirstComeFirstServed().bid_targets(View(), [first, later]) == [first]


def test_policy_3_bids_everywhere_and_keeps_the_nearest_award():
    a, b = auction("x/1", 1.0), auction("x/2", 2.0)
    p = NearestFirst()
    assert set(p.bid_targets(View(), [a, b])) == {a, b}
    assert p.collects_awards()
    best = p.choose_award([PendingAward(a, -20.0), PendingAward(b, -5.0)])
    assert best.auction is b


def test_policy_2_paired_haulers_carry_only_for_their_partner_others_bid_as_policy_1():
    a, b = auction("x/1", 1.0), auction("x/2", 2.0)
    p = AnticipatoryCoalitions()
    assert p.bid_targets(View(pair=True, working=True), [a, b]) == []
    assert p.bid_targets(View(pair=True, working=False), [a, b]) == []  # strictly its partner's
    assert p.bid_targets(View(pair=False), [a, b]) == [a]
    assert p.bid_targets(View(rtype="excavator"), [a, b]) == [a]
    # the one exception: a transport nobody else can take (no deadlock), partner idle only
    assert p.bid_targets(View(pair=True, stranded=True), [a, b]) == [a]
    assert p.bid_targets(View(pair=True, working=True, stranded=True), [a, b]) == []
    assert p.bid_targets(View(pair=True, stranded=True), []) == []


def test_relaxed_policy_2_lets_a_hauler_with_an_idle_partner_carry_for_anyone():
    a, b = auction("x/1", 1.0), auction("x/2", 2.0)
    p = RelaxedCoalitions()
    assert p.bid_targets(View(pair=True, working=True), [a, b]) == []
    assert p.bid_targets(View(pair=True, working=False), [a, b]) == [a]
    assert coalition_partner("excavator-3") == "hauler-3"
    assert coalition_partner("hauler-3") == "excavator-3"
    assert coalition_partner("scout-1") is None


def test_policy_names_resolve_from_numbers_and_names():
    assert resolve_policy("2") == "coalition"
    assert resolve_policy(3) == "nearest"
    assert resolve_policy("FCFS") == "fcfs"
    try:
        resolve_policy(str(unused_number()))
    except ValueError as exc:
        assert "policy" in str(exc)
    else:  # pragma: no cover
        raise AssertionError("unknown policy accepted")
