"""The board of rounds (engine/round_board.py) spares a robot a later round only when the
round would change nothing for it but its noted round, and every round a robot reads is
the one it would have noted itself. `CHECK` verifies both at every round; here over random
operator sequences (failures, returns, newcomers, policy switches, injected tasks, two
actions at one instant) under every policy and busy-bid rule. The event logs themselves
are compared with the board switched off in `test_fast_paths.py` and by the pinned digests.
"""

from __future__ import annotations

import dataclasses

import pytest

import engine.round_board
from engine import POLICIES, Mission, reference_scenario
from engine.bus import EmbeddedBus
from engine.scenario import BusConfig, Protocol
from experiments.chaos import chaos_mission


def _scenario(scale: int, busy_bid: str):  # type: ignore[no-untyped-def]
    scenario = reference_scenario().scaled(scale)
    protocol = Protocol.model_validate({**scenario.protocol.model_dump(), "busy_bid": busy_bid})
    return scenario.model_copy(update={"protocol": protocol})


@pytest.mark.parametrize("policy", sorted(POLICIES))
@pytest.mark.parametrize(("seed", "busy_bid"), [(0, "silent"), (1, "once"), (2, "every_round")])
def test_the_board_skips_only_robots_a_round_leaves_as_they_were(
    policy: str, seed: int, busy_bid: str, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setattr(engine.round_board, "CHECK", True)
    run = chaos_mission(
        _scenario(1, busy_bid), seed, policy, actions=14, window_s=1_500.0, planner="straight"
    )
    assert run.finished, run


def test_at_scale_most_later_rounds_visit_nobody(monkeypatch: pytest.MonkeyPatch) -> None:
    """What the board is for: at scale 3 under silent busy robots, a later round reaches a
    few per cent of the robots that hear it (the rest are busy and quiet), checked as above."""
    monkeypatch.setattr(engine.round_board, "CHECK", True)
    visits = {"rounds": 0, "heard": 0, "visited": 0}
    sparse = engine.round_board.RoundBoard.deliver_sparse

    def counted(self, msg, audience, visit, now):  # type: ignore[no-untyped-def]
        def counting(name: str) -> None:
            visits["visited"] += 1
            visit(name)

        visits["rounds"] += 1
        visits["heard"] += len(audience - {msg.sender})
        sparse(self, msg, audience, counting, now)

    monkeypatch.setattr(engine.round_board.RoundBoard, "deliver_sparse", counted)
    m = Mission(_scenario(3, "silent"), 0, "fcfs", "straight")
    m.run()
    assert m.status == "completed"
    assert visits["rounds"] > 300
    assert visits["visited"] < 0.1 * visits["heard"], visits


def test_a_paired_hauler_is_left_be_until_its_partner_could_be_declared_silent(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """Policy 2: a paired hauler whose partner works has no targets, whatever the auctions
    (`Policy.no_targets_until`). The board leaves it be until its partner's last hearing plus
    the failure timeout, then stirs it (`RoundBoard._wake_due`); checked as above, with
    excavators failing abruptly and gracefully so that partners really fall silent."""
    monkeypatch.setattr(engine.round_board, "CHECK", True)
    woken: list[str] = []
    wake_due = engine.round_board.RoundBoard._wake_due

    def counted(self, now):  # type: ignore[no-untyped-def]
        before = set(self._attentive)
        wake_due(self, now)
        woken.extend(self._attentive - before)

    monkeypatch.setattr(engine.round_board.RoundBoard, "_wake_due", counted)
    m = Mission(_scenario(3, "silent"), 0, "coalition", "straight")
    for t, name, mode in ((400.0, "excavator-1", "abrupt"), (900.0, "excavator-2", "graceful")):
        m.apply({"t": t, "kind": "disable_robot", "args": {"name": name, "mode": mode}})
    m.run()
    assert m.status == "completed"
    assert any(name.startswith("hauler") for name in woken)


def test_a_lossy_bus_keeps_no_board() -> None:

    lossy = reference_scenario().model_copy(update={"bus": BusConfig(loss=0.1)})
    assert Mission(lossy, 0, "fcfs").ctx.bus.board is None
    assert Mission(reference_scenario(), 0, "fcfs").ctx.bus.board is not None
    assert EmbeddedBus.rounds_on_board


def _settled_bidder(m: Mission) -> str:
    """Advance to the first moment some busy bidder is quiet and settled on the board."""
    board = m.ctx.bus.board
    assert board is not None
    while not m.done:
        m.advance(m.now + 50.0)
        for name, robot in m.ctx.robots.items():
            bidder = getattr(robot, "bidder", None)
            if (
                bidder is not None
                and bidder.biddable
                and bidder.my_bids
                and bidder.stays_quiet()
                and name not in board._attentive
            ):
                return name
    raise AssertionError("no bidder ever settled")


CHANGES = {
    "its reservation ends": lambda m, r: r.bidder.let_go(),
    "an auction it bid in closes": lambda m, r: r.bidder.closed(next(iter(r.bidder.my_bids))),
    "an auction it can serve opens": lambda m, r: r.bidder.note_auction(
        dataclasses.replace(next(iter(r.bidder.biddable.values())), auction_id="new", opened_at=1e9)
    ),
    "it forgets an auction": lambda m, r: r.bidder.forget_auction(next(iter(r.bidder.biddable))),
    "an auctioneer went down or came back": lambda m, r: r.bidder.auctioneers_changed(),
    "its task is revoked": lambda m, r: r.on_revoked(),
    "it fails": lambda m, r: r.fail(),
    "the policy changes": lambda m, r: m.set_policy("nearest"),
}


@pytest.mark.parametrize("change", sorted(CHANGES))
def test_whatever_can_end_a_bidders_quiet_stirs_it(change: str) -> None:
    """The board visits a quiet bidder again only once it is stirred: each way its quiet can
    end must stir it (the random sequences above rarely reach some of them). A new policy
    makes every robot look again at once: stirred, or found quiet under the new policy."""
    m = Mission(_scenario(3, "silent"), 0, "fcfs", "straight")
    name = _settled_bidder(m)
    robot = m.ctx.robots[name]
    CHANGES[change](m, robot)
    board = m.ctx.bus.board
    assert board is not None
    if change == "the policy changes":
        assert name in board._attentive or robot.bidder.stays_quiet()
    else:
        assert name in board._attentive
