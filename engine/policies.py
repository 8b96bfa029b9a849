"""How a robot treats several open auctions (docs/spec.md §8), behind one interface.

A policy is a strategy over a read-only view of the robot (`engine.bidding.RobotView`) and
what the robot knows; it answers, as pure functions: which open auctions to bid in
(`bid_targets`), what to bid and when to bid again (`bids`, choosing one of the rules in
engine/bidding.py), whether to gather simultaneous awards and which to keep
(`collects_awards`, `choose_award`), how many won tasks a robot may queue (`queue_limit`),
whether excavator–hauler coalitions are active (`coalitions`), and when an excavator
auctions the transport of its next mineral (`transport_lead_s`). A new policy is one
subclass with its metadata (number, name, label, colour, description, decentralized) passed
to `register_policy`; no robot code changes, and the CLI, the API, the dashboard and the
tests all read the registry (`policy_table`).
"""

from __future__ import annotations

import re
from collections.abc import Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any, TypedDict

from engine.bidding import BidMemory, Bids, OpenAuction, RobotView, distance_bids, time_bids
from engine.messages import Location

if TYPE_CHECKING:
    from engine.central import Allocator
    from engine.context import MissionContext
    from engine.offline import OfflineAllocator


@dataclass(frozen=True, slots=True)
class PendingAward:
    auction: OpenAuction
    utility: float


class Policy:
    """The interface, and the metadata every registered policy states about itself."""

    number = -1
    name = "base"
    label = ""  # short human name for charts and menus ("Coalitions")
    colour = "#a3b1c2"  # one hex colour per policy, used by every chart and menu
    description = ""  # one line
    decentralized = True  # False: some unit with global knowledge decides (the baseline)
    targets_pure = True
    """`bid_targets` only reads: a robot that provably sends no bid may skip asking it."""
    targets_from_list = False
    """`bid_targets` reads nothing but the auction list, and `bids` never reads
    `BidMemory.changed`: a busy robot that sent nothing need not ask again until the list or
    its own bids change (a hauler hears every re-announcement of every waiting transport).
    A subclass that overrides either method must say so again."""

    def __init_subclass__(cls, **kwargs: Any) -> None:
        super().__init_subclass__(**kwargs)
        own = cls.__dict__
        if ("bid_targets" in own or "bids" in own) and "targets_from_list" not in own:
            cls.targets_from_list = False

    def bid_targets(self, view: RobotView, auctions: Sequence[OpenAuction]) -> list[OpenAuction]:
        """Of the open auctions the robot can serve, given in opening order, those it bids in now
        (the view says whether it is a hauler paired under a coalition policy, and more)."""
        raise NotImplementedError

    def bids(self, view: RobotView, targets: Sequence[OpenAuction], mem: BidMemory) -> Bids:
        """The bids to send now in the target auctions: the negated path length by default
        (docs/spec.md §6.2); `engine/bidding.py` holds the rules to choose from."""
        return distance_bids(view, targets, mem)

    def collects_awards(self) -> bool:
        """Gather awards that arrive together and keep only the best?"""
        return False

    def choose_award(self, awards: Sequence[PendingAward]) -> PendingAward:
        """Of several awards, the one to accept: highest utility, then earliest opened."""
        return min(awards, key=lambda a: (-a.utility, a.auction.order))

    def coalitions(self) -> bool:
        return False

    def transport_lead_s(self, haul_s: float, dig_s: float) -> float:
        """How long before a bucket is expected to fill the excavator auctions its transport
        (0: when it is full), given a hauler's straight drive from the plant to the site and
        the time one dig takes."""
        return 0.0

    def early_transports(self) -> bool:
        """Can a transport be auctioned before its excavator stands at the site with a full
        bucket (a positive transport lead)? Then a hauler that arrives first waits there."""
        return False

    def queue_limit(self, rtype: str) -> int:
        """How many won tasks a robot of this type may hold beside the one it works on and
        still bid a finite utility (0: a robot with any task is busy and bids -inf)."""
        return 0

    def allocator(self) -> Allocator | None:
        """An oracle that picks auction winners from global state (the centralized baseline);
        None: the auctioneer ranks the bids (docs/spec.md §6)."""
        return None

    def standby(self, ctx: MissionContext, robot: str) -> Location | None:
        """Where a robot with nothing to do should wait (the offline reference's pre-placed
        robots); None: it waits where it is."""
        return None


POLICIES: dict[str, type[Policy]] = {}
"""The registry: name → class, in registration order (which every menu and report follows)."""
POLICY_NAMES: dict[int, str] = {}
_HEX = re.compile(r"^#[0-9a-f]{6}$")


def register_policy(cls: type[Policy]) -> type[Policy]:
    """Plug a policy in (a class decorator): the one place the CLI, the API, the dashboard and
    the tests learn of it. Refuses metadata they could not show, or a number another policy has,
    because `resolve_policy` and every menu key on them."""
    if not cls.name or cls.name != cls.name.lower() or not cls.label or not cls.description:
        raise ValueError(
            f"{cls.__name__}: a policy needs a lower-case name, a label and a description"
        )
    if cls.number < 0 or not _HEX.match(cls.colour):
        raise ValueError(f"{cls.__name__}: number must be >= 0 and colour '#rrggbb' (lower case)")
    taken = POLICY_NAMES.get(cls.number)
    if taken is not None and taken != cls.name:
        raise ValueError(f"{cls.__name__}: number {cls.number} is already {taken!r}")
    POLICIES[cls.name] = cls
    POLICY_NAMES[cls.number] = cls.name
    return cls


class PolicyMeta(TypedDict):
    """One registered policy as plain data (JSON-ready)."""

    number: int
    name: str
    label: str
    colour: str
    description: str
    decentralized: bool


def policy_table() -> list[PolicyMeta]:
    """Every registered policy's metadata in registration order: what the CLI help, the API
    (`GET /api/policies`), the dashboard and the tests list, so none keeps its own copy."""
    return [
        PolicyMeta(
            number=p.number,
            name=p.name,
            label=p.label,
            colour=p.colour,
            description=p.description,
            decentralized=p.decentralized,
        )
        for p in POLICIES.values()
    ]


def policy_help() -> str:
    """The registered policies as one line of CLI help: `1|fcfs (FCFS), …`."""
    return ", ".join(f"{p['number']}|{p['name']} ({p['label']})" for p in policy_table())


def earliest(auctions: Sequence[OpenAuction]) -> list[OpenAuction]:
    """The auction that opened first (the list comes in opening order)."""
    return [auctions[0]] if auctions else []


@register_policy
class FirstComeFirstServed(Policy):
    """Policy 1: bid only in the auction that opened first, until it closes."""

    number, name = 1, "fcfs"
    label, colour = "FCFS", "#56b4e9"
    description = "bid only in the auction that opened first"
    targets_from_list = True

    def bid_targets(self, view: RobotView, auctions: Sequence[OpenAuction]) -> list[OpenAuction]:
        return earliest(auctions)


_NUMBER = re.compile(r"-(\d+)$")


def coalition_partner(name: str) -> str | None:
    """Policy 2's pairs: excavator-k works with hauler-k (a rule every robot can apply)."""
    m = _NUMBER.search(name)
    if m is None:
        return None
    if name.startswith("excavator-"):
        return f"hauler-{m.group(1)}"
    if name.startswith("hauler-"):
        return f"excavator-{m.group(1)}"
    return None


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

    def bid_targets(self, view: RobotView, auctions: Sequence[OpenAuction]) -> list[OpenAuction]:
        if view.rtype == "hauler" and view.paired():
            if view.partner_working():
                return []
            return earliest([a for a in auctions if view.stranded(a)])
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
    before its bucket is expected to fill, so a hauler stands by when it does (`lead`)."""

    lead = True

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

    The class attributes switch the rules off one at a time, for the measurements.
    """

    number, name = 4, "lookahead"
    label, colour = "Lookahead", "#0072b2"
    description = "early transport auctions, arrival-time bids, one-task queues"
    queue: dict[str, int] = {"hauler": 1, "excavator": 1}  # noqa: RUF012 - read-only table
    time_bids = True
    bid_all = True

    def bid_targets(self, view: RobotView, auctions: Sequence[OpenAuction]) -> list[OpenAuction]:
        return list(auctions) if self.bid_all else earliest(auctions)

    def bids(self, view: RobotView, targets: Sequence[OpenAuction], mem: BidMemory) -> Bids:
        return (time_bids if self.time_bids else distance_bids)(view, targets, mem)

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

    def __init__(self) -> None:
        self._oracle: OfflineAllocator | None = None

    def bid_targets(self, view: RobotView, auctions: Sequence[OpenAuction]) -> list[OpenAuction]:
        """The robot's own next planned task, and any task the plan does not cover."""
        name, ctx = getattr(view, "name", None), getattr(view, "ctx", None)
        if self._oracle is None or name is None or ctx is None:
            return list(auctions)
        plan = self._oracle
        return [a for a in auctions if plan.invites(ctx, name, a.location, a.task_type)]

    def queue_limit(self, rtype: str) -> int:
        return 1

    def _planner(self) -> OfflineAllocator:
        if self._oracle is None:
            from engine.offline import OfflineAllocator

            self._oracle = OfflineAllocator()
        return self._oracle

    def allocator(self) -> Allocator | None:
        return self._planner()

    def standby(self, ctx: MissionContext, robot: str) -> Location | None:
        return self._planner().standby(ctx, robot)


ALIASES = {"central": "central-greedy"}
"""Former names, still accepted (scripts, stored missions and sweeps that used them)."""


def resolve_policy(value: str | int) -> str:
    """'2', 2 or 'coalition' → 'coalition'; raises ValueError naming the choices."""
    text = str(value).strip().lower()
    if text.isdigit() and int(text) in POLICY_NAMES:
        return POLICY_NAMES[int(text)]
    text = ALIASES.get(text, text)
    if text in POLICIES:
        return text
    choices = ", ".join(f"{n}|{name}" for n, name in sorted(POLICY_NAMES.items()))
    raise ValueError(f"policy: unknown policy {value!r} (choose one of {choices})")


def make_policy(name: str | int) -> Policy:
    return POLICIES[resolve_policy(name)]()
