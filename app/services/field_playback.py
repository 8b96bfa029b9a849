"""Playback of a field run: a moment rebuilt from what was stored, never re-simulated.

A field run (real agent processes over Zenoh, docs/field.md) is not a function of its seed,
so `GET …/state?t=` cannot replay it as it replays a simulated mission
(`app/services/playback.py`). Instead each robot reported its own pose every
`field.agent.POSE_INTERVAL_S` of mission time (stored in `poses`), and its events and
auctions were stored as they happened; the state at `t` is read from those rows, in the
shape the simulated playback answers (`StateAt`, its `state` a `Mission.snapshot()`), so the
dashboard's timeline works unchanged:

- a robot is where its two stored poses around `t` put it (linear in between; its last pose
  when none follows within `HOLD_GAP_S`, or when its stored events say it failed before `t`),
  absent before its first pose;
- sites are found, dug and worked as the `site_found` and `dug` events up to `t` say, minerals
  lie on the ground from `mineral_dropped` to `mineral_recovered`, deliveries are the
  `delivered` events;
- the scanned cells are those the scouts' stored tracks pass through: an approximation (the
  engine marks a cell when its scout reaches the cell's waypoint, which is not stored);
- auctions stand as at `t`: opened by then, open until their stored close, with the bids and
  offers made by `t`; the `messages` counter is 0 (messages are not stored).

`moment` is the pure part (rows in, answer out: unit-tested on hand-built rows); `read_stored`
the reading, one session up to `t`.
"""

from __future__ import annotations

import base64
import itertools
import math
from collections.abc import Iterable, Sequence
from dataclasses import dataclass
from typing import Any, NamedTuple

import numpy as np
from sqlalchemy import func, select
from sqlalchemy.orm import Session, selectinload

from app.db.models import Auction, Event, Pose
from app.live.records import auction_dict
from app.services.playback_pool import FEED_AUCTIONS
from engine.team import robot_type

#: A robot whose next pose comes later than this after the last one was not reporting (a
#: process stopped and started again, a stall): it is held at its last pose, not slid across.
#: Four of `field.agent.POSE_INTERVAL_S` (not imported: `field` brings Zenoh, loaded only when
#: a field mission starts; a test holds the two together).
HOLD_GAP_S = 20.0
#: The events a moment is built from (the count of all of them is read apart).
KINDS = (
    "site_found",
    "dug",
    "delivered",
    "mineral_dropped",
    "mineral_recovered",
    "robot_failed",
    "robot_enabled",
    "policy_changed",
    "task_started",
    "task_ended",
)
_TYPES = {"scout": 0, "excavator": 1, "hauler": 2}
#: Points sampled along one stored segment of a scout's track (a long one is a gap: the scout
#: was not reporting, so where it went in between is a guess anyway).
SAMPLES_MAX = 32


class PoseRow(NamedTuple):
    robot: str
    t: float
    x: float
    y: float
    heading: float
    state: str
    load: int


@dataclass(frozen=True)
class Stored:
    """What the database holds of a field run up to `t`."""

    poses: list[PoseRow]  # every pose at or before t, by time
    after: dict[str, PoseRow]  # each robot's first pose after t (within HOLD_GAP_S)
    events: list[dict[str, Any]]  # {seq, t, kind, data} of KINDS at or before t, by seq
    seen: int  # 1 + the largest seq of any event at or before t (0: none)
    reannounced: int  # `auction_reannounced` events at or before t
    auctions: list[dict[str, Any]]  # `AuctionRecord.to_dict()` shapes, opened at or before t


def read_stored(session: Session, mission_id: int, t: float) -> Stored:
    """One mission's rows up to `t` (and the first pose after it, per robot)."""
    cols = (Pose.robot, Pose.t, Pose.x, Pose.y, Pose.heading, Pose.state, Pose.load)
    mine = Pose.mission_id == mission_id
    poses = [PoseRow(*r) for r in session.execute(select(*cols).where(mine, Pose.t <= t))]
    poses.sort(key=lambda p: p.t)
    after: dict[str, PoseRow] = {}
    later = select(*cols).where(mine, Pose.t > t, Pose.t <= t + HOLD_GAP_S).order_by(Pose.t)
    for r in session.execute(later):
        after.setdefault(r[0], PoseRow(*r))
    by = (Event.mission_id == mission_id, Event.t <= t)
    kept = select(Event.seq, Event.t, Event.kind, Event.data).where(*by, Event.kind.in_(KINDS))
    events = [
        {"seq": seq, "t": et, "kind": kind, "data": data}
        for seq, et, kind, data in session.execute(kept.order_by(Event.seq))
    ]
    again = select(func.count()).where(*by, Event.kind == "auction_reannounced")
    last = session.scalar(select(func.max(Event.seq)).where(*by))
    rows = session.scalars(
        select(Auction)
        .where(Auction.mission_id == mission_id, Auction.opened_at <= t)
        .options(selectinload(Auction.bids), selectinload(Auction.awards))
        .order_by(Auction.opened_at, Auction.auction_id)
    )
    seen = 0 if last is None else last + 1
    records = [auction_record(a) for a in rows]
    return Stored(poses, after, events, seen, int(session.scalar(again) or 0), records)


def auction_record(a: Auction) -> dict[str, Any]:
    """A stored auction (its bids and awards loaded) as the engine's `AuctionRecord.to_dict()`
    had it: what a field run is played back and taken back from."""
    return {
        "id": a.auction_id,
        "kind": a.kind,
        "auctioneer": a.auctioneer,
        "task_type": a.task_type,
        "task_id": a.task_id,
        "location": [a.location_x, a.location_y],
        "status": a.status,
        "opened_at": a.opened_at,
        "closed_at": a.closed_at,
        "allocated_to": a.allocated_to,
        "reannouncements": a.reannouncements,
        "reauction_of": a.reauction_of,
        "policy": a.policy,
        "bids": [
            {"t": b.t, "bidder": b.bidder, "utility": b.utility, "round": b.round} for b in a.bids
        ],
        "awards": [{"t": w.t, "winner": w.winner, "outcome": w.outcome} for w in a.awards],
    }


# --- the moment -------------------------------------------------------------------------


def pose_at(before: PoseRow, after: PoseRow | None, t: float) -> tuple[float, float, float]:
    """(x, y, heading) at `t` from the poses around it: linear in between (the heading the
    short way round); `before`'s own when nothing follows within `HOLD_GAP_S`."""
    if after is None or not before.t < after.t <= before.t + HOLD_GAP_S or t <= before.t:
        return before.x, before.y, before.heading
    f = min(1.0, (t - before.t) / (after.t - before.t))
    turn = (after.heading - before.heading + math.pi) % (2 * math.pi) - math.pi
    return (
        before.x + f * (after.x - before.x),
        before.y + f * (after.y - before.y),
        before.heading + f * turn,
    )


def _down(events: Iterable[dict[str, Any]]) -> set[str]:
    """Robots whose last word up to now is `robot_failed` (not enabled since)."""
    last: dict[str, str] = {}
    for e in events:
        if e["kind"] in ("robot_failed", "robot_enabled"):
            last[str(e["data"].get("robot"))] = e["kind"]
    return {r for r, kind in last.items() if kind == "robot_failed"}


def _tasks(events: Iterable[dict[str, Any]]) -> dict[str, str]:
    """Each robot's task in hand: its last started and not ended since."""
    held: dict[str, str] = {}
    for e in events:
        d, robot = e["data"], str(e["data"].get("robot"))
        if e["kind"] == "task_started":
            held[robot] = f"{d.get('task_type')}:{d.get('task_id')}"
        elif e["kind"] == "task_ended" and held.get(robot, "").endswith(f":{d.get('task_id')}"):
            del held[robot]
    return held


def _order(name: str) -> tuple[int, int, str]:
    """The team's order: scouts, excavators, haulers, each by number."""
    head, _, num = name.rpartition("-")
    return _TYPES.get(head, 3), int(num) if num.isdigit() else 0, name


def robots_at(stored: Stored, t: float) -> list[dict[str, Any]]:
    """Every robot that has reported by `t`, as a snapshot lists it."""
    tracks: dict[str, list[PoseRow]] = {}
    for p in stored.poses:
        tracks.setdefault(p.robot, []).append(p)
    down, tasks = _down(stored.events), _tasks(stored.events)
    out = []
    for name in sorted(tracks, key=_order):
        track = tracks[name]
        last, failed = track[-1], name in down
        x, y, heading = pose_at(last, None if failed else stored.after.get(name), t)
        travelled = sum(math.dist((a.x, a.y), (b.x, b.y)) for a, b in itertools.pairwise(track))
        out.append(
            {
                "name": name,
                "type": robot_type(name),
                "state": "failed" if failed else last.state,
                "x": x,
                "y": y,
                "heading": heading,
                "load": last.load,
                "alive": not failed,
                "task": None if failed else tasks.get(name),
                "distance": travelled + math.dist((last.x, last.y), (x, y)),
                "path": [],
                "enabled": not failed,
                "partner": None,
            }
        )
    return out


def sites_at(world_map: dict[str, Any], events: Sequence[dict[str, Any]]) -> list[dict[str, Any]]:
    """The map's sites as the stored events left them: found, pile, who digs there."""
    found: dict[str, float] = {}
    dug: dict[str, tuple[int, str]] = {}
    for e in events:
        d = e["data"]
        if e["kind"] == "site_found":
            found.setdefault(str(d.get("site")), float(e["t"]))
        elif e["kind"] == "dug":
            dug[str(d.get("site"))] = (int(d.get("remaining", 0)), str(d.get("robot")))
    out = []
    for s in world_map.get("sites", []):
        remaining, worker = dug.get(s["id"], (int(s["minerals"]), None))
        out.append(
            {
                "id": s["id"],
                "x": s["x"],
                "y": s["y"],
                "found": s["id"] in found,
                "found_at": found.get(s["id"]),
                "remaining": remaining,
                "total": int(s["minerals"]),
                "excavator": worker if remaining > 0 else None,
            }
        )
    return out


def dropped_at(events: Iterable[dict[str, Any]]) -> list[dict[str, float]]:
    """Minerals on the ground: dropped and not recovered since."""
    ground: dict[str, dict[str, float]] = {}
    for e in events:
        d = e["data"]
        if e["kind"] == "mineral_dropped":
            ground[str(d.get("mineral"))] = {"x": float(d["x"]), "y": float(d["y"])}
        elif e["kind"] == "mineral_recovered":
            ground.pop(str(d.get("mineral")), None)
    return list(ground.values())


def scanned_at(world_map: dict[str, Any], stored: Stored, t: float) -> tuple[str, int, int]:
    """(the bitmap as `Terrain.scanned_b64` encodes it, cells marked, cells in all): the
    cells the scouts' stored tracks pass through by `t`, sampled every half cell."""
    g = world_map.get("grid") or {"cols": 0, "rows": 0, "cell_w": 1.0, "cell_h": 1.0}
    cols, rows, cw, ch = int(g["cols"]), int(g["rows"]), float(g["cell_w"]), float(g["cell_h"])
    cells = np.zeros(cols * rows, dtype=np.uint8)
    tracks: dict[str, list[tuple[float, float]]] = {}
    for p in stored.poses:
        if robot_type(p.robot) == "scout":
            tracks.setdefault(p.robot, []).append((p.x, p.y))
    for robot in robots_at(stored, t):
        if robot["type"] == "scout":
            tracks[robot["name"]].append((robot["x"], robot["y"]))
    step = min(cw, ch) / 2
    pairs = [seg for track in tracks.values() for seg in itertools.pairwise(track)]
    if pairs and cells.size:
        seg = np.asarray(pairs, dtype=float)  # (segments, 2 ends, x/y)
        a, d = seg[:, 0, :], seg[:, 1, :] - seg[:, 0, :]
        longest = float(np.hypot(d[:, 0], d[:, 1]).max())
        f = np.linspace(0.0, 1.0, min(SAMPLES_MAX, math.ceil(longest / step)) + 1)
        pts = a[:, None, :] + f[None, :, None] * d[:, None, :]  # (segments, samples, x/y)
        c = np.clip((pts[..., 0] / cw).astype(int), 0, cols - 1)
        r = np.clip((pts[..., 1] / ch).astype(int), 0, rows - 1)
        cells[(r * cols + c).ravel()] = 1
    bits = np.packbits(cells, bitorder="little")
    return base64.b64encode(bits.tobytes()).decode("ascii"), int(cells.sum()), cols * rows


def auctions_at(records: Sequence[dict[str, Any]], t: float) -> list[dict[str, Any]]:
    """Each auction opened by `t` as it stood then (`auction_dict` shapes, by opening)."""
    out = []
    for rec in records:
        if rec["opened_at"] > t:
            continue
        closed = rec["closed_at"] is not None and rec["closed_at"] <= t
        awards = [w for w in rec["awards"] if w["t"] <= t]
        if not closed:  # an offer not yet answered at t
            awards = [{**w, "outcome": "pending"} if w is awards[-1] else w for w in awards]
        shown = {
            **rec,
            "status": rec["status"] if closed else "open",
            "closed_at": rec["closed_at"] if closed else None,
            "allocated_to": rec["allocated_to"] if closed else None,
            "bids": [b for b in rec["bids"] if b["t"] <= t],
            "awards": awards,
        }
        out.append(auction_dict(shown))
    return out


def moment(
    stored: Stored, t: float, mission: dict[str, Any], world_map: dict[str, Any]
) -> dict[str, Any]:
    """The answer of `…/state?t=` for a field run (`state`, `auctions`, `deliveries`,
    `events`, as the simulated playback's worker gives them). `mission`: its `status` at `t`,
    `policy` at the start, `scenario` name and `seed`."""
    events = stored.events
    policy = mission["policy"]
    for e in events:
        if e["kind"] == "policy_changed":
            policy = str(e["data"].get("new", policy))
    sites = sites_at(world_map, events)
    auctions = auctions_at(stored.auctions, t)
    deliveries = [e for e in events if e["kind"] == "delivered"]
    scanned, scanned_count, cells_total = scanned_at(world_map, stored, t)
    counters = {
        "sites_found": sum(1 for s in sites if s["found"]),
        "sites_total": len(sites),
        "minerals_delivered": len(deliveries),
        "minerals_total": sum(s["total"] for s in sites),
        "auctions": len(auctions),
        "bids": sum(len(a["bids"]) for a in auctions),
        "declines": sum(a["declines"] for a in auctions),
        "reannouncements": stored.reannounced,
        "messages": 0,
    }
    open_ = [a for a in auctions if a["status"] == "open"]
    older = [a for a in auctions[:-FEED_AUCTIONS] if a["status"] == "open"]
    state = {
        "t": t,
        "status": mission["status"],
        "policy": policy,
        "scenario": mission["scenario"],
        "seed": mission["seed"],
        "robots": robots_at(stored, t),
        "sites": sites,
        "dropped": dropped_at(events),
        "scanned": scanned,
        "scanned_count": scanned_count,
        "cells_total": cells_total,
        "auctions": open_,
        "counters": counters,
    }
    return {
        "state": state,
        "auctions": older + auctions[-FEED_AUCTIONS:],
        "deliveries": deliveries,
        "events": stored.seen,
    }
