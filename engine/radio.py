"""A radio of limited range (docs/model.md#communication).

A message reaches the robots connected to its sender by at most `hops` links, where a link
joins two living robots at most `range_m` apart, or a robot and the plant's base station at
most `base_range_m` apart (the operator's console speaks through the base station). Robots and
the base relay at once (relaying takes no time beyond the bus's latency). Loss and latency, if
configured, apply per receiver on top.

Liveness gossips: a heartbeat carries what its sender last heard from every robot, so a
receiver learns that a robot out of its own reach is alive (`merge`). A peer that falls silent
is judged by where the listener last knew it to be: if, by the positions it believes, the
peer would be out of reach, it is presumed out of range, not failed, and gets
`silent_timeout_s` before the usual probes and verdict.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

import numpy as np

from engine.bus import EmbeddedBus, _deliver_one
from engine.events import Event
from engine.geometry import Point, dist
from engine.messages import Heartbeat, Message
from engine.realism import Radio

if TYPE_CHECKING:
    from engine.context import Believer, MissionContext

BASE = "operator"
"""The base station's node: the operator's console stands at the plant."""


def hop_reach(link: np.ndarray, hops: int) -> np.ndarray:
    """Who reaches whom in at most `hops` links; `link[i, j]` says i and j hear each other."""
    reach = link | np.eye(len(link), dtype=bool)
    step = link.astype(np.int32)
    for _ in range(hops - 1):
        grown = reach | ((reach.astype(np.int32) @ step) > 0)
        if (grown == reach).all():
            break
        reach = grown
    return reach


class RadioNet:
    def __init__(self, cfg: Radio, ctx: MissionContext) -> None:
        self.cfg = cfg
        self.ctx = ctx
        self._key: tuple[float, int] | None = None
        self._names: list[str] = []
        self._reach = np.zeros((0, 0), dtype=bool)
        self._contact = np.zeros(0, dtype=bool)
        self._index: dict[str, int] = {}
        self.detections = 0
        self.false_detections = 0
        self.deliveries = 0  # (message, living robot) pairs a message reached
        self.missed = 0  # (message, living robot) pairs it did not
        ctx.observer.log.subscribe(self._judge_detection)

    # --- the true network, now ---------------------------------------------------------
    def _nodes(self) -> list[tuple[str, Point, float]]:
        """(name, position, reach of its radio) of every radio that is on."""
        plant = self.ctx.world.plant
        base = self.cfg.base_range_m or self.cfg.range_m
        out = [(BASE, plant, base)]
        for r in self.ctx.robots.values():
            if r.alive and r.name != BASE:
                out.append((r.name, r.mobility.position()[0], self.cfg.range_m))
        return out

    def _refresh(self) -> None:
        now = float(self.ctx.env.now)
        alive = sum(1 for r in self.ctx.robots.values() if r.alive)
        key = (now, alive + len(self.ctx.robots) * 100_000)
        if key == self._key:
            return
        self._key = key
        nodes = self._nodes()
        self._names = [n for n, _, _ in nodes]
        self._index = {n: i for i, n in enumerate(self._names)}
        link = _links(nodes)
        self._reach = hop_reach(link, self.cfg.hops)
        # in contact: the base reaches me with a hop to spare, for the robots around it
        self._contact = (
            hop_reach(link, self.cfg.hops - 1)[:, 0]
            if self.cfg.hops > 1
            else np.array([dist(p, nodes[0][1]) <= self.cfg.range_m for _, p, _ in nodes])
        )

    def receivers(self, sender: str) -> list[str]:
        """Who hears a message this sender sends now (the sender excluded)."""
        self._refresh()
        i = self._index.get(sender)
        if i is None:
            return []
        row = self._reach[i]
        out = [self._names[j] for j in np.flatnonzero(row) if j != i]
        self.deliveries += len(out)
        self.missed += len(self._names) - 1 - len(out)
        return out

    def in_contact(self, name: str) -> bool:
        """Does this robot reach the base station (and so the operator and the plant)?"""
        self._refresh()
        i = self._index.get(name)
        return i is not None and bool(self._contact[i])

    def contact_point(self, p: Point) -> Point:
        """Where to drive to regain contact: towards the plant, well inside the base's reach."""
        plant = self.ctx.world.plant
        d = dist(p, plant)
        cfg = self.cfg
        keep = 0.8 * (cfg.base_range_m if cfg.hops > 1 and cfg.base_range_m else cfg.range_m)
        if d <= keep:
            return plant
        world = self.ctx.world
        r = keep
        while r > 0.0:  # the first free point on the way in (a crater may cover the first)
            f = r / d
            q = (plant[0] + (p[0] - plant[0]) * f, plant[1] + (p[1] - plant[1]) * f)
            if world.is_free(*q):
                return q
            r -= 1.0
        return plant

    # --- what a robot believes ---------------------------------------------------------
    def presumed_out_of_reach(self, robot: Believer, peer: str, now: float) -> bool:
        """Silent `peer`: by the positions this robot last heard of (its peers' heartbeats),
        would it be out of reach? Then it is presumed out of range, until silent_timeout_s."""
        board = self.ctx.liveness
        if (
            self.cfg.base_range_m > 0
            and robot.name != BASE
            and now - board.last_heard(robot.name, BASE)
            > 2 * self.ctx.scenario.protocol.heartbeat_s
        ):
            return True  # I have lost the base station's beacon: I am the one out of range
        if now - board.last_heard(robot.name, peer) > self.cfg.silent_timeout_s:
            return False
        hb = board.last_heartbeat(robot.name, peer)
        if hb is None:
            return False
        speeds = self.ctx.scenario.speeds
        nodes = [(robot.name, robot.mobility.position()[0], self.cfg.range_m)]
        nodes.append((BASE, self.ctx.world.plant, self.cfg.base_range_m or self.cfg.range_m))
        slack = [0.0, 0.0]
        for name in board.names:
            if name in (robot.name, BASE, peer) or name in robot.down:
                continue
            other = board.last_heartbeat(robot.name, name)
            if other is not None and now - other.t <= self.cfg.silent_timeout_s:
                nodes.append((name, (other.x, other.y), self.cfg.range_m))
                slack.append(getattr(speeds, other.rtype, 0.0) * max(0.0, now - other.t))
        nodes.append((peer, (hb.x, hb.y), self.cfg.range_m))
        # each may have driven on since its heartbeat: a link counts only if it holds
        # wherever they went
        slack.append(getattr(speeds, hb.rtype, 0.0) * max(0.0, now - hb.t))
        reach = _reach_of(nodes, self.cfg.hops, np.array(slack))
        return not bool(reach[0, -1])

    # --- the researcher's view ---------------------------------------------------------
    def _judge_detection(self, ev: Event) -> None:
        if ev.kind != "failure_detected":
            return
        self.detections += 1
        r = self.ctx.robots.get(ev.data["robot"])
        if r is not None and r.alive:
            self.false_detections += 1

    def metrics(self) -> dict[str, Any]:
        pairs = self.deliveries + self.missed
        return {
            "radio_reach": self.deliveries / pairs if pairs else 1.0,
            "failure_detections": self.detections,
            "false_failures": self.false_detections,
            "false_failure_rate": self.false_detections / self.detections
            if self.detections
            else 0.0,
        }


def _reach_of(
    nodes: list[tuple[str, Point, float]], hops: int, slack: np.ndarray | None = None
) -> np.ndarray:
    """Who reaches whom among these radios. Two robots hear each other within the robots'
    range; the base station and a robot within the base's range (its mast and power make the
    link, both ways). `slack`: how far each node may be from the position given (a link must
    hold wherever it is)."""
    return hop_reach(_links(nodes, slack), hops)


def _links(nodes: list[tuple[str, Point, float]], slack: np.ndarray | None = None) -> np.ndarray:
    pos = np.array([p for _, p, _ in nodes], dtype=float).reshape(len(nodes), 2)
    radius = np.array([r for _, _, r in nodes], dtype=float)
    d = np.hypot(pos[:, None, 0] - pos[None, :, 0], pos[:, None, 1] - pos[None, :, 1])
    if slack is not None:
        d = d + slack[:, None] + slack[None, :]
    link: np.ndarray = d <= np.minimum(radius[:, None], radius[None, :])
    for b, (name, _, r) in enumerate(nodes):
        if name == BASE:
            link[b, :] = link[:, b] = d[b, :] <= r
    return link


class RangedBus(EmbeddedBus):
    """The embedded bus, delivering each message only to the robots in reach of its sender."""

    def __init__(self, net: RadioNet, *args: Any) -> None:
        super().__init__(*args)
        self.net = net
        self._ideal = False
        self.board = None  # robots out of reach hear nothing: every copy goes to its robot

    def publish(self, msg: Message) -> None:
        self.published += 1
        self._on_publish(msg)
        heard = self.net.receivers(msg.sender)
        if isinstance(msg, Heartbeat):
            self._ranged_heartbeat(msg, heard)
            return
        cfg = self._cfg
        if cfg.loss == 0.0 and cfg.latency_s == 0.0 and cfg.jitter_s == 0.0:
            ev = self._env.timeout(0.0)
            ev.callbacks.append(lambda _e: self._deliver_now(msg, heard))
            return
        handlers = self._subscribers
        self._send_lossy(msg, [(n, handlers[n]) for n in heard if n in handlers])

    def _deliver_now(self, msg: Message, heard: list[str]) -> None:
        t = float(self._env.now)
        for name in heard:
            handler = self._subscribers.get(name)
            if handler is not None:
                _deliver_one(self._liveness, name, handler, msg, t)

    def _ranged_heartbeat(self, hb: Heartbeat, heard: list[str]) -> None:
        board, cfg = self._liveness, self._cfg
        serial = board.record_heartbeat(hb)
        receivers = np.array([board.index[n] for n in heard if n in board.index], dtype=np.int64)
        if cfg.loss > 0.0 and len(receivers):
            kept = self._rng.random(len(receivers)) >= cfg.loss
            self.lost += int(len(receivers) - kept.sum())
            receivers = receivers[kept]
        delay = cfg.latency_s + (cfg.jitter_s * self._rng.random() if cfg.jitter_s else 0.0)
        ev = self._env.timeout(delay)

        def deliver(_e: Any) -> None:
            t = float(self._env.now)
            board.deliver_heartbeat(hb.sender, serial, receivers, t)
            merge(board, board.index[hb.sender], receivers)

        ev.callbacks.append(deliver)


def merge(board: Any, sender: int, receivers: np.ndarray) -> None:
    """Gossip: each receiver now knows of every robot what the sender knew, if that is newer
    (when each was last heard from, and its latest heartbeat)."""
    if not len(receivers):
        return
    n = len(board.names)
    theirs = board.heard[sender, :n]
    mine = board.heard[receivers, :n]
    known = np.isfinite(theirs)
    newer = known & (~np.isfinite(mine) | (theirs > mine))
    board.heard[receivers, :n] = np.where(newer, theirs, mine)
    seen = board.hb_seen[receivers, :n]
    board.hb_seen[receivers, :n] = np.maximum(seen, board.hb_seen[sender, :n])
