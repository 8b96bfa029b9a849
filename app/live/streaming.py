"""What a live mission's viewers are sent between frames: the events it logged and the auction
records that changed, noted as they happen (under the gate, on the stepping thread or the
loop) and published by the loop on its next tick."""

from __future__ import annotations

from app.live.mission import LiveMission
from app.live.records import auction_dict
from engine import Event

#: Event kinds not forwarded to viewers: raw bus traffic (bids arrive as `auction` updates).
QUIET_KINDS = frozenset({"message", "bid"})


def note_event(lm: LiveMission, ev: Event) -> None:
    """The mission logged `ev`: note what to stream (the loop sends it)."""
    if not lm.hub.viewers:
        return
    aid = ev.data.get("auction_id")
    if aid is not None:
        lm.dirty_auctions.add(aid)
    if ev.kind not in QUIET_KINDS:
        lm.outbox.append(ev)


def note_auction(lm: LiveMission, auction_id: str) -> None:
    """An auction's record changed with no event naming it: stream it at the next tick."""
    if lm.hub.viewers:
        lm.dirty_auctions.add(auction_id)


def publish_pending(lm: LiveMission) -> None:
    """Stream the events and auction changes noted since the last call (under the gate)."""
    events, lm.outbox = lm.outbox, []
    for ev in events:
        lm.hub.publish({"type": "event", "event": ev.to_dict()})
    if not lm.dirty_auctions:
        return
    dirty, lm.dirty_auctions = lm.dirty_auctions, set()
    if not lm.hub.viewers:
        return
    by_id = {rec.id: rec for rec in lm.mission.auctions if rec.id in dirty}
    for aid in sorted(dirty):
        if aid in by_id:
            lm.hub.publish({"type": "auction", "auction": auction_dict(by_id[aid].to_dict())})
