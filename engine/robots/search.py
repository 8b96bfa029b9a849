"""A scout's share of the search: its route of grid cells and how far along it is, every
scout's plan as far as it knows, the sites it knows of, and sharing cells with a newcomer
(Handoff), taking over a silent scout's cells and giving them back."""

from __future__ import annotations

from typing import TYPE_CHECKING, Protocol

from engine.messages import Handoff, Hello, Takeover

if TYPE_CHECKING:
    from engine.context import MissionContext

SHARE_MIN = 4
"""A scout shares its route only if each half would have at least this many cells."""


class _Peers(Protocol):
    rejoining: bool

    def peers_of_type(self, rtype: str) -> list[str]: ...
    def peer_alive(self, name: str) -> bool: ...


class SearchingRobot(Protocol):
    """What the search part needs of its scout."""

    name: str
    ctx: MissionContext

    @property
    def recovery(self) -> _Peers: ...
    @property
    def down(self) -> set[str]: ...
    @property
    def participating(self) -> bool: ...
    def wake(self) -> None: ...


class Search:
    """The cells a scout scans, and how scouts share them."""

    def __init__(self, robot: SearchingRobot, routes: dict[str, list[int]]) -> None:
        self.robot = robot
        self.name = robot.name
        self.ctx = robot.ctx
        self.env = robot.ctx.env
        # every scout's plan: common knowledge at the start, then updated by Takeover messages.
        # No route list is ever changed in place (a change makes a new list), so every scout
        # can share the lists it starts with: hundreds of scouts each copying every scout's
        # route were 130 MB at scale 100.
        self.routes = dict(routes)
        self._team_routes = routes  # mine is kept there too, for scouts that join later
        self.route: list[int] = routes.setdefault(self.name, [])
        self.cursor = 0
        self.known_tasks: set[str] = set()  # sites found, mine and my peers'
        self._given: dict[str, tuple[str, list[int], float]] = {}  # handoff id → (to, cells, t)
        self._received: list[str] = []
        self._handoffs = 0
        self._reported = 0  # scan progress in my last heartbeat

    # --- what a heartbeat and a Hello say ---------------------------------------------------
    def progress(self) -> int:
        return self.cursor

    def reported(self) -> int:
        """The progress a heartbeat now says (remembered: peers rank donors by it)."""
        self._reported = self.cursor
        return self.cursor

    def handoffs_received(self) -> tuple[str, ...]:
        return tuple(self._received)

    def remaining(self) -> int:
        """Cells still to scan beyond the one being driven to."""
        return max(0, len(self.route) - self.cursor - 1)

    def wants_work(self) -> bool:
        return self.remaining() == 0

    def on_task_heard(self, task_type: str, task_id: str) -> None:
        if task_type == "excavate":
            self.known_tasks.add(task_id)

    # --- taking over a silent scout's cells ----------------------------------------------
    def adopt_extra(self, peer: str) -> list[int]:
        hb = self.ctx.liveness.last_heartbeat(self.name, peer)
        done = hb.progress if hb is not None else 0
        cells = self.routes.get(peer, [])[done:]
        self._set_route(self.route + cells)
        self.robot.wake()
        return cells

    def _set_route(self, cells: list[int]) -> None:
        """My route is now `cells` (a new list: the old one may be shared)."""
        self.route = self._team_routes[self.name] = cells

    def on_takeover_heard(self, msg: Takeover) -> None:
        theirs = self.routes.get(msg.sender, [])
        known = set(theirs)
        # said again on a return
        self.routes[msg.sender] = theirs + [c for c in msg.cells if c not in known]

    def on_adoption_undone(self, failed: str) -> None:
        theirs = self.routes.get(failed, [])
        hb = self.ctx.liveness.last_heartbeat(self.name, failed)
        cells = set(theirs[hb.progress if hb is not None else 0 :])
        keep = self.route[: self.cursor] + [c for c in self.route[self.cursor :] if c not in cells]
        self._set_route(keep)

    def on_cells_taken(self, cells: tuple[int, ...]) -> None:
        """A peer scans these of my remaining cells now (it adopted them while I was down)."""
        taken = set(cells)
        route = self.route
        self._set_route(route[: self.cursor] + [c for c in route[self.cursor :] if c not in taken])

    # --- sharing the search with a scout that has none -------------------------------------
    def on_hello_heard(self, msg: Hello) -> None:
        if msg.rtype == "scout" and msg.wants_work and self.robot.participating:
            self._maybe_share(msg.sender)

    def _maybe_share(self, to: str) -> None:
        """The scout with the longest remaining route (as far as I know) gives the newcomer
        the far half of it; everyone else stays put (and a scout still settling its earlier
        duties does not give any away)."""
        mine = self.remaining()
        peers = self.robot.recovery
        if mine < 2 * SHARE_MIN or peers.rejoining:
            return
        # rank everyone, me included, by what the last heartbeats said: the same data for all
        # scouts, so they agree on the donor
        reported = len(self.route) - self._reported
        board = self.ctx.liveness
        down = self.robot.down
        for name in peers.peers_of_type("scout"):
            if name in (self.name, to) or name in down or not peers.peer_alive(name):
                continue
            hb = board.last_heartbeat(self.name, name)
            theirs = len(self.routes.get(name, [])) - (hb.progress if hb is not None else 0)
            if theirs > reported or (theirs == reported and name < self.name):
                return
        cells = self.route[-(mine // 2) :]
        self._set_route(self.route[: -(mine // 2)])
        self._handoffs += 1
        hid = self.ctx.observer.of_this_life(f"{self.name}>{to}#{self._handoffs}")
        self._given[hid] = (to, cells, float(self.env.now))
        self.routes[to] = self.routes.get(to, []) + cells
        self.ctx.observer.emit("handoff", by=self.name, to=to, cells=len(cells), handoff_id=hid)
        self.ctx.bus.publish(Handoff(sender=self.name, to=to, cells=tuple(cells), handoff_id=hid))

    def on_handoff_heard(self, msg: Handoff) -> None:
        if msg.to == self.name:
            if msg.handoff_id not in self._received:
                self._received.append(msg.handoff_id)
                self._set_route(self.route + list(msg.cells))
                self.robot.wake()
            return
        moved = set(msg.cells)
        donor = self.routes.get(msg.sender, [])
        self.routes[msg.sender] = [c for c in donor if c not in moved]
        self.routes[msg.to] = self.routes.get(msg.to, []) + list(msg.cells)

    def check_handoffs(self) -> None:
        """Cells given away and not confirmed by the receiver's heartbeat in time are scanned
        by me again (at worst twice, never not at all)."""
        board, proto = self.ctx.liveness, self.ctx.scenario.protocol
        down = self.robot.down
        for hid, (to, cells, t) in list(self._given.items()):
            hb = board.last_heartbeat(self.name, to)
            if hb is not None and hid in hb.received:
                del self._given[hid]  # confirmed: the cells are theirs
            elif to in down or self.env.now - t > 3 * proto.heartbeat_s:
                del self._given[hid]
                self._set_route(self.route + cells)
                self.ctx.observer.emit("handoff_taken_back", by=self.name, to=to, handoff_id=hid)
                self.robot.wake()
