"""The scenario: every parameter of a mission, validated, with the reference values as defaults.

A scenario plus a seed fully determines a run. Quantities the research design leaves open
(speeds, dig/transfer/unload times, protocol timeouts) carry documented defaults here; see
docs/spec.md §2 for the reasoning behind each.
"""

from __future__ import annotations

import json
import math
import tomllib
from pathlib import Path
from typing import Annotated, Any, Literal

from pydantic import (
    BaseModel,
    ConfigDict,
    Field,
    SerializerFunctionWrapHandler,
    ValidationError,
    model_serializer,
    model_validator,
)

from engine.realism import Battery, Docks, Energy, Radio, Uncertainty

Coord = Annotated[float, Field(ge=-1e7, le=1e7, allow_inf_nan=False)]
"""A position: far beyond any area (5 km sides) but bounded, so bucket arithmetic stays exact."""

MIN_CRATER_R = 0.001
MAX_CRATER_R = 1000.0
CraterRadius = Annotated[float, Field(ge=MIN_CRATER_R, le=MAX_CRATER_R, allow_inf_nan=False)]
"""A random crater's radius bound: the world stores craters to the millimetre (a smaller
radius would round to a zero-radius crater, which `Crater` refuses mid-generation) and at
most as big as an explicit crater may be."""

MIN_PERIOD_S = 0.001
"""The shortest protocol or work duration: every repeating timer must move simulated time
forward (a 1e-300 s period added to t > 0 is t again, and the run never ends)."""
Period = Annotated[float, Field(ge=MIN_PERIOD_S, allow_inf_nan=False)]
MIN_HEARTBEAT_S = 1.0
"""Each heartbeat is a broadcast to every robot; faster ones make a run cost robots² × time /
heartbeat (0.1 s is already 60× the reference's wall time, 0.01 s does not finish)."""
MIN_SPEED = 0.001
"""1 mm/s: a path's length over a denormal speed overflows to an infinite travel time."""


MAX_SEARCH_CELLS = 4_000_000
"""More scan cells than this is not a mission the engine can hold (a 2 km side at 1 m)."""


class ScenarioError(ValueError):
    """A scenario that cannot be used; the message names the field and the reason."""


class _Model(BaseModel):
    model_config = ConfigDict(extra="forbid", frozen=True)


class Crater(_Model):
    """A circular obstacle robots must plan around."""

    x: Coord
    y: Coord
    r: Annotated[float, Field(gt=0, le=MAX_CRATER_R, allow_inf_nan=False)]


class Team(_Model):
    """How many robots of each type start the mission."""

    scouts: Annotated[int, Field(ge=1, le=2000)] = 2
    excavators: Annotated[int, Field(ge=1, le=2000)] = 4
    haulers: Annotated[int, Field(ge=1, le=2000)] = 6


class Speeds(_Model):
    """Driving speeds in metres per simulated second (a few km/h, like planetary rovers)."""

    scout: Annotated[float, Field(ge=MIN_SPEED, le=100, allow_inf_nan=False)] = 1.0
    excavator: Annotated[float, Field(ge=MIN_SPEED, le=100, allow_inf_nan=False)] = 0.5
    hauler: Annotated[float, Field(ge=MIN_SPEED, le=100, allow_inf_nan=False)] = 0.8


class Timing(_Model):
    """Durations of physical work, in simulated seconds."""

    dig_s: Annotated[Period, Field(le=3600)] = 20.0
    transfer_s: Annotated[float, Field(ge=0, le=3600, allow_inf_nan=False)] = 5.0
    unload_s: Annotated[float, Field(ge=0, le=3600, allow_inf_nan=False)] = 5.0


class Protocol(_Model):
    """Auction and liveness timing (simulated seconds)."""

    bid_window_s: Annotated[Period, Field(le=600)] = 1.0
    ack_timeout_s: Annotated[Period, Field(le=600)] = 2.0
    retry_s: Annotated[Period, Field(le=3600)] = 5.0
    award_collect_s: Annotated[float, Field(ge=0, le=600, allow_inf_nan=False)] = 0.2
    heartbeat_s: Annotated[float, Field(ge=MIN_HEARTBEAT_S, le=3600, allow_inf_nan=False)] = 10.0
    failure_timeout_s: Annotated[float, Field(gt=0, le=36000, allow_inf_nan=False)] = 30.0
    probes: Annotated[int, Field(ge=0, le=20)] = 5
    busy_bid: Literal["once", "every_round", "silent"] = "once"

    @model_validator(mode="after")
    def _consistent(self) -> Protocol:
        if self.award_collect_s >= self.ack_timeout_s:
            raise ValueError("award_collect_s must be shorter than ack_timeout_s")
        if self.failure_timeout_s <= 2 * self.heartbeat_s:
            raise ValueError("failure_timeout_s must exceed two heartbeat periods")
        return self


class BusConfig(_Model):
    """The embedded bus's fault model: seeded loss and latency."""

    loss: Annotated[float, Field(ge=0, le=0.9, allow_inf_nan=False)] = 0.0
    latency_s: Annotated[float, Field(ge=0, le=60, allow_inf_nan=False)] = 0.0
    jitter_s: Annotated[float, Field(ge=0, le=60, allow_inf_nan=False)] = 0.0


class Scenario(_Model):
    """A whole mission's world and parameters; the defaults are the reference scenario
    (docs/spec.md §2)."""

    name: Annotated[str, Field(min_length=1, max_length=80)] = "reference"
    width: Annotated[float, Field(gt=0, le=5000, allow_inf_nan=False)] = 100.0
    height: Annotated[float, Field(gt=0, le=5000, allow_inf_nan=False)] = 100.0
    plant: tuple[Coord, Coord] | None = None
    sites: Annotated[int, Field(ge=1, le=5000)] = 10
    minerals: Annotated[int, Field(ge=1, le=100000)] = 64
    team: Team = Team()
    scan_radius: Annotated[float, Field(gt=0, le=100, allow_inf_nan=False)] = 2.5
    craters: list[Crater] = Field(default_factory=list, max_length=2000)
    random_craters: Annotated[int, Field(ge=0, le=2000)] = 6
    crater_radius: tuple[CraterRadius, CraterRadius] = (2.0, 5.0)
    speeds: Speeds = Speeds()
    timing: Timing = Timing()
    protocol: Protocol = Protocol()
    bus: BusConfig = BusConfig()
    max_time_s: Annotated[Period, Field(le=1e7)] = 200_000.0
    # a mission with no progress (scan, find, dig, pickup, delivery, allocation, operator
    # action) for this long cannot finish as it stands: it ends `stalled`, saying what is stuck
    stall_timeout_s: Annotated[Period, Field(le=1e7)] = 3600.0
    start_spread: Annotated[float, Field(ge=0, le=100, allow_inf_nan=False)] = 3.0
    # the realism options (engine/realism.py, docs/model.md), each off by default
    energy: Energy = Energy()
    docks: Docks = Docks()
    uncertainty: Uncertainty = Uncertainty()
    radio: Radio = Radio()

    @model_serializer(mode="wrap")
    def _omit_options_left_alone(self, handler: SerializerFunctionWrapHandler) -> dict[str, Any]:
        """A realism section at its defaults (off) is left out of the dump, so a scenario
        that does not use the options keeps the content hash (and stored form) it had before
        they existed."""
        data: dict[str, Any] = handler(self)
        for key, default in _OPTION_DEFAULTS.items():
            if getattr(self, key) == default:
                data.pop(key, None)
        return data

    @property
    def realism_on(self) -> list[str]:
        """The realism options this scenario turns on."""
        return [o for o in REALISM_OPTIONS if getattr(self, o).enabled]

    @property
    def plant_xy(self) -> tuple[float, float]:
        """The processing plant: the given point, or the centre of the area."""
        return self.plant if self.plant is not None else (self.width / 2, self.height / 2)

    @model_validator(mode="after")
    def _feasible(self) -> Scenario:
        px, py = self.plant_xy
        if not (0 <= px <= self.width and 0 <= py <= self.height):
            raise ValueError("plant must lie inside the area")
        if self.minerals < self.sites:
            raise ValueError("minerals must be at least sites (every site holds one or more)")
        lo, hi = self.crater_radius
        if lo > hi:
            raise ValueError("crater_radius must be (min, max) with min <= max")
        for i, c in enumerate(self.craters):
            if math.hypot(c.x - px, c.y - py) <= c.r + self.start_spread + 1.0:
                raise ValueError(f"craters[{i}] covers the plant or the start area")
        free = self.width * self.height - sum(math.pi * c.r**2 for c in self.craters)
        if free < 0.25 * self.width * self.height:
            raise ValueError("craters cover too much of the area for sites to fit")
        cell = self.scan_radius * math.sqrt(2)
        cells = (self.width / cell) * (self.height / cell)
        if cells > MAX_SEARCH_CELLS:
            raise ValueError(
                f"scan_radius: {self.scan_radius:g} is too small for a {self.width:g}×"
                f"{self.height:g} area ({cells:.3g} search cells; at most {MAX_SEARCH_CELLS:g})"
            )
        if self.sites > 0.5 * cells:
            raise ValueError("sites: more sites than fit apart on the search grid")
        self._realism_feasible()
        return self

    def _realism_feasible(self) -> None:
        px, py = self.plant_xy
        if self.energy.enabled:
            for i, (x, y) in enumerate(self.energy.chargers):
                if not (0 <= x <= self.width and 0 <= y <= self.height):
                    raise ValueError(f"energy.chargers[{i}] must lie inside the area")
            far = max(math.hypot(x - px, y - py) for x in (0, self.width) for y in (0, self.height))
            for rtype in ROBOT_TYPES:
                need = one_task_kj(self, rtype, far)
                cap = getattr(self.energy, rtype).capacity_kj
                if need > cap * (1 - self.energy.reserve):
                    raise ValueError(
                        f"energy.{rtype}.capacity_kj: {cap:g} kJ cannot take {rtype}s from the "
                        f"plant to a task at the area's far corner and back ({need:.4g} kJ "
                        f"beside the reserve)"
                    )
        if self.radio.enabled and self.radio.silent_timeout_s <= self.protocol.failure_timeout_s:
            raise ValueError("radio.silent_timeout_s must exceed protocol.failure_timeout_s")

    def scaled(self, k: int) -> Scenario:
        """K times the team, sites, minerals and craters on an area √K wider (same density)."""
        if k < 1:
            raise ScenarioError("scale: must be a whole number >= 1")
        if k == 1:
            return self
        s = math.sqrt(k)
        px, py = self.plant_xy
        data = self.model_dump()
        data.update(
            width=self.width * s,
            height=self.height * s,
            plant=(px * s, py * s),
            sites=self.sites * k,
            minerals=self.minerals * k,
            team={
                "scouts": self.team.scouts * k,
                "excavators": self.team.excavators * k,
                "haulers": self.team.haulers * k,
            },
            craters=[{"x": c.x * s, "y": c.y * s, "r": c.r} for c in self.craters],
            random_craters=self.random_craters * k,
            # "reference-x10": readable, and safe in a file name or a shell word; the base is
            # cut to keep the name within its 80 characters
            name=f"{self.name[: 80 - len(f'-x{k}')]}-x{k}",
        )
        if self.energy.chargers:
            data["energy"]["chargers"] = [(x * s, y * s) for x, y in self.energy.chargers]
        try:
            return Scenario.model_validate(data)  # a scaled scenario must pass every check too
        except ValidationError as exc:
            raise ScenarioError(f"scale {k}: {_error_text(exc)}") from None


_OPTION_DEFAULTS: dict[str, Any] = {
    "energy": Energy(),
    "docks": Docks(),
    "uncertainty": Uncertainty(),
    "radio": Radio(),
}
REALISM_OPTIONS = tuple(_OPTION_DEFAULTS)
"""The realism options, in the order they are named (engine/realism.py)."""


def reference_scenario() -> Scenario:
    """The reference scenario (docs/spec.md §2)."""
    return Scenario()


def _error_text(exc: ValidationError) -> str:
    parts = []
    for err in exc.errors():
        field = ".".join(str(p) for p in err["loc"]) or "scenario"
        parts.append(f"{field}: {err['msg']}")
    return "; ".join(parts)


def parse_scenario(data: dict[str, Any]) -> Scenario:
    """Validate a scenario mapping, raising ScenarioError that names the field."""
    try:
        return Scenario.model_validate(data)
    except ValidationError as exc:
        raise ScenarioError(_error_text(exc)) from None


def load_scenario(path: str | Path) -> Scenario:
    """Load a scenario from a .toml or .json file."""
    p = Path(path)
    try:
        raw = p.read_bytes()
    except OSError as exc:
        raise ScenarioError(f"scenario file {p}: {exc.strerror or exc}") from None
    try:
        if p.suffix.lower() == ".toml":
            data = tomllib.loads(raw.decode("utf-8"))
        elif p.suffix.lower() == ".json":
            data = json.loads(raw)
        else:
            raise ScenarioError(f"scenario file {p}: must end in .toml or .json")
    except (tomllib.TOMLDecodeError, json.JSONDecodeError, UnicodeDecodeError) as exc:
        raise ScenarioError(f"scenario file {p}: not valid {p.suffix[1:].upper()}: {exc}") from None
    if not isinstance(data, dict):
        raise ScenarioError(f"scenario file {p}: must hold a table/object at the top level")
    try:
        return parse_scenario(data)
    except ScenarioError as exc:  # a bad value: say which file holds it, as for bad syntax
        raise ScenarioError(f"scenario file {p}: {exc}") from None


RobotType = Literal["scout", "excavator", "hauler"]
ROBOT_TYPES: tuple[RobotType, ...] = ("scout", "excavator", "hauler")


def one_task_kj(s: Scenario, rtype: str, far: float) -> float:
    """The most one task can cost a robot of this type, as it estimates it: from the plant to
    a point `far` away, the task's work, and back (scouts: a scan leg there and back)."""
    e = s.energy
    b: Battery = getattr(e, rtype)
    margin = 1.0 + 2.0 * s.uncertainty.work_cv if s.uncertainty.enabled else 1.0
    drive = 2 * far * e.detour * b.drive_kj_per_m
    t = s.timing
    if rtype == "scout":
        speed: float = getattr(s.speeds, rtype)
        return drive + far * e.detour * b.work_kw / speed
    work_s = t.transfer_s + t.unload_s if rtype == "hauler" else t.dig_s + t.transfer_s
    return drive + b.work_kw * work_s * margin
