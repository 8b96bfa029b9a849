"""The policies Regolith ships: the research's three (1–3), Policy 4 (`lookahead`), the
relaxed Policy 2 (5), the centralized baseline (0) and the clairvoyant reference (6).

Registered in this order, which every menu and report follows; a policy added in a module of
its own in this package (docs/policies.md, "Adding a policy") is registered after these.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from types import MappingProxyType
from typing import TYPE_CHECKING

from engine.bidding import BidMemory, Bids, OpenAuction, RobotView, distance_bids, time_bids
from engine.messages import Location
from engine.policies.base import Policy, PolicyContext, earliest
from engine.policies.registry import register_policy

if TYPE_CHECKING:
    from engine.central import Allocator
    from engine.offline import OfflineAllocator


@register_policy
class FirstComeFirstServed(Policy):
    """Policy 1: bid only in the auction that opened first, until it closes."""

    number, name = 1, "fcfs"
    label, colour = "FCFS", "#56b4e9"
    description = "bid only in the auction that opened first"
    targets_from_list = True

    def bid_targets(self, view: RobotView, auctions: Sequence[OpenAuction]) -> list[OpenAuction]:
        return earliest(auctions)


@register_policy
class AnticipatoryCoalitions(FirstComeFirstServed):
    """Policy 2, as specified: a paired hauler follows its excavator and carries only its
    minerals, with no auction; everyone else bids as Policy 1.

    One narrow exception keeps a mission from deadlocking: with no unpaired hauler alive (more
    excavators than haulers, or haulers lost), an auctioned transport — an excavator without a
    partner, or a fallen mineral — would never be carried, so a paired hauler whose own
    partner has no site then bids in transport auctions as Policy 1.
    """

    number, name = 2, "coalition"
    label, colour = "Coalitions", "#e69f00"
    description = "excavator-k and hauler-k work as a pair; the rest bid as Policy 1"
    targets_from_list = False  # a paired hauler's targets depend on its partner

    def targets_from_list_for(self, view: RobotView) -> bool:
        # a hauler's targets are the earliest auction or nothing: one bidding as Policy 1 now
        # (no partner, or one not alive) has the widest, so a quiet noted now holds whatever
        # its partner does later (its targets can only shrink to nothing)
        return view.rtype != "hauler" or not view.has_partner() or not view.paired()

    def no_targets_until(self, view: RobotView) -> float | None:
        if view.rtype == "hauler" and view.partner_working():
            return view.paired_until()
        return None

    def bid_targets(self, view: RobotView, auctions: Sequence[OpenAuction]) -> list[OpenAuction]:
        if view.rtype == "hauler" and view.paired():
            if view.partner_working():
                return []
            return earliest(auctions) if auctions and view.transports_stranded() else []
        return earliest(auctions)

    def coalitions(self) -> bool:
        return True


@register_policy
class NearestFirst(Policy):
    """Policy 3: bid in every open auction; of several awards keep the nearest, decline the rest."""

    number, name = 3, "nearest"
    label, colour = "Nearest", "#009e73"
    description = "bid in every auction; of several awards keep the nearest"
    targets_from_list = True

    def bid_targets(self, view: RobotView, auctions: Sequence[OpenAuction]) -> list[OpenAuction]:
        return list(auctions)

    def collects_awards(self) -> bool:
        return True


class EarlyTransports(Policy):
    """Every mineral's transport is auctioned one hauler drive (from the plant) plus one dig
    before its bucket is expected to fill, so a hauler stands by when it does (parameter
    `lead`; False: when it is full)."""

    defaults = MappingProxyType({"lead": True})

    def __init__(self, context: PolicyContext | None = None) -> None:
        super().__init__(context)
        self.lead = bool(self.params["lead"])

    def transport_lead_s(self, haul_s: float, dig_s: float) -> float:
        return haul_s + dig_s if self.lead else 0.0

    def early_transports(self) -> bool:
        return self.lead


@register_policy
class Lookahead(EarlyTransports):
    """Policy 4: act on what is about to happen (rules, reasons, measurements: docs/policies.md).

    - every mineral's transport is auctioned one hauler drive (from the plant) plus one dig
      before its bucket is expected to fill — the first one while the excavator is still on
      its way — so a hauler stands by when the bucket fills;
    - robots bid the negated expected arrival time (finish what they hold, then drive) and may
      hold `queue` tasks beside the current one;
    - everyone bids in every open auction and keeps the best of simultaneous awards.

    Its parameters switch the rules off one at a time, for the measurements
    (experiments/ablations.py): `lead`, `time_bids`, `bid_all` and `queue` (type → limit).
    """

    number, name = 4, "lookahead"
    label, colour = "Lookahead", "#0072b2"
    description = "early transport auctions, arrival-time bids, one-task queues"
    defaults = MappingProxyType(
        {"lead": True, "time_bids": True, "bid_all": True, "queue": {"hauler": 1, "excavator": 1}}
    )
    # targets are the list (or its earliest); a busy robot's time bids read `changed` only
    # for auctions it bid a finite utility in, so one that refused every target stays quiet
    targets_from_list = True

    def __init__(self, context: PolicyContext | None = None) -> None:
        super().__init__(context)
        self.time_bids = bool(self.params["time_bids"])
        self.bid_all = bool(self.params["bid_all"])
        self.queue: Mapping[str, int] = dict(self.params["queue"])

    def bid_targets(self, view: RobotView, auctions: Sequence[OpenAuction]) -> list[OpenAuction]:
        return list(auctions) if self.bid_all else earliest(auctions)

    def bids(self, view: RobotView, targets: Sequence[OpenAuction], mem: BidMemory) -> Bids:
        return (time_bids if self.time_bids else distance_bids)(view, targets, mem)

    def busy_bids_once(self) -> bool:
        return not self.time_bids  # time bids withdraw a finite bid once the robot is busy

    def collects_awards(self) -> bool:
        return self.bid_all

    def queue_limit(self, rtype: str) -> int:
        return self.queue.get(rtype, 0)


@register_policy
class CentralGreedy(EarlyTransports):
    """The centralized baseline (number 0): a central unit with global state awards each
    auction by a greedy, myopic assignment — the robots free right now to the tasks open right
    now, minimizing their summed travel time (engine/central.py). It is not an optimum: it
    neither waits for a robot about to be free nor plans ahead. Robots bid in every open auction
    so the records look like the others'; the bids do not decide anything."""

    number, name = 0, "central-greedy"
    label, colour = "Central greedy", "#bbbbbb"
    description = "baseline, not decentralized: greedy assignment of free robots to open tasks"
    decentralized = False  # Policy 4's early transport auctions: only the allocation differs
    targets_from_list = True

    def bid_targets(self, view: RobotView, auctions: Sequence[OpenAuction]) -> list[OpenAuction]:
        return list(auctions)

    def allocator(self) -> Allocator | None:
        from engine.central import OracleAllocator

        return OracleAllocator()


@register_policy
class RelaxedCoalitions(AnticipatoryCoalitions):
    """Policy 2 as Regolith first built it: a paired hauler whose partner has no site bids in
    every auction like an unpaired one (docs/policies.md: the study's rule is the strict one,
    `coalition`; this variant is kept to measure the difference)."""

    number, name = 5, "coalition-relaxed"
    label, colour = "Coalitions (relaxed)", "#cc79a7"
    description = "Policy 2, but a paired hauler with an idle partner carries for anyone"

    # Policy 2's answers hold: targets differ from its only while a partner has no site
    targets_from_list_for = AnticipatoryCoalitions.targets_from_list_for
    no_targets_until = AnticipatoryCoalitions.no_targets_until

    def bid_targets(self, view: RobotView, auctions: Sequence[OpenAuction]) -> list[OpenAuction]:
        if view.rtype == "hauler" and view.paired() and view.partner_working():
            return []
        return earliest(auctions)


@register_policy
class Offline(EarlyTransports):
    """The clairvoyant reference (number 6): a schedule of every site and mineral, planned with
    perfect information from t = 0 and carried out through the same auctions
    (engine/offline.py, engine/schedule.py). Not a design: no robot could know what it reads.
    It uses Policy 4's transport lead and one-task queues; a robot bids in the auction of its
    own next planned task (and in any the plan does not cover), but the plan decides."""

    number, name = 6, "offline"
    label, colour = "Offline (clairvoyant)", "#d55e00"
    description = "reference, not decentralized: a clairvoyant schedule planned from t = 0"
    decentralized = False
    targets_pure = False  # the plan is built (and planner queries made) on first ask

    def __init__(self, context: PolicyContext | None = None) -> None:
        super().__init__(context)
        self._oracle: OfflineAllocator | None = None

    def bid_targets(self, view: RobotView, auctions: Sequence[OpenAuction]) -> list[OpenAuction]:
        """The robot's own next planned task, and any task the plan does not cover."""
        plan = self._oracle
        if plan is None:
            return list(auctions)
        return plan.invited(self.global_view, view.name, auctions)

    def queue_limit(self, rtype: str) -> int:
        return 1

    def _planner(self) -> OfflineAllocator:
        if self._oracle is None:
            from engine.offline import OfflineAllocator

            self._oracle = OfflineAllocator()
        return self._oracle

    def allocator(self) -> Allocator | None:
        return self._planner()

    def standby(self, robot: str) -> Location | None:
        return self._planner().standby(self.global_view, robot)
