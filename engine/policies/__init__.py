"""How a robot treats several open auctions (docs/spec.md §8), behind one interface.

`base` holds the interface (`Policy`) and what a policy is given (`PolicyContext`: its own
seeded random stream, its parameters and, for a baseline only, the global view); `registry`
the one list of policies every client reads; `builtin` the policies Regolith ships. Every
other module of this package is a policy added later: imported here, in name order, it
registers itself (docs/policies.md, "Adding a policy"), so a new policy is one new file.
"""

from __future__ import annotations

import importlib
import pkgutil

from engine.bidding import OpenAuction
from engine.policies.base import (
    POLICY_STREAM,
    PendingAward,
    Policy,
    PolicyContext,
    coalition_partner,
    earliest,
    policy_rng,
)
from engine.policies.builtin import (
    AnticipatoryCoalitions,
    CentralGreedy,
    EarlyTransports,
    FirstComeFirstServed,
    Lookahead,
    NearestFirst,
    Offline,
    RelaxedCoalitions,
)
from engine.policies.registry import (
    ALIASES,
    POLICIES,
    POLICY_NAMES,
    PolicyMeta,
    check_policy,
    make_policy,
    policy_class,
    policy_help,
    policy_table,
    register_policy,
    register_variant,
    resolve_policy,
    unused_number,
)

__all__ = [
    "ALIASES",
    "POLICIES",
    "POLICY_NAMES",
    "POLICY_STREAM",
    "AnticipatoryCoalitions",
    "CentralGreedy",
    "EarlyTransports",
    "FirstComeFirstServed",
    "Lookahead",
    "NearestFirst",
    "Offline",
    "OpenAuction",
    "PendingAward",
    "Policy",
    "PolicyContext",
    "PolicyMeta",
    "RelaxedCoalitions",
    "check_policy",
    "coalition_partner",
    "earliest",
    "make_policy",
    "policy_class",
    "policy_help",
    "policy_rng",
    "policy_table",
    "register_policy",
    "register_variant",
    "resolve_policy",
    "unused_number",
]

_OWN = {"base", "builtin", "registry"}


def _discover() -> None:
    """Import every policy module of this package beyond its own three, in name order."""
    for mod in sorted(m.name for m in pkgutil.iter_modules(__path__)):
        if mod not in _OWN and not mod.startswith("_"):
            importlib.import_module(f"{__name__}.{mod}")


_discover()
