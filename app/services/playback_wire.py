"""The playback worker's wire: length-prefixed JSON frames over a pipe.

A frame is a 4-byte big-endian length and that many bytes of UTF-8 JSON holding one object.
Either side refuses a frame longer than `MAX_FRAME` before reading it (a corrupt or runaway
peer cannot make the other allocate without bound) and anything that is not a JSON object.
"""

from __future__ import annotations

import asyncio
import json
import struct
from typing import Any

#: The largest frame either side accepts: a state of a reference mission is 13-45 KB, one of
#: a mission at scale 4 a few hundred KB; a request carries the scenario and actions.
MAX_FRAME = 16 * 2**20
_HEAD = struct.Struct(">I")


class WireError(Exception):
    """The peer sent something that is not a frame of ours (or too large a one)."""


def encode(message: dict[str, Any]) -> bytes:
    body = json.dumps(message, separators=(",", ":")).encode()
    if len(body) > MAX_FRAME:
        raise WireError(f"a {len(body)}-byte message is over the {MAX_FRAME}-byte frame limit")
    return _HEAD.pack(len(body)) + body


async def read_frame(reader: asyncio.StreamReader) -> dict[str, Any] | None:
    """The next message, or None at a clean end of stream (between frames)."""
    try:
        head = await reader.readexactly(_HEAD.size)
    except asyncio.IncompleteReadError as exc:
        if exc.partial:
            raise WireError("the stream ended inside a frame's header") from None
        return None
    (size,) = _HEAD.unpack(head)
    if size > MAX_FRAME:
        raise WireError(f"a {size}-byte frame is over the {MAX_FRAME}-byte limit")
    try:
        body = await reader.readexactly(size)
    except asyncio.IncompleteReadError:
        raise WireError(f"the stream ended inside a {size}-byte frame") from None
    try:
        message = json.loads(body)
    except ValueError as exc:
        raise WireError(f"a frame that is not JSON ({exc})") from None
    if not isinstance(message, dict):
        raise WireError(f"a frame holding a {type(message).__name__}, not an object")
    return message
