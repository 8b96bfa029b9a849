"""Stand-ins for the engine's `run_mission`, injected into the runner in tests only.

Module-level functions so a spawned worker process can import them by name.
"""

from __future__ import annotations

import math
import random
from typing import Any

from engine import reference_scenario
from experiments.spec import SweepSpec, make_spec, parse_policies, parse_seeds

POLICIES = {1: "fcfs", 2: "coalition", 3: "nearest"}


def resolve(text: str) -> str:
    """Like engine.resolve_policy: '3' or 'nearest' → 'nearest'."""
    t = text.strip().lower()
    if t.isdigit() and int(t) in POLICIES:
        return POLICIES[int(t)]
    if t in POLICIES.values():
        return t
    raise ValueError(f"unknown policy {text!r}")


def fake_run(scenario: Any, seed: int, policy: str) -> dict[str, Any]:
    """Deterministic metrics shaped like `regolith run --json`; 'nearest' is faster."""
    rng = random.Random(f"{seed}/{policy}")
    base = {"fcfs": 1000.0, "coalition": 980.0, "nearest": 900.0}[policy]
    makespan = base + rng.gauss(0, 40)
    return {
        "status": "completed",
        "policy": policy,
        "seed": seed,
        "makespan_s": makespan,
        "distance": {
            "scout": 2000 + rng.gauss(0, 30),
            "excavator": 800 + rng.gauss(0, 50),
            "hauler": 3000 + rng.gauss(0, 90),
        },
        "auction_open_s": {
            "scout_excavator": {"mean": 30 + rng.random() * 10, "max": 90.0, "n": 10},
            "excavator_hauler": {"mean": 5 + rng.random(), "max": 20.0, "n": 64},
        },
        "counts": {"auctions": 74, "bids": 500 + seed, "declines": 0, "messages": 4000},
        "sites_found_s": [1.0, 2.0] if seed % 2 else [],
        "undefined": math.nan,
        "wall_s": rng.random(),
    }


def failing_run(scenario: Any, seed: int, policy: str) -> dict[str, Any]:
    """Raises on seed 3: a crash in one run must not lose the others."""
    if seed == 3:
        raise RuntimeError("engine exploded")
    return fake_run(scenario, seed, policy)


def fake_spec(policies: str = "1,2,3", seeds: str = "0-5") -> SweepSpec:
    """A sweep spec over the fake policies on the reference scenario."""
    return make_spec(
        parse_policies(policies, resolve, POLICIES), parse_seeds(seeds), reference_scenario()
    )
