"""The scenario's realism options (docs/model.md): energy, a plant with docks, uncertain work
and a limited radio range. Each is a section of the scenario, off by default; with all of them
off a run is the reference model's, bit for bit, and none of them costs anything.

Only the settings live here (validated, each field named in an error); the behaviour is in
`engine.energy`, `engine.plant`, `engine.durations` and `engine.radio`.
"""

from __future__ import annotations

from typing import Annotated, Literal

from pydantic import BaseModel, ConfigDict, Field

Coord = Annotated[float, Field(ge=-1e7, le=1e7, allow_inf_nan=False)]
Positive = Annotated[float, Field(gt=0, le=1e9, allow_inf_nan=False)]
NonNegative = Annotated[float, Field(ge=0, le=1e9, allow_inf_nan=False)]


class _Model(BaseModel):
    model_config = ConfigDict(extra="forbid", frozen=True)


class Battery(_Model):
    """One robot type's battery: capacity and consumption (kJ; kW = kJ per second)."""

    capacity_kj: Positive = 400.0
    drive_kj_per_m: NonNegative = 0.5
    work_kw: NonNegative = 1.0
    """Drawn per second of work: digging, a transfer, unloading, scanning (a scout scans as it
    drives, so it draws this on top of driving)."""


class Energy(_Model):
    """Batteries, consumption and charging (docs/model.md#energy)."""

    enabled: bool = False
    scout: Battery = Battery(capacity_kj=400.0, drive_kj_per_m=0.5, work_kw=0.1)
    excavator: Battery = Battery(capacity_kj=300.0, drive_kj_per_m=0.8, work_kw=2.0)
    hauler: Battery = Battery(capacity_kj=200.0, drive_kj_per_m=0.4, work_kw=1.0)
    charge_kw: Positive = 2.0
    """Charging rate at any charger, the same for every robot; a charger serves any number."""
    chargers: list[tuple[Coord, Coord]] = Field(default_factory=list, max_length=100)
    """Charging points besides the plant (which always is one)."""
    reserve: Annotated[float, Field(ge=0, lt=1, allow_inf_nan=False)] = 0.1
    """Fraction of the capacity a robot keeps in hand when it judges a task feasible: its
    estimates use straight lines (times a detour factor) and mean work durations."""
    detour: Annotated[float, Field(ge=1, le=10, allow_inf_nan=False)] = 1.3
    """Estimated driving distance = straight-line distance × detour (craters lengthen paths)."""


class Docks(_Model):
    """The plant unloads at most `count` haulers at once; the others queue, first come first
    served (docs/model.md#plant)."""

    enabled: bool = False
    count: Annotated[int, Field(ge=1, le=1000)] = 1


class Uncertainty(_Model):
    """Seeded variation of work durations and driving speed (docs/model.md#work-durations)."""

    enabled: bool = False
    distribution: Literal["lognormal", "gamma"] = "lognormal"
    work_cv: Annotated[float, Field(ge=0, le=3, allow_inf_nan=False)] = 0.3
    """Coefficient of variation of dig, transfer and unload times (mean: the scenario's
    timing); 0 keeps them fixed."""
    speed_cv: Annotated[float, Field(ge=0, le=1, allow_inf_nan=False)] = 0.0
    """Coefficient of variation of a robot's speed on each leg it drives (mean: its nominal
    speed); 0 keeps speeds constant."""


class Radio(_Model):
    """A radio of limited range, relayed by robots in between (docs/model.md#communication)."""

    enabled: bool = False
    range_m: Annotated[float, Field(gt=0, le=1e5, allow_inf_nan=False)] = 40.0
    """A robot hears a robot at most this far away (a symmetric link)."""
    hops: Annotated[int, Field(ge=1, le=16)] = 3
    """Most links a message crosses (1: direct only); robots and the base station relay."""
    base_range_m: Annotated[float, Field(ge=0, le=1e5, allow_inf_nan=False)] = 60.0
    """The plant's base station reaches robots this far away (0: no base station). The
    operator speaks through it."""
    silent_timeout_s: Annotated[float, Field(gt=0, le=1e6, allow_inf_nan=False)] = 600.0
    """How long a peer that fell silent out of radio reach (by its last known position) gets
    before it is taken for failed; one silent within reach gets the protocol's
    failure_timeout_s."""
