"""A compact mission for the field tests whose checks hold of any mission, not of the
reference's size: chaos, attacks, the dashboard's story. A field mission runs against the wall
clock at the pace the machine allows (tests/field/pace.py: 50x on this project's two-core
machines), so its length in mission time is CI time: the reference mission ends at ~2,100 s
(engine runs of seeds 0, 5, 11, 101, 202, 303 under three policies) and its field missions
took 51-53 s of wall time each.

The compact mission keeps what the protocol is exercised by: the reference team (2 scouts, 4
excavators, 6 haulers: twelve agent processes and the operator's), every role and hierarchy,
craters in the way. On a 70 m square with 8 sites of 40 minerals, its last site is found by
~700 s and it ends by ~1,150 s (those seeds under four policies: mean 1,151 s, 884-1,405 s);
as field missions at 50x, 27-32 s. Tests whose checks are sized to the reference (the restart
test's two 750 s server outages) keep the reference."""

from __future__ import annotations

from typing import Any

from engine.scenario import Scenario, parse_scenario

COMPACT: dict[str, Any] = {
    "name": "compact",
    "width": 70.0,
    "height": 70.0,
    "sites": 8,
    "minerals": 40,
    "random_craters": 4,
}
"""What the compact mission changes of the reference (a scenario's defaults): as it is, the
`scenario` of a request that starts one."""


def compact_scenario() -> Scenario:
    return parse_scenario(COMPACT)
