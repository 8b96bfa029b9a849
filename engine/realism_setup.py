"""Switch a mission's realism options on (docs/model.md): each one present in the context only
if the scenario enables it."""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from engine.bus import EmbeddedBus
from engine.durations import Durations
from engine.energy import EnergyModel
from engine.plant import Plant
from engine.radio import RadioNet, RangedBus

if TYPE_CHECKING:
    from engine.context import MissionContext


def install_realism(ctx: MissionContext, work_rng: np.random.Generator) -> None:
    sc = ctx.scenario
    if sc.uncertainty.enabled:
        ctx.durations = Durations(sc.uncertainty, work_rng)
    if sc.docks.enabled:
        ctx.docks = Plant(ctx.env, sc.docks.count)
    if sc.energy.enabled:
        ctx.energy = EnergyModel(sc.energy, sc, ctx.world, ctx.env)


def make_bus(ctx: MissionContext, bus_rng: np.random.Generator) -> EmbeddedBus:
    """The broadcast bus, or with a limited radio range the bus that reaches only robots in
    reach of the sender."""
    sc = ctx.scenario
    args = (ctx.env, sc.bus, bus_rng, ctx.observer.record_message, ctx.liveness)
    if not sc.radio.enabled:
        return EmbeddedBus(*args)
    ctx.radio = RadioNet(sc.radio, ctx)
    return RangedBus(ctx.radio, *args)
