"""What an agent's robot sees of the world outside its own process: the field, through the
world service, and the robots beside it, through their agents.

`RemoteField` has the methods of `engine.terrain.Terrain` that robots call; each becomes a query
to the world service. (The robots beside it: `field.bodies`.)
"""

from __future__ import annotations

from typing import Any, Protocol

from engine.geometry import Point, dist
from engine.terrain import NEAR, GroundMineral


class Asker(Protocol):
    """The agent's query functions (field.agent.Agent)."""

    step: int
    name: str

    def ask_world(self, op: str, **args: Any) -> Any: ...

    def ask_body(self, name: str, op: str, **args: Any) -> Any: ...

    def new_id(self, what: str) -> str:
        """An id no other call of any agent, past or present, has used."""
        ...

    def stopping(self) -> bool: ...


class RemoteSite:
    """A site as a robot standing at it (or a scout that just saw it) knows it; the pile and
    who works it are read from and written to the world service."""

    def __init__(self, asker: Asker, d: dict[str, Any]) -> None:
        self._asker = asker
        self.id: str = d["id"]
        self.x: float = d["x"]
        self.y: float = d["y"]
        self.total: int = d["total"]
        self._seen: dict[str, Any] | None = None
        self._seen_step = -1

    def _get(self, key: str) -> Any:
        # read once per step of the agent (a policy pricing twenty auctions reads the pile
        # it stands at twenty times: twenty round trips to a busy world service made an
        # excavator fall minutes behind its messages, its heartbeats stopped)
        if self._seen is None or self._seen_step != self._asker.step:
            self._seen = self._asker.ask_world("site", id=self.id)
            self._seen_step = self._asker.step
        return None if self._seen is None else self._seen[key]

    def _set(self, key: str, value: Any) -> None:
        # `by`: a pile that shrinks went into the setter's bucket (the world's record of loads);
        # a dig carries a `once` id: asked again after a late reply, it is not a second dig
        once = {"once": self._asker.new_id("dig")} if key == "remaining" else {}
        self._seen = self._asker.ask_world(
            "site_set", id=self.id, by=self._asker.name, **{key: value}, **once
        )
        self._seen_step = self._asker.step

    remaining = property(lambda s: s._get("remaining") or 0, lambda s, v: s._set("remaining", v))
    # (None only when the agent is stopping: the world service is asked until it answers)
    worker = property(lambda s: s._get("worker"), lambda s, v: s._set("worker", v))
    last_worker = property(lambda s: s._get("last_worker"), lambda s, v: s._set("last_worker", v))
    found_at = property(lambda s: s._get("found_at"))


class RemoteField:
    """`engine.terrain.Terrain` as robots use it, served by the world service."""

    sites: tuple[RemoteSite, ...] = ()  # a robot never sees the list of all sites

    def __init__(self, asker: Asker) -> None:
        self._asker = asker
        self._at: dict[Point, RemoteSite | None] = {}  # sites never move: asked once per spot

    def _site(self, d: dict[str, Any] | None) -> RemoteSite | None:
        return None if d is None else RemoteSite(self._asker, d)

    def site_at(self, p: Point) -> RemoteSite | None:
        p = (float(p[0]), float(p[1]))
        if p not in self._at:
            if len(self._at) > 4096:
                self._at.clear()
            d = self._asker.ask_world("site_at", x=p[0], y=p[1])
            if d is None and self._asker.stopping():
                return None  # (not an answer: not kept)
            self._at[p] = self._site(d)
        return self._at[p]

    def sites_near(self, a: Point, b: Point, r: float) -> list[RemoteSite]:
        found = self._asker.ask_world("sites_near", ax=a[0], ay=a[1], bx=b[0], by=b[1], r=r)
        return [RemoteSite(self._asker, d) for d in found or ()]

    def note_site_found(self, site: RemoteSite, by: str) -> None:
        self._asker.ask_world("found", id=site.id, by=by)

    def mark_scanned(self, cell: int) -> None:
        self._asker.ask_world("scan", cell=cell, by=self._asker.name)

    @property
    def ground(self) -> list[GroundMineral]:
        found = self._asker.ask_world("ground") or ()
        return [GroundMineral(g["id"], g["x"], g["y"], g["dropped_at"]) for g in found]

    def ground_near(self, p: Point, radius: float = NEAR) -> GroundMineral | None:
        for g in self.ground:
            if dist((g.x, g.y), p) <= radius:
                return g
        return None

    def drop_mineral(self, p: Point, by: str) -> None:
        self._asker.ask_world("drop", x=p[0], y=p[1], by=by, once=self._asker.new_id("drop"))

    def pick_ground(self, g: GroundMineral, by: str) -> None:
        self._asker.ask_world("pick", id=g.id, by=by, once=self._asker.new_id("pick"))

    def note_delivery(self, by: str) -> None:
        self._asker.ask_world("deliver", by=by, once=self._asker.new_id("deliver"))
