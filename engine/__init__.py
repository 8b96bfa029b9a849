"""Regolith's engine: the auction-based mining mission as pure, deterministic domain code.

See docs/engine-api.md. Nothing here imports the web or database layers.
"""

from engine.errors import CommandRejected, EngineError, UnknownRobotError
from engine.events import Event
from engine.interface import AuctionView, MissionInterface, MissionMode
from engine.mission import PLANNERS, Mission, run_mission
from engine.policies import (
    POLICIES,
    POLICY_NAMES,
    Policy,
    PolicyMeta,
    policy_help,
    policy_table,
    register_policy,
    resolve_policy,
)
from engine.scenario import (
    Scenario,
    ScenarioError,
    load_scenario,
    parse_scenario,
    reference_scenario,
)

__all__ = [
    "PLANNERS",
    "POLICIES",
    "POLICY_NAMES",
    "AuctionView",
    "CommandRejected",
    "EngineError",
    "Event",
    "Mission",
    "MissionInterface",
    "MissionMode",
    "Policy",
    "PolicyMeta",
    "Scenario",
    "ScenarioError",
    "UnknownRobotError",
    "load_scenario",
    "parse_scenario",
    "policy_help",
    "policy_table",
    "reference_scenario",
    "register_policy",
    "resolve_policy",
    "run_mission",
]
