"""The shapes a live mission's records take on their way out (streamed, stored, answered),
and the record of a mission that failed."""

from __future__ import annotations

from typing import Any


def auction_dict(record: dict[str, Any]) -> dict[str, Any]:
    """An auction in the one shape every answer carries (REST `AuctionRead`, the stream's
    `auction` messages, a snapshot's open auctions): the engine's record plus `declines`."""
    declines = sum(1 for w in record["awards"] if w["outcome"] == "declined")
    return {**record, "declines": declines}


def describe(exc: BaseException) -> str:
    """An exception as one stored line (its type and the start of its message)."""
    text = str(exc).splitlines()[0] if str(exc) else ""
    return f"{type(exc).__name__}: {text}"[:300]


def failed_record(changes: dict[str, Any], reason: str) -> dict[str, Any]:
    """A mission's final record, ended as failed with `reason` (its metrics and last state
    left out: they are what could not be trusted)."""
    out = {k: v for k, v in changes.items() if k not in ("metrics", "final_state")}
    return {**out, "status": "failed", "error": changes.get("error") or reason}


def stream_state(state: dict[str, Any] | None) -> dict[str, Any] | None:
    """A snapshot (live, or stored as a mission's final state) with its auctions so shaped."""
    if state is None:
        return None
    return {**state, "auctions": [auction_dict(a) for a in state["auctions"]]}
