"""The JSON schemas of the exported channels (MCAP schema encoding `jsonschema`).

The `foxglove.*` ones are written here from Foxglove's published message reference, keeping
its names and field names (a viewer recognises a schema by its name, then reads the fields):
only the fields this export fills are constrained, the rest are listed so that a validator
accepts exactly what Foxglove's own readers expect. The `regolith.*` ones describe Regolith's
own records (the stored event, the operator action, the robots' states).
"""

from __future__ import annotations

from typing import Any

JSON = dict[str, Any]


def _obj(props: JSON, required: list[str] | None = None, title: str = "") -> JSON:
    out: JSON = {"type": "object", "properties": props}
    out["required"] = list(props) if required is None else required
    if title:
        out["title"] = title
    return out


def _num() -> JSON:
    return {"type": "number"}


def _str() -> JSON:
    return {"type": "string"}


def _arr(items: JSON) -> JSON:
    return {"type": "array", "items": items}


TIME = _obj(
    {"sec": {"type": "integer", "minimum": 0}, "nsec": {"type": "integer", "minimum": 0}},
    title="time",
)
DURATION = _obj({"sec": {"type": "integer"}, "nsec": {"type": "integer", "minimum": 0}})
VECTOR3 = _obj({"x": _num(), "y": _num(), "z": _num()}, title="foxglove.Vector3")
QUATERNION = _obj({"x": _num(), "y": _num(), "z": _num(), "w": _num()}, title="foxglove.Quaternion")
POSE = _obj({"position": VECTOR3, "orientation": QUATERNION}, title="foxglove.Pose")
COLOR = _obj(
    {k: {"type": "number", "minimum": 0, "maximum": 1} for k in "rgba"}, title="foxglove.Color"
)
KEY_VALUE = _obj({"key": _str(), "value": _str()}, title="foxglove.KeyValuePair")

_SPHERE = _obj({"pose": POSE, "size": VECTOR3, "color": COLOR}, title="foxglove.SpherePrimitive")
_CUBE = _obj({"pose": POSE, "size": VECTOR3, "color": COLOR}, title="foxglove.CubePrimitive")
_CYLINDER = _obj(
    {"pose": POSE, "size": VECTOR3, "bottom_scale": _num(), "top_scale": _num(), "color": COLOR},
    title="foxglove.CylinderPrimitive",
)
_TEXT = _obj(
    {
        "pose": POSE,
        "billboard": {"type": "boolean"},
        "font_size": _num(),
        "scale_invariant": {"type": "boolean"},
        "color": COLOR,
        "text": _str(),
    },
    title="foxglove.TextPrimitive",
)
_LINE = _obj(
    {
        "type": {"enum": [0, 1, 2]},  # LINE_STRIP, LINE_LOOP, LINE_LIST
        "pose": POSE,
        "thickness": _num(),
        "scale_invariant": {"type": "boolean"},
        "points": _arr(_obj({"x": _num(), "y": _num(), "z": _num()}, title="foxglove.Point3")),
        "color": COLOR,
        "colors": _arr(COLOR),
        "indices": _arr({"type": "integer", "minimum": 0}),
    },
    title="foxglove.LinePrimitive",
)
_ENTITY = _obj(
    {
        "timestamp": TIME,
        "frame_id": _str(),
        "id": _str(),
        "lifetime": DURATION,
        "frame_locked": {"type": "boolean"},
        "metadata": _arr(KEY_VALUE),
        "arrows": _arr({"type": "object"}),
        "cubes": _arr(_CUBE),
        "spheres": _arr(_SPHERE),
        "cylinders": _arr(_CYLINDER),
        "lines": _arr(_LINE),
        "triangles": _arr({"type": "object"}),
        "texts": _arr(_TEXT),
        "models": _arr({"type": "object"}),
    },
    title="foxglove.SceneEntity",
)
SCENE_UPDATE = _obj(
    {
        "deletions": _arr(
            _obj({"timestamp": TIME, "type": {"enum": [0, 1]}, "id": _str()}),
        ),
        "entities": _arr(_ENTITY),
    },
    title="foxglove.SceneUpdate",
)
POSES_IN_FRAME = _obj(
    {"timestamp": TIME, "frame_id": _str(), "poses": _arr(POSE)}, title="foxglove.PosesInFrame"
)
FRAME_TRANSFORMS = _obj(
    {
        "transforms": _arr(
            _obj(
                {
                    "timestamp": TIME,
                    "parent_frame_id": _str(),
                    "child_frame_id": _str(),
                    "translation": VECTOR3,
                    "rotation": QUATERNION,
                },
                title="foxglove.FrameTransform",
            )
        )
    },
    title="foxglove.FrameTransforms",
)
LOG = _obj(
    {
        "timestamp": TIME,
        "level": {"enum": [0, 1, 2, 3, 4, 5]},  # UNKNOWN, DEBUG, INFO, WARNING, ERROR, FATAL
        "message": _str(),
        "name": _str(),
        "file": _str(),
        "line": {"type": "integer", "minimum": 0},
    },
    title="foxglove.Log",
)

EVENT = _obj(
    {
        "timestamp": TIME,
        "seq": {"type": "integer", "minimum": 0},
        "t": _num(),
        "kind": _str(),
        "data": {"type": "object"},
    },
    title="regolith.Event",
)
ACTION = _obj(
    {
        "timestamp": TIME,
        "seq": {"type": "integer", "minimum": 0},
        "t": _num(),
        "kind": _str(),
        "args": {"type": "object"},
        "replay": {"type": "boolean"},
    },
    title="regolith.OperatorAction",
)
_ROBOT = _obj(
    {
        "name": _str(),
        "type": _str(),
        "state": _str(),
        "x": _num(),
        "y": _num(),
        "heading": _num(),
        "load": {"type": "integer", "minimum": 0},
        "alive": {"type": "boolean"},
        "distance": _num(),
        "charge": {"type": ["number", "null"]},
        "task": {"type": ["string", "null"]},
    },
    title="regolith.RobotState",
)
ROBOT_STATES = _obj(
    {
        "timestamp": TIME,
        "t": _num(),
        "robots": _arr(_ROBOT),
        "counters": {"type": "object", "additionalProperties": {"type": "integer"}},
    },
    title="regolith.RobotStates",
)

#: Schema name -> schema, every one this export registers.
SCHEMAS: dict[str, JSON] = {
    s["title"]: s
    for s in (SCENE_UPDATE, POSES_IN_FRAME, FRAME_TRANSFORMS, LOG, EVENT, ACTION, ROBOT_STATES)
}
