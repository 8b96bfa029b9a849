"""A bidder's book of open auctions (engine/robots/known_auctions.py) keeps, as bids are sent
and auctions come and go, the same answers a scan of every auction would give: the list in
opening order without the auctions of peers thought down, and the auctions in which a busy
bidder may still say something (`unsaid`). The mission-level tests (test_fast_paths.py)
cannot see a stale `unsaid` that only adds a target to ask, which sends no bid; these can."""

from __future__ import annotations

import math
import random

from hypothesis import given, settings
from hypothesis import strategies as st

from engine.bidding import OpenAuction
from engine.robots.known_auctions import KnownAuctions


class _Robot:
    def __init__(self) -> None:
        self.down: set[str] = set()


def _auction(i: int, auctioneer: str) -> OpenAuction:
    return OpenAuction(f"a{i}", auctioneer, "excavate", (float(i), 0.0), f"t{i}", float(i % 5))


def _scanned(book: KnownAuctions, robot: _Robot, sent: dict[str, tuple[int, float]]) -> tuple:
    """What a scan of every auction gives: the list in opening order, the auctions not bid
    -inf in, and those not bid in at all."""
    listed = sorted(
        (a for a in book.biddable.values() if a.auctioneer not in robot.down),
        key=lambda a: a.order,
    )
    unrefused = {a.auction_id for a in listed if sent.get(a.auction_id, (0, 0.0))[1] != -math.inf}
    unbid = {a.auction_id for a in listed if a.auction_id not in sent}
    return listed, unrefused, unbid


def test_a_refusal_and_a_bid_move_an_auction_between_the_sets() -> None:
    robot, sent, stirs = _Robot(), {}, []
    book = KnownAuctions(robot, sent, lambda: stirs.append(1))
    book.note_auction(_auction(1, "scout-1"))
    book.note_auction(_auction(2, "scout-2"))
    assert [a.auction_id for a in book.auctions_in_order()] == ["a1", "a2"]
    assert book.unsaid(once=False) == {"a1", "a2"} and book.unsaid(once=True) == {"a1", "a2"}
    sent["a1"] = (0, -math.inf)
    book.note_bid("a1", -math.inf)
    assert book.unsaid(once=False) == {"a2"} and book.unsaid(once=True) == {"a2"}
    sent["a2"] = (0, 12.5)  # a finite bid: distance bids may still be asked again, once not
    book.note_bid("a2", 12.5)
    assert book.unsaid(once=False) == {"a2"} and book.unsaid(once=True) == set()
    sent["a1"] = (1, 3.0)  # a later round's finite bid after a refusal
    book.note_bid("a1", 3.0)
    assert book.unsaid(once=False) == {"a1", "a2"}
    assert [a.auction_id for a in book.unsaid_in_order(once=False)] == ["a1", "a2"]
    robot.down.add("scout-1")
    book.auctioneers_changed()
    assert [a.auction_id for a in book.auctions_in_order()] == ["a2"]
    assert book.unsaid(once=False) == {"a2"}
    assert stirs  # the board of rounds was told each time the list changed


@settings(max_examples=60, deadline=None)
@given(st.integers(0, 2**32 - 1))
def test_the_book_answers_as_a_scan_of_every_auction_does(seed: int) -> None:
    rng = random.Random(seed)
    robot, sent = _Robot(), {}
    book = KnownAuctions(robot, sent, lambda: None)
    book.auctions_in_order()  # kept from here on, not rebuilt
    peers = ["scout-1", "scout-2", "scout-3"]
    for step in range(60):
        move = rng.random()
        ids = list(book.biddable)
        if move < 0.35:
            book.note_auction(_auction(step, rng.choice(peers)))
        elif move < 0.7 and ids:
            aid = rng.choice(ids)
            utility = rng.choice([-math.inf, float(rng.randint(1, 50))])
            sent[aid] = (sent.get(aid, (-1, 0.0))[0] + 1, utility)
            book.note_bid(aid, utility)
        elif move < 0.85 and ids:
            aid = rng.choice(ids)
            book.forget_auction(aid)
            sent.pop(aid, None)
        else:
            peer = rng.choice(peers)
            robot.down ^= {peer}
            book.auctioneers_changed()
        listed, unrefused, unbid = _scanned(book, robot, sent)
        assert book.auctions_in_order() == listed
        assert book.unsaid(once=False) == unrefused
        assert book.unsaid(once=True) == unbid
        assert book.unsaid_in_order(once=False) == [a for a in listed if a.auction_id in unrefused]
