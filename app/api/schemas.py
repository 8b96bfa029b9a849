"""API schemas, named by role; kept apart from the storage models in `app/db/models.py`."""

from __future__ import annotations

from datetime import datetime
from typing import Annotated, Any, Literal

from pydantic import AfterValidator, BaseModel, BeforeValidator, ConfigDict, Field

from engine import POLICIES, POLICY_NAMES, Scenario, resolve_policy
from experiments.spec import MAX_SEED

# Request fields are strict: JSON `true` is not the number 1 (`"speed": true` ran at 1.0) and
# `"5"` is not 5. Points stay lists in JSON, so strictness goes on their numbers, not the tuple.
Finite = Annotated[float, Field(strict=True, allow_inf_nan=False, ge=-1e7, le=1e7)]
Seed = Annotated[int, Field(strict=True, ge=0, le=MAX_SEED)]
Point = tuple[Finite, Finite]
Name = Annotated[str, Field(min_length=1, max_length=80, pattern=r"^[A-Za-z0-9_.:/-]+$")]
RobotType = Literal["scout", "excavator", "hauler"]
TaskType = Literal["excavate", "transport"]
MissionStatus = Literal[
    "running", "paused", "completed", "timeout", "stalled", "stopped", "interrupted", "failed"
]
MissionMode = Literal["simulated", "field"]


def _policy(value: str | int) -> str:
    return resolve_policy(value)


def _policy_input(value: Any) -> Any:
    """A name or a whole number only: as a Literal, `false` equalled 0 (the central baseline)
    and `1.0` equalled 1; pydantic cannot make a Literal strict, so this check does."""
    if isinstance(value, bool) or not isinstance(value, (str, int)):
        raise ValueError("expected a policy name or number")
    return value


# The schema lists the policies registered when the app is imported: names or numbers.
_NAMES = Literal[tuple(sorted(POLICIES))]  # type: ignore[valid-type]
_NUMBERS = Literal[tuple(sorted(POLICY_NAMES))]  # type: ignore[valid-type]
PolicyName = Annotated[  # type: ignore[valid-type]
    _NAMES | _NUMBERS, BeforeValidator(_policy_input), AfterValidator(_policy)
]
PolicyFilter = _NAMES
#: the slowest a mission runs (simulated s per wall s): a reference mission then takes about
#: six hours; below it (1e-300 was accepted) a mission would never visibly move
MIN_SPEED = 0.1


def _speed(value: float) -> float:
    if 0 < value < MIN_SPEED:
        raise ValueError(f"must be 0 (pause), at least {MIN_SPEED:g}, or 'max'")
    return value


Speed = (
    Annotated[
        float,
        Field(strict=True, ge=0, le=10_000, allow_inf_nan=False),
        AfterValidator(_speed),
    ]
    | Literal["max"]
)


class _In(BaseModel):
    model_config = ConfigDict(extra="forbid")


class MissionCreate(_In):
    """A new live mission. `planner`: "ompl" (RRT-Connect, the study's), "exact" (shortest
    paths over the craters' tangent graph) or "straight" (obstacle-free tests only)."""

    model_config = ConfigDict(
        extra="forbid",
        json_schema_extra={
            "examples": [
                {"policy": "fcfs", "seed": 0, "speed": 10},
                {
                    "policy": "coalition",
                    "seed": 7,
                    "speed": "max",
                    "planner": "exact",
                    "scenario": {
                        "name": "small-field",
                        "width": 60.0,
                        "height": 60.0,
                        "plant": [30.0, 30.0],
                        "sites": 6,
                        "minerals": 24,
                        "team": {"scouts": 2, "excavators": 2, "haulers": 3},
                        "craters": [{"x": 12.0, "y": 45.0, "r": 4.0}],
                        "random_craters": 2,
                    },
                },
            ]
        },
    )

    policy: PolicyName = "fcfs"
    seed: Seed = 0
    speed: Speed = 1.0
    paused: Annotated[bool, Field(strict=True)] = False
    scenario: Scenario | None = None
    planner: Literal["ompl", "exact", "straight"] = "ompl"
    # field mode (docs/field.md): every robot its own process on this machine, over Zenoh;
    # `speed` is then fixed for the mission's life (a number >= 1, simulated s per wall s)
    field: Annotated[bool, Field(strict=True)] = False


class SpeedUpdate(_In):
    """0 pauses (the mission keeps its previous speed for resume); "max" runs flat out."""

    model_config = ConfigDict(
        extra="forbid",
        json_schema_extra={"examples": [{"speed": 20}, {"speed": "max"}, {"speed": 0}]},
    )

    speed: Speed


class PolicyUpdate(_In):
    model_config = ConfigDict(
        extra="forbid", json_schema_extra={"examples": [{"policy": "coalition"}, {"policy": 2}]}
    )

    policy: PolicyName


class RobotDisable(_In):
    """graceful: finishes nothing new and hands its work back; abrupt: stops where it is."""

    model_config = ConfigDict(
        extra="forbid", json_schema_extra={"examples": [{"mode": "graceful"}]}
    )

    mode: Literal["graceful", "abrupt"] = "graceful"


class RobotCreate(_In):
    """A robot joining the mission, at `position` (inside the area) or beside the plant."""

    model_config = ConfigDict(
        extra="forbid",
        json_schema_extra={"examples": [{"type": "hauler", "position": [50.0, 47.0]}]},
    )

    type: RobotType
    position: Point | None = None


class TaskCreate(_In):
    """An operator-initiated auction at `location`, with the operator as auctioneer."""

    model_config = ConfigDict(
        extra="forbid",
        json_schema_extra={"examples": [{"type": "excavate", "location": [60.0, 60.0]}]},
    )

    type: TaskType = "excavate"
    location: Point


class ScenarioFile(_In):
    """A scenario file's text as uploaded (`POST /api/scenarios/parse`)."""

    model_config = ConfigDict(
        extra="forbid",
        json_schema_extra={
            "examples": [
                {
                    "text": 'name = "small"\nwidth = 60.0\nheight = 60.0\nsites = 6\n',
                    "format": "toml",
                },
                {"text": '{"name": "small", "width": 60.0, "height": 60.0}', "format": "json"},
            ]
        },
    )

    text: str
    format: Literal["toml", "json"] = "toml"


class ActionRead(BaseModel):
    model_config = ConfigDict(from_attributes=True)

    seq: int
    t: float
    kind: str
    args: dict[str, Any]
    replay: bool
    created_at: datetime


class MissionRead(BaseModel):
    """A mission's identity and state; `policy` is the current one."""

    id: int
    status: MissionStatus
    policy: str
    initial_policy: str
    policies: list[str] = Field(
        description="every policy in effect during the run, in order (initial first)"
    )
    mixed_policy: bool = Field(
        description="the policy was switched live to another: its figures belong to no "
        "single policy"
    )
    seed: int
    speed: float | Literal["max"]
    planner: str
    mode: MissionMode = Field(
        description='"simulated" (the engine: replayable from scenario, seed, planner and '
        'actions) or "field" (real agent processes, docs/field.md: not reproducible, so '
        "never replayed, resumed after a restart or pooled with simulated runs)"
    )
    scenario_name: str
    scenario_hash: str = Field(
        description="content hash of the scenario (16 hex digits; equal parameters, equal "
        "hash, whatever the name); a sweep's runs.csv carries the same"
    )
    sim_time: float
    created_at: datetime
    started_at: datetime | None
    ended_at: datetime | None
    error: str | None = None


class MissionDetail(MissionRead):
    """A mission with its scenario, live or final metrics and operator actions."""

    scenario: dict[str, Any]
    metrics: dict[str, Any] | None
    actions: list[ActionRead]


class MissionPage(BaseModel):
    items: list[MissionRead]
    total: int
    limit: int
    offset: int


class RobotRead(BaseModel):
    """A robot as the engine reports it (extra engine fields pass through)."""

    model_config = ConfigDict(extra="allow")

    name: str
    type: str
    state: str
    x: float
    y: float
    load: int | None = None
    task: str | None = None
    alive: bool | None = None
    enabled: bool | None = None
    charge: float | None = Field(
        default=None, description="Battery charge, 0-1 (scenarios with energy on; docs/model.md)"
    )


class TaskCreated(BaseModel):
    auction_id: str
    type: str
    location: tuple[float, float]


class BidRead(BaseModel):
    """utility None stands for -inf (capable but busy)."""

    model_config = ConfigDict(from_attributes=True)

    t: float
    bidder: str
    utility: float | None
    round: int


class AwardRead(BaseModel):
    model_config = ConfigDict(from_attributes=True)

    t: float
    winner: str
    outcome: str


class AuctionRead(BaseModel):
    id: str
    kind: str
    auctioneer: str
    task_type: str
    task_id: str | None
    location: tuple[float, float]
    status: str
    opened_at: float
    closed_at: float | None
    allocated_to: str | None
    reannouncements: int
    reauction_of: str | None
    policy: str
    declines: int
    bids: list[BidRead]
    awards: list[AwardRead]


class AuctionPage(BaseModel):
    items: list[AuctionRead]
    total: int
    limit: int
    offset: int


class EventRead(BaseModel):
    model_config = ConfigDict(from_attributes=True)

    seq: int
    t: float
    kind: str
    data: dict[str, Any]


class MissionStateAt(BaseModel):
    """A mission as it was at simulated time `t`, rebuilt by replay (playback)."""

    t: float
    end: float = Field(description="the mission's simulated time now: the timeline's end")
    mission: MissionRead = Field(description="the mission as it is now (not at `t`)")
    state: dict[str, Any] = Field(description="`Mission.snapshot()` at `t`, as in `snapshot`")
    auctions: list[dict[str, Any]] = Field(
        description="`AuctionRead`s as they stood at `t`: the 200 latest opened, and older open"
    )
    deliveries: list[EventRead] = Field(description="every `delivered` event up to `t`")
    events: int = Field(description="events up to `t` (every event with seq < this)")


class EventPage(BaseModel):
    """Events after `after` in order; pass `next_after` back to get the next page."""

    items: list[EventRead]
    total: int
    limit: int
    next_after: int | None


class AuthRead(BaseModel):
    """What a valid token grants (`GET /api/auth/check`)."""

    role: Literal["operator"]


class ErrorRead(BaseModel):
    """Every refusal other than a validation error (422)."""

    detail: str


class Health(BaseModel):
    status: Literal["ok"]
    version: str
    missions_live: int
    viewers: int


class PolicyRead(BaseModel):
    """One registered policy (`engine.policy_table`): what clients show it as."""

    number: int = Field(description="accepted wherever a policy is, like the name")
    name: str
    label: str = Field(description="short human name for menus and charts")
    colour: str = Field(pattern=r"^#[0-9a-f]{6}$", description="its colour in every chart")
    description: str
    decentralized: bool = Field(description="false for the centralized oracle baseline")
