"""Switch a mission's realism options on (docs/model.md): each one present in the context only
if the scenario enables it."""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

import numpy as np

from engine.durations import Durations
from engine.energy import EnergyModel
from engine.plant import Plant

if TYPE_CHECKING:
    from engine.context import MissionContext


def install_realism(ctx: MissionContext, work_rng: np.random.Generator) -> None:
    sc = ctx.scenario
    if sc.uncertainty.enabled:
        ctx.durations = Durations(sc.uncertainty, work_rng)
    if sc.docks.enabled:
        ctx.docks = Plant(ctx.env, sc.docks.count)
    if sc.energy.enabled:
        ctx.energy = EnergyModel(sc.energy, sc, ctx.world.plant, ctx.env)


def realism_metrics(ctx: MissionContext) -> dict[str, Any]:
    """The figures of the options that are on (none for the reference model)."""
    out: dict[str, Any] = {}
    if ctx.docks is not None:
        out.update(ctx.docks.metrics())
    if ctx.durations is not None:
        out["work_draws"] = ctx.durations.draws
    if ctx.energy is not None:
        out.update(ctx.energy.metrics(list(ctx.robots.values())))
    return out
