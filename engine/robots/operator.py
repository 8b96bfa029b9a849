"""The human operator's console: an auctioneer on the bus with no body (docs/spec.md §4: any
robot or a human can auction a task). It cannot fail, and it answers no auctions."""

from __future__ import annotations

from typing import Any

from engine.robots.base import Robot

OPERATOR = "operator"


class Operator(Robot):
    rtype = "operator"
    capability = None

    def life(self) -> Any:
        yield self.env.event()  # nothing to do between operator commands

    def fail(self) -> None:
        raise RuntimeError("the operator console cannot fail")
