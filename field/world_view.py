"""What mission control knows of a field mission whose world runs in a process of its own
(`field.world_process`): the fixed part of the world, derived here from the scenario and seed
as the world's process derives it, and what its last answer showed (terrain, clock, loads,
its agents). `field.world_handle` keeps it up to date; the live views read it as they read a
simulated mission's terrain."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np

from engine.scenario import Scenario
from engine.team import roster, start_positions
from engine.terrain import SiteState
from engine.world import generate_world
from field.clock import MissionClock


@dataclass
class AgentInfo:
    """An agent process as the world's process last said."""

    name: str
    gen: int
    pid: int
    alive: bool
    started_at: float
    killed_at: float | None = None
    exit: int | None = None

    @classmethod
    def of(cls, d: dict[str, Any]) -> AgentInfo:
        return cls(
            str(d["name"]),
            int(d["gen"]),
            int(d["pid"]),
            bool(d["alive"]),
            float(d["started_at"]),
            d.get("killed_at"),
            d.get("exit"),
        )


class _Finished:
    def __init__(self) -> None:
        self.triggered = False


@dataclass
class _Ground:
    x: float
    y: float


@dataclass
class TerrainView:
    """The world's terrain as last shown (what `engine.views` reads of a `Terrain`)."""

    sites: list[SiteState] = field(default_factory=list)
    ground: list[_Ground] = field(default_factory=list)
    sites_found: int = 0
    delivered: int = 0
    minerals_total: int = 0
    finished_at: float | None = None
    scanned_count: int = 0
    cells_total: int = 0
    finished: _Finished = field(default_factory=_Finished)
    _picture: dict[str, Any] = field(default_factory=dict)

    def show(self, view: dict[str, Any]) -> None:
        st, pic = view["status"], view["picture"]
        self._picture = pic
        self.sites = [
            SiteState(
                s["id"],
                s["x"],
                s["y"],
                s["total"],
                s["remaining"],
                found_at=s["found_at"],
                worker=s["excavator"],
            )
            for s in pic["sites"]
        ]
        self.ground = [_Ground(g["x"], g["y"]) for g in pic["dropped"]]
        self.sites_found, self.delivered = int(st["sites_found"]), int(st["delivered"])
        self.minerals_total, self.finished_at = int(st["minerals_total"]), st["finished_at"]
        self.scanned_count, self.cells_total = int(pic["scanned_count"]), int(pic["cells_total"])
        self.finished.triggered = bool(st["finished"])

    def picture(self) -> dict[str, Any]:
        return dict(self._picture)

    def scanned_b64(self) -> str:
        return str(self._picture.get("scanned", ""))


class WorldView:
    """The world as mission control knows it: what is fixed from the scenario and seed (the
    map, the roster, the start ring), and what the world's process last showed."""

    def __init__(self, scenario: Scenario, seed: int, policy: str) -> None:
        world_rng = np.random.default_rng(np.random.SeedSequence(seed).spawn(4)[0])
        self.scenario = scenario
        self.world = generate_world(scenario, world_rng)
        self.roster = roster(scenario.team)
        starts = start_positions(self.world, scenario.start_spread, len(self.roster))
        self.starts = dict(zip(self.roster, starts, strict=True))
        self.terrain = TerrainView()
        self.policy = policy
        self.clock = MissionClock()  # the world's, as its last answer carried it
        self.loads: dict[str, int] = {}
        self.refused = 0
        self.queries = 0
        self.late = 0  # queries the world skipped: their askers had stopped waiting
        self.dropped: dict[str, Any] = {}  # frames the world's process dropped, as it counts
        self.last: dict[str, Any] = {}
        self.shown: tuple[int, int] = (-1, -1)  # (world's life, view's number) last shown

    def show(self, view: dict[str, Any]) -> bool:
        """Show `view` unless one read later is shown already (two askers' answers can
        cross: the poller's, read before a pause, after the pause's own); True if shown."""
        stamp = (int(view.get("agents", {}).get("world_gen", 0)), int(view.get("seq", 0)))
        if stamp <= self.shown:
            return False
        self.shown = stamp
        self.terrain.show(view)
        self.policy = str(view["policy"])
        self.clock.adopt(view["clock"])
        self.loads = dict(view["loads"])
        self.refused = int(view["refusals"]["total"])
        self.queries = int(view["queries"])
        self.late = int(view.get("late") or 0)
        self.dropped = dict(view.get("dropped") or {})
        self.last = view
        return True

    def now(self) -> float:
        return self.clock.now()

    def status(self) -> dict[str, Any]:
        return dict(self.last.get("status") or {})

    def minerals_in(self) -> dict[str, int]:
        return dict(self.last.get("minerals_in") or {})

    def refusals(self) -> dict[str, Any]:
        """What the world refused its members, by reason and sender."""
        return dict(self.last.get("refusals") or {})
