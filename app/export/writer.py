"""Write a stored mission as MCAP, as a stream of byte blocks (an HTTP body or a file).

The `mcap` library writes to any object with `write` and `tell`; `_Spool` collects what it
writes and hands it on after each message, so at most one chunk (about 1 MiB before
compression) and one page of events are held at a time, however long the mission. Every
message's log time is its simulated time (t = 0 is the mission's start, so a viewer shows
the run from 1970-01-01 00:00:00), and messages are written in time order.
"""

from __future__ import annotations

import heapq
import json
from collections.abc import Generator, Iterable, Iterator
from typing import IO, Any, cast

from mcap.writer import Writer

from app.export import messages as msg
from app.export import source
from app.export.schemas import SCHEMAS
from app.export.source import StoredMission

CHUNK_BYTES = 1024 * 1024
Item = tuple[float, int, int, str, str, dict[str, Any]]  # t, order, n, topic, schema, message


class _Spool:
    """A write-only stream that keeps what was written until it is taken."""

    def __init__(self) -> None:
        self._parts: list[bytes] = []
        self._pos = 0

    def write(self, data: bytes) -> int:
        self._parts.append(bytes(data))
        self._pos += len(data)
        return len(data)

    def tell(self) -> int:
        return self._pos

    def flush(self) -> None:
        pass

    def take(self) -> bytes:
        out = b"".join(self._parts)
        self._parts.clear()
        return out


def _event_items(read: source.Reader, m: StoredMission) -> Iterator[Item]:
    """Each stored event on /log and /events/<kind>; sites also on /scene/sites as they are
    found and dug."""
    sites = {s["id"]: s for s in (m.world_map or {}).get("sites", [])}
    left = {sid: int(s.get("minerals", 0)) for sid, s in sites.items()}
    for seq, t, kind, data in source.events(read, m):
        yield t, source.EVENT, seq, "/log", "foxglove.Log", msg.log_line(seq, t, kind, data)
        event = msg.event_message(seq, t, kind, data)
        yield t, source.EVENT, seq, f"/events/{kind}", "regolith.Event", event
        sid = str(data.get("site"))
        if kind in ("site_found", "dug") and sid in sites:  # a site dug is a site found
            if kind == "dug" and isinstance(data.get("remaining"), int):
                left[sid] = data["remaining"]
            scene = {"deletions": [], "entities": [msg.site_entity(t, sites[sid], True, left[sid])]}
            yield t, source.EVENT, seq, "/scene/sites", "foxglove.SceneUpdate", scene


def _action_items(m: StoredMission) -> Iterator[Item]:
    for a in m.actions:
        body = msg.action_message(a["seq"], a["t"], a["kind"], a["args"], a["replay"])
        yield a["t"], source.ACTION, a["seq"], "/operator/actions", "regolith.OperatorAction", body


def _pose_items(m: StoredMission, gate: source.Gate, step: float) -> Iterator[Item]:
    for t, robots, counters in source.replay_robots(m, gate, step):
        yield t, source.POSE, 0, "/tf", "foxglove.FrameTransforms", msg.transforms(t, robots)
        yield t, source.POSE, 1, "/robots/poses", "foxglove.PosesInFrame", msg.poses(t, robots)
        yield (
            t,
            source.POSE,
            2,
            "/scene/robots",
            "foxglove.SceneUpdate",
            msg.robots_scene(t, robots),
        )
        body = msg.robot_states(t, robots, counters)
        yield t, source.POSE, 3, "/robots/state", "regolith.RobotStates", body


def _static_items(m: StoredMission) -> Iterator[Item]:
    world = m.world_map
    if world is None:
        return
    yield 0.0, source.ACTION, -2, "/scene/map", "foxglove.SceneUpdate", msg.map_scene(world)
    sites = [msg.site_entity(0.0, s, False, int(s.get("minerals", 0))) for s in world["sites"]]
    scene = {"deletions": [], "entities": sites}
    yield 0.0, source.ACTION, -1, "/scene/sites", "foxglove.SceneUpdate", scene


def items(
    read: source.Reader,
    m: StoredMission,
    gate: source.Gate,
    step: float = source.POSE_STEP_S,
) -> Iterator[Item]:
    """Every message of the export, merged into simulated-time order."""
    streams: list[Iterable[Item]] = [_static_items(m), _action_items(m), _event_items(read, m)]
    if m.mode == "simulated":
        streams.append(_pose_items(m, gate, step))
    return heapq.merge(*streams, key=lambda it: it[:3])


def mcap_blocks(
    read: source.Reader,
    m: StoredMission,
    gate: source.Gate,
    step: float = source.POSE_STEP_S,
) -> Generator[bytes, None, None]:
    """The MCAP file of mission `m`, as byte blocks to write or send in order."""
    spool = _Spool()
    writer = Writer(cast(IO[Any], spool), chunk_size=CHUNK_BYTES)
    writer.start(profile="", library="regolith")
    schema_ids: dict[str, int] = {}
    channels: dict[str, int] = {}
    writer.add_metadata("regolith.mission", _metadata(m, step))
    for t, _order, _n, topic, schema, body in items(read, m, gate, step):
        channel = channels.get(topic)
        if channel is None:
            if schema not in schema_ids:
                data = json.dumps(SCHEMAS[schema]).encode()
                schema_ids[schema] = writer.register_schema(schema, "jsonschema", data)
            channel = writer.register_channel(topic, "json", schema_ids[schema])
            channels[topic] = channel
        ns = msg.to_ns(t)
        data = json.dumps(body, separators=(",", ":")).encode()
        writer.add_message(channel, log_time=ns, data=data, publish_time=ns)
        block = spool.take()
        if block:
            yield block
    writer.finish()  # type: ignore[no-untyped-call]
    yield spool.take()


def _metadata(m: StoredMission, step: float) -> dict[str, str]:
    return {
        "mission": str(m.id),
        "mode": m.mode,
        "status": m.status,
        "scenario": m.scenario_name,
        "seed": str(m.seed),
        "policy": m.policy,
        "planner": m.planner,
        "sim_time_s": f"{m.sim_time:.3f}",
        "poses": f"replayed every {step:g} s of simulated time"
        if m.mode == "simulated"
        else "none",
    }
