"""The excavator's auctioneer role for transport: task ids for its transports, their open
auctions, and, with radio range on, reporting in when nobody hears one.

Out of range of the base station an excavator's transport auction may reach no idle hauler;
it then drives into reach with the full bucket until a hauler wins the transport
(docs/model.md#radio-range), and back to the site, where the winner waits for it.
"""

from __future__ import annotations

import contextlib
import math
from typing import TYPE_CHECKING, Any

from engine.geometry import dist
from engine.planning import PlanningError
from engine.robots.base import Robot

if TYPE_CHECKING:
    from engine.field import SiteState


class TransportAuctioneer(Robot):
    """What an excavator does as the auctioneer of its minerals' transports."""

    def __init__(self, *args: Any, **kwargs: Any) -> None:
        super().__init__(*args, **kwargs)
        self._transport_serial = 0
        self._back_at = -math.inf  # radio range: when I last came back from reporting in

    def _transport_id(self, kind: str) -> str:
        """A task id never used before: `t` for a transport auctioned ahead, `r` for one
        offered again for a full bucket."""
        self._transport_serial += 1
        return f"{self.name}#{kind}{self._transport_serial}"

    def _transport_open(self, task_id: str) -> bool:
        return self.house.is_open(task_id)

    def _cancel_transport(self, task_id: str) -> None:
        self.house.cancel_task(task_id)  # the partner came back before anyone won it

    # --- radio range: a transport nobody hears ---------------------------------------------
    def unheard(self, task_id: str) -> bool:
        """Is this transport's auction open, unwon, for longer than two retry intervals,
        while I am out of the base station's reach (so, likely, of every idle hauler)?"""
        radio = self.ctx.radio
        assert radio is not None
        if self.house.watching(task_id) or radio.in_contact(self.name):
            return False
        proto = self.ctx.scenario.protocol
        now = float(self.env.now)
        if now - self._back_at <= 2 * proto.retry_s:
            return False  # just back from reporting in: a hauler may be on its way
        return any(
            r.task_id == task_id and now - r.opened_at > 2 * proto.retry_s
            for r in self.house.open_records()
        )

    def report_in(self, site: SiteState, task_id: str) -> Any:
        """Drive into the base's reach with the full bucket until a hauler wins the
        transport (or a few retry intervals pass), then back to the site: the winner waits
        for me there."""
        radio = self.ctx.radio
        assert radio is not None
        self.ctx.observer.emit("reporting_in", robot=self.name, task_id=task_id)
        spot, back = radio.contact_point(self.pos), (site.x, site.y)
        energy = self.ctx.energy
        if energy is not None:
            there_and_back = (dist(self.pos, spot) + dist(spot, back)) * energy.cfg.detour
            if not energy.can_drive(self, there_and_back, back):
                yield from self.recharge()  # bucket and all; then report in from the charger
        self.state = "travelling"
        with contextlib.suppress(PlanningError):
            yield from self.go_to(spot)
        proto = self.ctx.scenario.protocol
        until = float(self.env.now) + 3 * proto.retry_s
        self.state = "reporting"  # (not "waiting": a partner must not take this for a site)
        while (
            not self.house.watching(task_id)
            and self._transport_open(task_id)
            and self.env.now < until
        ):
            yield self.env.timeout(proto.bid_window_s)
        self.state = "travelling"
        yield from self.go_to(back)
        self._back_at = float(self.env.now)
