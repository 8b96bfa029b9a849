"""What an agent's robot is: the engine's own robot class for its type, on a mission
context whose auction records are also reported to mission control."""

from __future__ import annotations

from typing import Any

from engine.auction_rules import AuctionRecord
from engine.context import MissionContext
from engine.geometry import Point
from engine.robots import Excavator, Hauler, Operator, Robot, Scout
from engine.spiral import spiral_routes

_CLASSES: dict[str, type[Robot]] = {"excavator": Excavator, "hauler": Hauler}


class FieldContext(MissionContext):
    """A mission context whose auction records are also reported to mission control."""

    report: Any = None

    def new_auction(self, *args: Any, **kw: Any) -> AuctionRecord:
        rec = super().new_auction(*args, **kw)
        self.report({"kind": "auction", "record": rec.to_dict()})
        return rec

    def close_auction(self, rec: AuctionRecord, status: str, winner: str | None) -> None:
        super().close_auction(rec, status, winner)
        self.report({"kind": "auction", "record": rec.to_dict()})


def make_robot(name: str, rtype: str, ctx: MissionContext, pos: Point) -> Robot:
    """The robot `name` of type `rtype` at `pos` (the operator's console: an auctioneer with
    no body; a scout: with the spiral routes of the whole scouting team)."""
    if rtype == "operator":
        return Operator(name, ctx, pos, 1.0)
    speed = getattr(ctx.scenario.speeds, rtype, 1.0)
    if rtype == "scout":
        world = ctx.world
        routes = spiral_routes(world.grid, world.plant, ctx.scenario.team.scouts)
        return Scout(name, ctx, pos, speed, {f"scout-{i + 1}": r for i, r in enumerate(routes)})
    return _CLASSES[rtype](name, ctx, pos, speed)
