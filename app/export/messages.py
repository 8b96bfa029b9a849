"""Pure conversions from Regolith's records to the exported messages (JSON-ready dicts).

Positions are metres in the frame `map` (x east, y north, z up, the plant on the ground);
a robot's heading becomes a rotation about z.
"""

from __future__ import annotations

import math
from typing import Any

JSON = dict[str, Any]
FRAME = "map"

_TYPE_COLOR = {
    "scout": (0.26, 0.55, 0.95),
    "excavator": (0.96, 0.58, 0.17),
    "hauler": (0.30, 0.75, 0.38),
}
_GREY = (0.55, 0.55, 0.55)
_WARN = {
    "robot_failed",
    "failure_detected",
    "robot_quiet",
    "auction_declined",
    "mineral_dropped",
    "unreachable",
    "handoff_taken_back",
    "robot_disabled",
}
_ERROR = {"mission_stalled"}
_DEBUG = {"message", "bid"}
_LEVEL = {"debug": 1, "info": 2, "warning": 3, "error": 4}


def stamp(t: float) -> JSON:
    """Simulated seconds as a Foxglove time (t = 0 is the mission's start)."""
    ns = to_ns(t)
    return {"sec": ns // 1_000_000_000, "nsec": ns % 1_000_000_000}


def to_ns(t: float) -> int:
    return max(0, round(t * 1e9))


def _vec(x: float = 0.0, y: float = 0.0, z: float = 0.0) -> JSON:
    return {"x": float(x), "y": float(y), "z": float(z)}


def _yaw(heading: float) -> JSON:
    return {"x": 0.0, "y": 0.0, "z": math.sin(heading / 2), "w": math.cos(heading / 2)}


def _pose(x: float, y: float, z: float = 0.0, heading: float = 0.0) -> JSON:
    return {"position": _vec(x, y, z), "orientation": _yaw(heading)}


def _color(rgb: tuple[float, float, float], a: float = 1.0) -> JSON:
    return {"r": rgb[0], "g": rgb[1], "b": rgb[2], "a": a}


def _text(x: float, y: float, z: float, text: str) -> JSON:
    return {
        "pose": _pose(x, y, z),
        "billboard": True,
        "font_size": 14.0,
        "scale_invariant": True,
        "color": _color((1.0, 1.0, 1.0)),
        "text": text,
    }


def _entity(t: float, eid: str, meta: dict[str, Any] | None = None, **prims: Any) -> JSON:
    out: JSON = {
        "timestamp": stamp(t),
        "frame_id": FRAME,
        "id": eid,
        "lifetime": {"sec": 0, "nsec": 0},
        "frame_locked": False,
        "metadata": [{"key": k, "value": str(v)} for k, v in (meta or {}).items()],
    }
    for name in ("arrows", "cubes", "spheres", "cylinders", "lines", "triangles", "texts"):
        out[name] = prims.get(name, [])
    out["models"] = []
    return out


def _cylinder(x: float, y: float, r: float, h: float, rgb: tuple[float, float, float]) -> JSON:
    return {
        "pose": _pose(x, y, h / 2),
        "size": _vec(2 * r, 2 * r, h),
        "bottom_scale": 1.0,
        "top_scale": 1.0,
        "color": _color(rgb),
    }


def map_scene(world: JSON) -> JSON:
    """The static map: the area's border, the plant and the craters (a SceneUpdate at t=0)."""
    w, h = float(world["width"]), float(world["height"])
    corners = [_vec(0, 0), _vec(w, 0), _vec(w, h), _vec(0, h)]
    border = {
        "type": 1,
        "pose": _pose(0, 0),
        "thickness": 0.3,
        "scale_invariant": False,
        "points": corners,
        "color": _color((0.8, 0.8, 0.8)),
        "colors": [],
        "indices": [],
    }
    px, py = float(world["plant"]["x"]), float(world["plant"]["y"])
    entities = [
        _entity(0.0, "area", {"width": w, "height": h}, lines=[border]),
        _entity(
            0.0,
            "plant",
            cylinders=[_cylinder(px, py, 2.0, 3.0, (0.85, 0.85, 0.95))],
            texts=[_text(px, py, 4.0, "plant")],
        ),
    ]
    for i, ob in enumerate(world.get("obstacles", [])):
        cyl = _cylinder(ob["x"], ob["y"], ob["r"], 0.5, (0.35, 0.3, 0.28))
        entities.append(_entity(0.0, f"crater-{i + 1}", {"r": ob["r"]}, cylinders=[cyl]))
    return {"deletions": [], "entities": entities}


def site_entity(t: float, site: JSON, found: bool, remaining: int) -> JSON:
    """A resource site: grey until found, then gold; its label counts what is left."""
    rgb = (0.95, 0.8, 0.2) if found else _GREY
    x, y = float(site["x"]), float(site["y"])
    sphere = {"pose": _pose(x, y, 0.5), "size": _vec(2, 2, 1), "color": _color(rgb, 0.9)}
    meta = {"found": found, "remaining": remaining, "minerals": site.get("minerals", 0)}
    label = f"{site['id']} · {remaining}" + ("" if found else " (unfound)")
    return _entity(t, site["id"], meta, spheres=[sphere], texts=[_text(x, y, 2.0, label)])


def robots_scene(t: float, robots: list[JSON]) -> JSON:
    """Every robot as a box coloured by type (grey once failed), labelled name and state."""
    entities = []
    for r in robots:
        rgb = _TYPE_COLOR.get(r["type"], _GREY) if r["alive"] else _GREY
        body = {
            "pose": _pose(r["x"], r["y"], 0.5, r["heading"]),
            "size": _vec(1.6, 1.0, 1.0),
            "color": _color(rgb),
        }
        meta = {"type": r["type"], "state": r["state"], "load": r["load"], "task": r.get("task")}
        label = _text(r["x"], r["y"], 1.8, f"{r['name']} · {r['state']}")
        entities.append(_entity(t, r["name"], meta, cubes=[body], texts=[label]))
    return {"deletions": [], "entities": entities}


def poses(t: float, robots: list[JSON]) -> JSON:
    """Every robot's pose, in the robot list's order (a PosesInFrame)."""
    return {
        "timestamp": stamp(t),
        "frame_id": FRAME,
        "poses": [_pose(r["x"], r["y"], 0.0, r["heading"]) for r in robots],
    }


def transforms(t: float, robots: list[JSON]) -> JSON:
    """A frame per robot under `map`, so a 3D panel can follow one (FrameTransforms)."""
    return {
        "transforms": [
            {
                "timestamp": stamp(t),
                "parent_frame_id": FRAME,
                "child_frame_id": r["name"],
                "translation": _vec(r["x"], r["y"]),
                "rotation": _yaw(r["heading"]),
            }
            for r in robots
        ]
    }


def robot_states(t: float, robots: list[JSON], counters: dict[str, int]) -> JSON:
    """The robots' states and the mission's counters, for the Plot and Raw Messages panels."""
    keys = ("name", "type", "state", "x", "y", "heading", "load", "alive", "distance")
    rows = [
        {k: r[k] for k in keys} | {"charge": r.get("charge"), "task": r.get("task")} for r in robots
    ]
    return {"timestamp": stamp(t), "t": t, "robots": rows, "counters": counters}


def event_message(seq: int, t: float, kind: str, data: JSON) -> JSON:
    return {"timestamp": stamp(t), "seq": seq, "t": t, "kind": kind, "data": data}


def action_message(seq: int, t: float, kind: str, args: JSON, replay: bool) -> JSON:
    return {"timestamp": stamp(t), "seq": seq, "t": t, "kind": kind, "args": args, "replay": replay}


def log_line(seq: int, t: float, kind: str, data: JSON) -> JSON:
    """One stored event as a Log panel line: who (robot, sender or the mission), what, details."""
    level = "error" if kind in _ERROR else "warning" if kind in _WARN else "info"
    if kind in _DEBUG:
        level = "debug"
    who = data.get("robot") or data.get("sender") or data.get("auctioneer") or "mission"
    if kind == "message":
        text = f"{data.get('type', 'message')} from {data.get('sender', '?')}"
    else:
        details = ", ".join(f"{k}={_short(v)}" for k, v in data.items() if _short(v) is not None)
        text = f"{kind}: {details}" if details else kind
    return {
        "timestamp": stamp(t),
        "level": _LEVEL[level],
        "message": text,
        "name": str(who),
        "file": "events",
        "line": seq,
    }


def _short(v: Any) -> str | None:
    """A field's value for a log line; lists and objects are left to the raw event topic."""
    if isinstance(v, float):
        return f"{v:.3f}".rstrip("0").rstrip(".")
    if isinstance(v, str | int | bool):
        return str(v)
    return None
