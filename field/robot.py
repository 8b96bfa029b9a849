"""What an agent's robot is: the engine's own robot class for its type, on a mission
context whose auction records are also reported to mission control."""

from __future__ import annotations

from typing import Any

from engine.auction_rules import AuctionRecord
from engine.context import MissionContext
from engine.geometry import Point
from engine.robots import Robot
from engine.team import build_robot, scout_routes


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
    """The robot `name` as a simulated mission builds it (`engine.team`)."""
    routes = scout_routes(ctx.world, ctx.scenario.team.scouts) if rtype == "scout" else {}
    return build_robot(name, rtype, ctx, pos, routes)
