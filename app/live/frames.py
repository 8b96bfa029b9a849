"""Live frames as deltas (the protocol is in docs/service.md, "Live stream").

A mission's `FrameStream` is what its viewers have been sent: the last frame, with positions
rounded to the stream's precision, and its sequence number. Each new engine frame becomes a
delta against it: the robots whose state, load or liveness changed (whole), the poses of the
robots that only moved (a flat array by robot index), the counters that changed and the
search cells newly scanned. A viewer that is behind gets its unsent deltas merged into one
(`Pending`), so it never skips a change; a viewer that asks (`resync`) gets a full frame.
"""

from __future__ import annotations

import base64
from typing import Any

import numpy as np

Json = dict[str, Any]

#: Robot fields that only say where a robot is; the others (state, load, alive, type) go whole.
POSE = ("x", "y", "heading")
#: The stream's precision: 1 cm and 1 mrad, so a moving robot costs ~22 bytes per frame;
#: a charge to the percent, so a draining battery sends its robot whole once per percent.
DIGITS = {"x": 2, "y": 2, "heading": 3, "charge": 2}


def rounded(robot: Json) -> Json:
    """A robot's frame fields at the stream's precision."""
    out = dict(robot)
    for key, digits in DIGITS.items():
        value = out.get(key)
        if isinstance(value, float):
            out[key] = round(value, digits)
    return out


def _new_cells(old: bytes, new: bytes) -> list[int]:
    """Indices of the bits set in `new` but not in `old` (bit i = cell i, little-endian)."""
    a = np.frombuffer(new, dtype=np.uint8)
    b = np.frombuffer(old.ljust(len(new), b"\0")[: len(new)], dtype=np.uint8)
    bits = np.unpackbits(a & ~b, bitorder="little")
    return [int(i) for i in np.flatnonzero(bits)]


class FrameStream:
    """The last frame every viewer of one mission has, and the delta to the next."""

    def __init__(self) -> None:
        self.seq = 0
        self.head: Json = {}  # t, status, policy
        self.robots: dict[str, Json] = {}  # by name, in index order
        self.names: list[str] = []  # index -> name
        self.index: dict[str, int] = {}
        self.scanned = ""  # base64 as the engine sends it
        self._scanned_bytes = b""
        self.scanned_count = 0
        self.counters: dict[str, Any] = {}
        self._raw: dict[str, Json] = {}  # the engine's last dict of each robot, unrounded
        self._full: tuple[int, Json] | None = None

    def advance(self, frame: Json) -> Json | None:
        """Take the engine's next frame; return the delta from the last one (with `seq` and
        `base`), a full frame if the roster shrank, or None when nothing changed."""
        raw_robots = frame["robots"]
        if len(raw_robots) < len(self.names) or any(
            r["name"] != n for r, n in zip(raw_robots, self.names, strict=False)
        ):
            self._reset(frame, [rounded(r) for r in raw_robots])
            self.seq += 1
            return self.full()
        whole: list[Json] = []
        poses: list[Any] = []
        raw = self._raw
        for i, engine_robot in enumerate(raw_robots):
            name = engine_robot["name"]
            if raw.get(name) == engine_robot:  # unchanged to the bit: nothing to round
                continue
            raw[name] = engine_robot
            r = rounded(engine_robot)
            old = self.robots.get(name)
            if old is None:
                self.names.append(name)
                self.index[name] = i
                whole.append(r)
            elif old != r:
                same = len(old) == len(r) and all(
                    old.get(k) == v for k, v in r.items() if k not in POSE
                )
                if same:
                    poses += [i, r["x"], r["y"], r["heading"]]
                else:
                    whole.append(r)
            self.robots[name] = r
        counters = {k: v for k, v in frame["counters"].items() if self.counters.get(k) != v}
        self.counters.update(counters)
        cells: list[int] = []
        if frame["scanned"] != self.scanned:
            bits = base64.b64decode(frame["scanned"])
            cells = _new_cells(self._scanned_bytes, bits)
            self.scanned, self._scanned_bytes = frame["scanned"], bits
        self.scanned_count = frame["scanned_count"]
        head = {k: frame[k] for k in ("t", "status", "policy")}
        if not (whole or poses or counters or cells) and head == self.head:
            return None
        self.head = head
        self.seq += 1
        delta: Json = {"seq": self.seq, "base": self.seq - 1, **head, "robots": whole}
        if poses:
            delta["poses"] = poses
        if counters:
            delta["counters"] = counters
        if cells:
            delta["scanned_new"] = cells
        delta["scanned_count"] = self.scanned_count
        return delta

    def _reset(self, frame: Json, robots: list[Json]) -> None:
        self.head = {k: frame[k] for k in ("t", "status", "policy")}
        self.robots = {r["name"]: r for r in robots}
        self._raw = {r["name"]: r for r in frame["robots"]}
        self.names = [r["name"] for r in robots]
        self.index = {n: i for i, n in enumerate(self.names)}
        self.scanned = frame["scanned"]
        self._scanned_bytes = base64.b64decode(frame["scanned"])
        self.scanned_count = frame["scanned_count"]
        self.counters = dict(frame["counters"])

    def full(self) -> Json:
        """The whole state at `seq` (the same fields as the engine's frame, plus `seq`)."""
        if self._full is None or self._full[0] != self.seq:
            self._full = (
                self.seq,
                {
                    "seq": self.seq,
                    "full": True,
                    **self.head,
                    "robots": list(self.robots.values()),
                    "scanned": self.scanned,
                    "scanned_count": self.scanned_count,
                    "counters": dict(self.counters),
                },
            )
        return self._full[1]


class Pending:
    """The deltas a viewer has not been sent yet, merged into one as they arrive."""

    def __init__(self, message: Json, text: str | None) -> None:
        self.message = message
        self.text = text
        self._merged = False

    def add(self, message: Json, stream: FrameStream) -> None:
        """Merge a newer delta (or full frame) into this one."""
        if message.get("full"):
            self.message, self.text, self._merged = message, None, False
            return
        if not self._merged:
            self._open(stream)
        m = self.message
        robots: dict[str, Json] = m["robots"]
        poses: dict[int, list[Any]] = m["poses"]
        for r in message["robots"]:
            robots[r["name"]] = r
            poses.pop(stream.index[r["name"]], None)
        flat = message.get("poses", ())
        for j in range(0, len(flat), 4):
            i, x, y, heading = flat[j : j + 4]
            name = stream.names[i]
            if name in robots:
                robots[name] = {**robots[name], "x": x, "y": y, "heading": heading}
            else:
                poses[i] = [x, y, heading]
        m["counters"].update(message.get("counters", {}))
        m["scanned_new"] += message.get("scanned_new", [])
        for key in ("type", "wall", "seq", "t", "status", "policy", "scanned_count"):
            m[key] = message[key]
        self.text = None

    def _open(self, stream: FrameStream) -> None:
        """Copy the first message into mergeable parts (it is shared with other viewers)."""
        m = self.message
        if m.get("full"):
            robots = {r["name"]: r for r in m["robots"]}
            self.message = {**m, "robots": robots, "poses": {}, "scanned_new": []}
            self.message["counters"] = dict(m["counters"])
        else:
            flat = m.get("poses", [])
            self.message = {
                **m,
                "robots": {r["name"]: r for r in m["robots"]},
                "poses": {flat[j]: flat[j + 1 : j + 4] for j in range(0, len(flat), 4)},
                "counters": dict(m.get("counters", {})),
                "scanned_new": list(m.get("scanned_new", [])),
            }
        self._merged = True

    def final(self, stream: FrameStream) -> Json:
        """The merged message, ready to encode."""
        if not self._merged:
            return self.message
        m = dict(self.message)
        m["robots"] = list(m["robots"].values())
        if m.get("full"):
            # a full frame with later deltas merged in: the stream's own full frame at seq
            return {"type": m["type"], "wall": m["wall"], **stream.full()}
        m["poses"] = [v for i in sorted(m["poses"]) for v in (i, *m["poses"][i])]
        for key in ("poses", "counters", "scanned_new"):
            if not m[key]:
                del m[key]
        return m


#: A robot's fields in a frame (the robot list and snapshots add task, path, … to these);
#: `charge` only with energy on (docs/model.md#energy).
FRAME_FIELDS = ("name", "type", "state", "x", "y", "heading", "load", "alive", "charge")


class Replica:
    """A client's copy of the stream: a snapshot, then each frame applied in order. The
    reference decoder for Python clients (tests, bench/); the dashboard's is js/framestate.js."""

    def __init__(self) -> None:
        self.seq: int | None = None
        self.head: Json = {}
        self.robots: dict[str, Json] = {}  # by name, in index order
        self.names: list[str] = []
        self.scanned = bytearray()
        self.scanned_count = 0
        self.counters: dict[str, Any] = {}

    def snapshot(self, message: Json) -> None:
        """A `snapshot` message: its state, at its `seq`."""
        state = message["state"] or {}
        self._whole(state, message.get("seq"))

    def _whole(self, state: Json, seq: int | None) -> None:
        self.seq = seq
        self.head = {k: state.get(k) for k in ("t", "status", "policy")}
        robots = [{k: r[k] for k in FRAME_FIELDS if k in r} for r in state.get("robots", [])]
        self.robots = {r["name"]: r for r in robots}
        self.names = list(self.robots)
        self.scanned = bytearray(base64.b64decode(state.get("scanned") or ""))
        self.scanned_count = state.get("scanned_count", 0)
        self.counters = dict(state.get("counters", {}))

    def apply(self, frame: Json) -> bool:
        """Apply a `frame` message; False (and nothing applied) if it does not follow on."""
        if frame.get("full"):
            self._whole(frame, frame["seq"])
            return True
        if self.seq is None or frame["base"] != self.seq:
            return False
        self.seq = frame["seq"]
        self.head = {k: frame[k] for k in ("t", "status", "policy")}
        for r in frame["robots"]:
            if r["name"] not in self.robots:
                self.names.append(r["name"])
            self.robots[r["name"]] = dict(r)
        flat = frame.get("poses", ())
        for j in range(0, len(flat), 4):
            robot = self.robots[self.names[flat[j]]]
            robot["x"], robot["y"], robot["heading"] = flat[j + 1 : j + 4]
        self.counters.update(frame.get("counters", {}))
        for cell in frame.get("scanned_new", ()):
            self.scanned[cell >> 3] |= 1 << (cell & 7)
        self.scanned_count = frame["scanned_count"]
        return True

    def state(self) -> Json:
        """Everything a full frame carries, for comparing."""
        return {
            "seq": self.seq,
            **self.head,
            "robots": [dict(r) for r in self.robots.values()],
            "scanned": base64.b64encode(bytes(self.scanned)).decode("ascii"),
            "scanned_count": self.scanned_count,
            "counters": dict(self.counters),
        }
