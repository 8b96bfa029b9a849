"""The wire format and the key space of field mode (docs/field.md).

Every protocol message travels as one JSON object, an `Envelope`:

    {"v": 1, "type": "<message type>", "mission": "<id>", "sender": "<robot>",
     "seq": <int>, "body": {...the engine message's fields...}}

under the key `regolith/<mission>/msg/<type>/<sender>`. `decode` validates the envelope and
then the body against the engine's own message model (`engine.messages`); anything else (not
JSON, another version, an unknown type, a missing or extra field, a body whose sender is not
the envelope's) is dropped: a robot never crashes on what it hears. (Said at debug level:
the callers count each drop and log it once per sender per interval, `field.trust`.)
"""

from __future__ import annotations

import json
import logging
import math
import re
from typing import Annotated, Any, Literal

from pydantic import BaseModel, ConfigDict, Field, ValidationError

from engine.messages import ALL_MESSAGES, Bid, Message, validate

log = logging.getLogger("regolith.field.wire")

VERSION = 1
"""The wire format's version; a receiver drops envelopes of any other version."""

PREFIX = "regolith"
MESSAGE_TYPES: dict[str, type[Message]] = {cls.__name__.lower(): cls for cls in ALL_MESSAGES}
"""Every protocol message the engine's robots exchange, by its wire name."""

_SEGMENT = re.compile(r"^[A-Za-z0-9_.\-]{1,64}$")
Segment = Annotated[str, Field(pattern=_SEGMENT.pattern)]


class Envelope(BaseModel):
    """One protocol message on the wire."""

    model_config = ConfigDict(extra="forbid", frozen=True)
    v: Literal[1]  # VERSION
    type: str
    mission: Segment
    sender: Segment
    seq: Annotated[int, Field(ge=0)]
    body: dict[str, Any]


class InjectTask(BaseModel):
    """An operator task (`POST /missions/{id}/tasks` on a field mission), sent by mission
    control as a query to the operator console's agent (`operator_key`), which auctions it
    like any robot's task and replies with the auction's id. Mission control has checked the
    place (inside the area, not in a crater) and snapped an excavation to a known site."""

    model_config = ConfigDict(extra="forbid", frozen=True)
    v: Literal[1]  # VERSION
    cmd: Literal["inject_task"]
    task_type: Literal["excavate", "transport"]
    x: Annotated[float, Field(allow_inf_nan=False)]
    y: Annotated[float, Field(allow_inf_nan=False)]
    task_id: Annotated[str, Field(min_length=1, max_length=128)]


def decode_inject(data: dict[str, Any]) -> InjectTask | None:
    """An operator task, or None (logged) if the request is not a valid one."""
    try:
        return InjectTask.model_validate(data)
    except (ValueError, ValidationError) as exc:
        log.debug("dropped a malformed operator task: %s", _short(exc))
        return None


def check_segment(value: str, what: str) -> str:
    """A mission id or robot name must be one key segment (no '/', '*', '$', spaces)."""
    if not _SEGMENT.match(value):
        raise ValueError(f"{what}: {value!r} must be 1-64 letters, digits, '_', '.' or '-'")
    return value


def message_key(mission: str, msg_type: str, sender: str) -> str:
    return f"{PREFIX}/{mission}/msg/{msg_type}/{sender}"


def messages_selector(mission: str) -> str:
    """Every protocol message of a mission."""
    return f"{PREFIX}/{mission}/msg/**"


def event_key(mission: str, sender: str) -> str:
    """What a robot or the world service reports to mission control (not read by robots)."""
    return f"{PREFIX}/{mission}/event/{sender}"


def world_key(mission: str) -> str:
    """The world service's queryable: ground truth, one operation per query."""
    return f"{PREFIX}/{mission}/world"


def body_key(mission: str, name: str) -> str:
    """A robot's physical body: what a robot standing beside it can see and do with it."""
    return f"{PREFIX}/{mission}/body/{name}"


def journal_key(mission: str, name: str) -> str:
    """Where mission control reads back what `name` reported (`field.journal`)."""
    return f"{PREFIX}/{mission}/journal/{name}"


def supervisor_key(mission: str) -> str:
    """Where mission control asks the world service's process to start, stop and list its
    agents (`field.world_process`)."""
    return f"{PREFIX}/{mission}/supervisor"


def operator_key(mission: str) -> str:
    """The operator console's queryable: operator tasks to auction (`InjectTask`)."""
    return f"{PREFIX}/{mission}/operator"


def presence_key(mission: str) -> str:
    """Mission control's liveliness token: present while its Zenoh session lives. Agents
    leave when it goes (mission control ended or died), not when it is merely slow."""
    return f"{PREFIX}/{mission}/presence/control"


def command_key(mission: str) -> str:
    """Operator commands from mission control to the agents."""
    return f"{PREFIX}/{mission}/command"


def encode(mission: str, msg: Message, seq: int) -> tuple[str, bytes]:
    """The key and the payload of one protocol message."""
    body = msg.to_dict()
    msg_type = body.pop("type")
    env = Envelope(v=1, type=msg_type, mission=mission, sender=msg.sender, seq=seq, body=body)
    return message_key(mission, msg_type, msg.sender), env.model_dump_json().encode()


def decode(payload: bytes, mission: str | None = None) -> Message | None:
    """The engine message a payload carries, or None (logged) if it is not a valid one."""
    try:
        raw = json.loads(payload, parse_constant=_no_constant)
        env = Envelope.model_validate(raw)
    except (ValueError, TypeError, ValidationError, RecursionError) as exc:
        log.debug("dropped a malformed message: %s", _short(exc))
        return None
    if mission is not None and env.mission != mission:
        log.debug("dropped a message of mission %r (this is %r)", env.mission, mission)
        return None
    cls = MESSAGE_TYPES.get(env.type)
    if cls is None:
        log.debug("dropped a message of unknown type %r from %s", env.type, env.sender)
        return None
    body = dict(env.body)
    if cls is Bid and body.get("utility", 0.0) is None:
        body["utility"] = -math.inf  # JSON has no infinity: 'busy' travels as null
    try:
        msg = validate(cls, body)
    except ValidationError as exc:
        log.debug("dropped an invalid %s from %s: %s", env.type, env.sender, _short(exc))
        return None
    if msg.sender != env.sender:
        log.debug("dropped a %s whose sender %r is not the envelope's", env.type, msg.sender)
        return None
    return msg


def encode_json(data: dict[str, Any]) -> bytes:
    """Queries, replies, events and commands: one versioned JSON object each."""
    return json.dumps({"v": VERSION, **data}, separators=(",", ":")).encode()


def decode_json(payload: bytes) -> dict[str, Any] | None:
    """A query, reply, event or command, or None (logged) if malformed or of another version."""
    try:
        data = json.loads(payload, parse_constant=_no_constant)
    except (ValueError, TypeError, RecursionError) as exc:
        log.debug("dropped a malformed payload: %s", _short(exc))
        return None
    if not isinstance(data, dict) or data.get("v") != VERSION:
        log.debug("dropped a payload that is not a version-%d object", VERSION)
        return None
    return data


def _no_constant(name: str) -> Any:
    """JSON has no NaN or infinity; Python's parser would take them, and a stored record
    holding one is not JSON any more."""
    raise ValueError(f"{name} is not a JSON number")


def _short(exc: BaseException) -> str:
    return str(exc).splitlines()[0][:200] if str(exc) else type(exc).__name__
