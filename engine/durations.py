"""Uncertain work (docs/model.md#work-durations): dig, transfer and unload times, and each
driving leg's speed, drawn from the run's own seeded stream.

A duration with mean m and coefficient of variation c is drawn from a lognormal
(σ² = ln(1 + c²), μ = ln m − σ²/2) or a gamma (shape 1/c², scale m·c²) distribution: both
positive, right-skewed (a dig that hits a rock takes much longer; none takes less than
nothing), with the scenario's value as their mean. Draws happen in the order the simulation
asks for them, so the same seed gives the same run.
"""

from __future__ import annotations

import math

import numpy as np

from engine.realism import Uncertainty


class Durations:
    def __init__(self, cfg: Uncertainty, rng: np.random.Generator) -> None:
        self._cfg = cfg
        self._rng = rng
        self.draws = 0

    def draw(self, mean: float, cv: float) -> float:
        """A value with this mean and coefficient of variation (the mean if either is 0)."""
        if mean <= 0.0 or cv <= 0.0:
            return mean
        self.draws += 1
        if self._cfg.distribution == "gamma":
            shape = 1.0 / (cv * cv)
            return float(self._rng.gamma(shape, mean / shape))
        sigma2 = math.log1p(cv * cv)
        return float(self._rng.lognormal(math.log(mean) - sigma2 / 2, math.sqrt(sigma2)))

    def work(self, mean: float) -> float:
        """A dig, transfer or unload time."""
        return self.draw(mean, self._cfg.work_cv)

    def leg_speed(self, nominal: float) -> float:
        """A robot's speed over one driving leg (at least a tenth of the nominal)."""
        return max(0.1 * nominal, self.draw(nominal, self._cfg.speed_cv))
