"""Who may ask the world service for what, and when (docs/field.md, "Trust").

The world service is the ground truth of a field mission, so each operation is checked
against the signed identity of the robot that asks (`field.trust.Certificate`) before it is
carried out: reads are any member's; an operation that changes the world only the robot it
concerns may ask, and only when the world's own record allows it (a delivery only by a
hauler that holds a mineral, a hand-over only with the giving excavator's signed consent
(its `Transfer` message), a pile only ever one mineral smaller and only by its digger, a find
only of a site the world showed that scout, a scan only of a cell that exists). While the
mission is paused nothing changes the world: such an operation is answered `PAUSED`.
"""

from __future__ import annotations

import base64
import binascii
from typing import TYPE_CHECKING, Any

from field.trust import Certificate, Rejected
from field.wire import body_key

if TYPE_CHECKING:
    from field.world_service import WorldService

READS = frozenset({"site_at", "site", "sites_near", "ground", "status"})
ROLE_OPS: dict[str, frozenset[str]] = {
    "scout": frozenset({"found", "scan"}),
    "excavator": frozenset({"site_set", "drop"}),
    "hauler": frozenset({"pick", "handover", "deliver", "drop"}),
    "operator": frozenset(),
}


PAUSED = "paused"
"""The world's answer to an operation that would change it while the mission is paused:
not a refusal, "ask again once time moves" (`Agent.ask_world`)."""
CHANGES = frozenset({"deliver", "pick", "drop", "handover", "site_set", "found", "scan"})
"""The operations that move a mineral or change the world: none while paused."""


class Paused(Exception):
    """The mission is paused: the world does not change (`PAUSED`)."""


class Refused(ValueError):
    """An operation its asker may not make (answered `ok: false` with the reason)."""


def authorize(ws: WorldService, op: str, a: dict[str, Any], caller: Certificate) -> None:
    """Raise `Refused` unless `caller` may ask `op` with these arguments now."""
    me = caller.name
    if op == "spawn":
        if a.get("name") != me:
            raise Refused(f"name: {me} cannot join as {a.get('name')!r}")
        return
    if op in READS:
        return
    if op == "settle":
        _own_id(a, me)
        return
    if op not in ROLE_OPS.get(caller.role, frozenset()):
        raise Refused(f"op: a {caller.role} may not {op}")
    if a.get("by") != me:
        raise Refused(f"by: {me} cannot act as {a.get('by')!r}")
    if "once" in a:
        _own_id(a, a["src"] if op == "handover" else me)
    load = ws.loads.get(me, 0)
    if op in ("drop", "deliver") and load <= 0:
        raise Refused(f"{op}: {me} carries nothing")
    if op in ("pick", "handover") and load > 0:
        raise Refused(f"{op}: {me}'s bin is full")
    if op == "scan":
        cell = a.get("cell")
        if not isinstance(cell, int) or not 0 <= cell < len(ws.terrain.scanned):
            raise Refused(f"cell: {cell!r} is not a cell of this map")
    elif op == "found":
        if a.get("id") not in ws.revealed.get(me, ()):
            raise Refused(f"id: {me} has not seen site {a.get('id')!r}")
    elif op == "site_set":
        _dig(ws, a, me)
    elif op == "handover":
        _consented(ws, a, me)


def _own_id(a: dict[str, Any], owner: str) -> None:
    if not str(a.get("once", "")).startswith(f"{owner}@"):
        raise Refused(f"once: not an id of {owner}'s")


def _dig(ws: WorldService, a: dict[str, Any], me: str) -> None:
    """A pile changes only by one mineral dug by the excavator working it; a site is taken
    only when free and given up only by its worker."""
    s = ws.site(a.get("id"))
    if s.worker not in (None, me):
        raise Refused(f"id: site {s.id} is worked by {s.worker}")
    if "worker" in a and a["worker"] not in (None, me):
        raise Refused(f"worker: {me} cannot give site {s.id} to {a['worker']!r}")
    if "last_worker" in a and a["last_worker"] != me:
        raise Refused(f"last_worker: {me} cannot name {a['last_worker']!r}")
    if "remaining" in a and (a["remaining"] != s.remaining - 1 or s.remaining <= 0):
        raise Refused(f"remaining: a dig takes one mineral (site {s.id} has {s.remaining})")


def _consented(ws: WorldService, a: dict[str, Any], me: str) -> None:
    """The giving excavator's own signed `Transfer` hand-over message to this hauler (a
    `handover` query, `field.bodies.FieldRendezvous`), with this id."""
    src = a.get("src")
    if ws.loads.get(str(src), 0) <= 0:
        raise Refused(f"src: {src!r} carries nothing")
    try:
        frame = base64.b64decode(str(a.get("consent", "")), validate=True)
        opened = ws.link.opener.open(body_key(ws.mission, me), frame)
        req = opened.json()
        op, msg, once = req["op"], req["args"]["msg"], req["args"]["once"]
    except (Rejected, binascii.Error, ValueError, KeyError, TypeError):
        raise Refused(f"consent: no signed transfer from {src!r}") from None
    if opened.sender != src or (op, msg, once) != ("handover", "transfer", a.get("once")):
        raise Refused(f"consent: no signed transfer from {src!r}")
