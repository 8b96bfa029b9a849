"""Policy 4's rules switched off one at a time, and the central baseline without its lead.

Each variant is a registered policy with some of its parameters changed, registered through
the registry (`engine.policies.register_variant`) by name only (not a number: the numbered
registry, the API's enum and the menus stay as they are) in every process that runs one.
`run_variant` is the sweep's run function for them; docs/policies.md's ablation table is
rendered from such a sweep (`experiments.reproduce`, experiment `ablations`).
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

VARIANTS: dict[str, tuple[str, dict[str, Any], str]] = {
    "no-lead": ("lookahead", {"lead": False}, "without the lead (rules 4–5 only)"),
    "no-time-bids-no-queue": (
        "lookahead",
        {"time_bids": False, "queue": {}},
        "without time bids and queues (rules 1–3 and 5, distance bids)",
    ),
    "first-auction-only": (
        "lookahead",
        {"bid_all": False},
        "bidding only in the first-opened auction (Policy 1's rule)",
    ),
    "central-greedy-no-lead": (
        "central-greedy",
        {"lead": False},
        "centralized greedy assignment, transports when the bucket is full",
    ),
}
"""name → (the registered policy it changes, the parameters changed, what it is)."""


def register_variants() -> None:
    from engine.policies import register_variant

    for name, (base, params, _) in VARIANTS.items():
        register_variant(name, base, params)


def run_variant(scenario: Any, seed: int, policy: str) -> Mapping[str, Any]:
    """The sweep's run function: the engine's `run_mission`, with the variants registered."""
    from engine import run_mission

    register_variants()
    return run_mission(scenario, seed, policy)
