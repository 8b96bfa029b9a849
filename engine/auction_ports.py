"""What an auctioneer (`engine.auction_house.AuctionHouse`) needs of its mission: the ports
the mission context (`engine.context`) and the field's world service fill, kept apart so the
house reads as the auction over time and its contract with the mission reads in one place."""

from __future__ import annotations

from collections.abc import Mapping, Sequence, Set
from typing import TYPE_CHECKING, Any, Protocol

import simpy

from engine.auction_rules import AuctionRecord
from engine.messages import Heartbeat, Location, Message, TaskType

if TYPE_CHECKING:
    from engine.scenario import Protocol as ProtocolSettings


class HeartbeatBoard(Protocol):
    """What the house reads of the liveness board to watch its winners."""

    def last_heartbeat(self, receiver: str, sender: str) -> Heartbeat | None: ...
    def last_heartbeat_about(
        self, receiver: str, sender: str, task_id: str
    ) -> Heartbeat | None: ...
    def holder_of(self, receiver: str, task_id: str, but: str | None = None) -> str | None: ...


class AuctionPorts(Protocol):
    """What an auctioneer needs of the mission, and nothing more: the clock, the protocol's
    timing, the bus, the observer's records, the heartbeats it hears (to watch winners), the
    road to the plant (where a lost mineral is searched for), the policy's choice among
    bidders tied exactly at the top and, for the centralized baseline only, an oracle's award
    order (None: the auctioneer ranks the bids)."""

    env: simpy.Environment

    @property
    def liveness(self) -> HeartbeatBoard: ...

    @property
    def protocol(self) -> ProtocolSettings: ...
    def publish(self, msg: Message) -> None: ...
    def emit(self, kind: str, /, **data: Any) -> None: ...
    def new_auction(
        self,
        auctioneer: str,
        kind: str,
        task_type: TaskType,
        location: Location,
        task_id: str,
        search_path: tuple[Location, ...],
        reauction_of: str | None,
    ) -> AuctionRecord: ...
    def close_auction(self, rec: AuctionRecord, status: str, winner: str | None) -> None: ...
    def note_decline(self, rec: AuctionRecord, winner: str, outcome: str) -> None: ...
    def oracle_rank(
        self, rec: AuctionRecord, bids: Mapping[str, float], excluded: Set[str]
    ) -> list[str] | None: ...
    def break_tie(self, rec: AuctionRecord, tied: Sequence[str]) -> str: ...
    def road_to_plant(self, start: Location) -> tuple[Location, ...]: ...
