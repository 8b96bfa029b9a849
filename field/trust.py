"""Who may speak on a field mission's bus: certificates, signed frames, and the checks made on
every payload before anything in it is parsed (docs/field.md, "Trust").

Mission control holds the mission's *authority*, an Ed25519 key. When it starts an agent it
issues that robot a *credential*: a fresh key pair and a certificate (mission, name, role,
generation, public key) signed by the authority. Every payload an agent or mission control
puts on the mission's keys is a *frame*: the sender's certificate, a sequence number and the
body, signed with the sender's key over the key expression it is sent on. A receiver, holding
only the authority's public key, checks in this order, cheapest first, and drops (and counts)
what fails: the size, the frame's shape, the certificate's signature and mission, that its
generation is the newest it has seen for that name, the frame's signature, that the sequence
number is new, and the nesting depth of the body. Only then is the body parsed as JSON.
"""

from __future__ import annotations

import base64
import json
import logging
import re
import struct
import threading
import time
from collections import defaultdict
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

from cryptography.exceptions import InvalidSignature
from cryptography.hazmat.primitives.asymmetric.ed25519 import (
    Ed25519PrivateKey,
    Ed25519PublicKey,
)
from cryptography.hazmat.primitives.serialization import Encoding, PublicFormat

log = logging.getLogger("regolith.field.trust")

CONTROL = "control"
"""Mission control's name and role on the bus: it signs commands and operator tasks."""
WORLD = "world"
"""The world service's name and role: it signs the world's answers, its events and the commands
it gives the agents it supervises (`stop`). A process of its own (`field/moon.py`), so mission
control can stop and come back while the robots mine on."""
ROLES = frozenset({CONTROL, WORLD, "operator", "scout", "excavator", "hauler"})
SUPERVISORS = frozenset({CONTROL, WORLD})
"""Who an agent takes commands from."""

MAGIC = b"RGF1"
_HEAD = struct.Struct(">4sQH")  # magic, sequence number, certificate length
_SIG = 64
MAX_CERT = 512
MAX_FRAME = 64 * 1024
"""Protocol messages, queries, replies and commands: a heartbeat with its route is ~2 KB."""
MAX_REPORT = 1024 * 1024
"""Events and auction records (an auction with every bid of a large team)."""
MAX_DEPTH = 16
"""JSON nesting a body may have; the deepest legitimate one (an auction record) has 4."""
REPLAY_WINDOW = 8192
Channel = str | Callable[[str], str]
"""What a frame must have been signed for: a key, or the key given the signer's name (a
robot's events are signed for `regolith/<m>/event/<its name>`)."""
LOG_EVERY_S = 10.0


class Rejected(Exception):
    """A frame that is dropped: `reason` is what failed, `who` the claimed sender (or
    'stranger' when not even a valid certificate came with it)."""

    def __init__(self, reason: str, who: str = "stranger", detail: str = "") -> None:
        super().__init__(f"{reason} from {who}{': ' + detail if detail else ''}")
        self.reason, self.who, self.detail = reason, who, detail


@dataclass(frozen=True)
class Certificate:
    mission: str
    name: str
    role: str
    gen: int
    public: bytes


@dataclass(frozen=True)
class Opened:
    """A frame that passed every check: who sent it, and its body (still bytes)."""

    cert: Certificate
    seq: int
    body: bytes

    @property
    def sender(self) -> str:
        return self.cert.name

    def json(self) -> Any:
        return json.loads(self.body)


def _b64(b: bytes) -> str:
    return base64.b64encode(b).decode()


def _raw_public(key: Ed25519PublicKey) -> bytes:
    return key.public_bytes(Encoding.Raw, PublicFormat.Raw)


def _signed_text(channel: str, seq: int, cert: bytes, body: bytes) -> bytes:
    # the key expression is signed too: a frame cannot be replayed onto another key
    return b"regolith-frame\0" + channel.encode() + b"\0" + struct.pack(">Q", seq) + cert + body


@dataclass(frozen=True)
class Credential:
    """What one process needs to speak on a mission's bus: its key, its certificate and the
    authority's public key (to check everybody else's). Handed to a local agent on its
    standard input, to one on another machine as a file (docs/field.md)."""

    mission: str
    name: str
    role: str
    gen: int
    key: bytes  # the private key, raw
    cert: bytes  # the authority's signature + the certificate's JSON
    anchor: bytes  # the authority's public key, raw

    def to_json(self) -> str:
        return json.dumps(
            {
                "v": 1,
                "mission": self.mission,
                "name": self.name,
                "role": self.role,
                "gen": self.gen,
                "key": _b64(self.key),
                "cert": _b64(self.cert),
                "anchor": _b64(self.anchor),
            }
        )

    def certificate(self) -> Certificate:
        d = json.loads(self.cert[_SIG:])
        return Certificate(d["m"], d["n"], d["r"], d["g"], base64.b64decode(d["k"]))

    @classmethod
    def from_json(cls, text: str) -> Credential:
        """ValueError (saying what is wrong) for anything but a credential of this format."""
        try:
            d = json.loads(text)
            if not isinstance(d, dict) or d.get("v") != 1:
                raise ValueError("not a version-1 credential")
            return cls(
                mission=str(d["mission"]),
                name=str(d["name"]),
                role=str(d["role"]),
                gen=int(d["gen"]),
                key=base64.b64decode(d["key"], validate=True),
                cert=base64.b64decode(d["cert"], validate=True),
                anchor=base64.b64decode(d["anchor"], validate=True),
            )
        except (KeyError, TypeError, ValueError) as exc:
            raise ValueError(f"credentials: {exc}") from None


class Authority:
    """Mission control's signing key for one mission: issues credentials, one generation
    more for each start of the same name (a restarted robot's old key stops counting)."""

    def __init__(
        self, mission: str, key: Ed25519PrivateKey | None = None, control_gen: int = 1
    ) -> None:
        self.mission = mission
        self._key = key or Ed25519PrivateKey.generate()
        self.anchor = _raw_public(self._key.public_key())
        self._gens: dict[str, int] = {CONTROL: control_gen - 1}
        self._lock = threading.Lock()
        self.control = self._issue(CONTROL, CONTROL, self._key)

    @classmethod
    def restore(cls, mission: str, secret: bytes, control_gen: int) -> Authority:
        """The authority of a mission mission control started before (kept with the
        database): its `control` certificate one generation newer than any before, so the
        robots take the returning mission control's word over the stopped one's."""
        return cls(mission, Ed25519PrivateKey.from_private_bytes(secret), control_gen)

    @property
    def secret(self) -> bytes:
        """The authority's private key, raw: for the database and the world service only."""
        return self._key.private_bytes_raw()

    def issue(self, name: str, role: str) -> Credential:
        if role not in ROLES - {CONTROL} or name == CONTROL or (role == WORLD) != (name == WORLD):
            raise ValueError(f"role: {role!r} cannot be issued to {name!r}")
        return self._issue(name, role, Ed25519PrivateKey.generate())

    def _issue(self, name: str, role: str, key: Ed25519PrivateKey) -> Credential:
        with self._lock:
            gen = self._gens[name] = self._gens.get(name, 0) + 1
        body = json.dumps(
            {
                "m": self.mission,
                "n": name,
                "r": role,
                "g": gen,
                "k": _b64(_raw_public(key.public_key())),
            },
            separators=(",", ":"),
        ).encode()
        cert = self._key.sign(b"regolith-cert\0" + body) + body
        raw_key = key.private_bytes_raw()
        return Credential(self.mission, name, role, gen, raw_key, cert, self.anchor)


class Sealer:
    """Signs what one process sends (thread-safe: one sequence for all its frames)."""

    def __init__(self, cred: Credential) -> None:
        self.cred = cred
        self._key = Ed25519PrivateKey.from_private_bytes(cred.key)
        self._seq = 0
        self._lock = threading.Lock()
        self._head = cred.cert

    @property
    def name(self) -> str:
        return self.cred.name

    def seal(self, channel: str, body: bytes) -> bytes:
        with self._lock:
            seq = self._seq
            self._seq += 1
        sig = self._key.sign(_signed_text(channel, seq, self._head, body))
        return _HEAD.pack(MAGIC, seq, len(self._head)) + self._head + sig + body


_STRINGS = re.compile(rb'"(?:[^"\\]|\\.)*"')
_NOT_BRACKETS = bytes(b for b in range(256) if b not in b"[]{}")


def nesting_depth(body: bytes) -> int:
    """The deepest nesting of JSON arrays and objects in `body`, without parsing it (strings
    removed first, then only the brackets are walked)."""
    depth = deepest = 0
    for c in _STRINGS.sub(b"", body).translate(None, _NOT_BRACKETS):
        if c in b"[{":
            depth += 1
            deepest = max(deepest, depth)
        else:
            depth -= 1
    return deepest


class Rejections:
    """Dropped frames, counted by reason and sender; logged once per sender and reason per
    interval (a flood of junk writes a line every `LOG_EVERY_S`, not a line a message)."""

    def __init__(self, where: str) -> None:
        self.where = where
        self.by_reason: dict[str, int] = defaultdict(int)
        self.by_sender: dict[str, int] = defaultdict(int)
        self._logged: dict[tuple[str, str], tuple[float, int]] = {}
        self._lock = threading.Lock()

    @property
    def total(self) -> int:
        return sum(self.by_reason.values())

    def count(self, exc: Rejected) -> None:
        now = time.monotonic()
        key = (exc.who[:64], exc.reason)
        with self._lock:
            self.by_reason[exc.reason] += 1
            if len(self.by_sender) < 1024 or key[0] in self.by_sender:
                self.by_sender[key[0]] += 1
            last, since = self._logged.get(key, (-LOG_EVERY_S, 0))
            if now - last < LOG_EVERY_S:
                self._logged[key] = (last, since + 1)
                return
            if len(self._logged) > 4096:
                self._logged.clear()
            self._logged[key] = (now, 0)
        more = f" (and {since} more since the last line)" if since else ""
        log.warning("%s: dropped %s%s", self.where, exc, more)

    def snapshot(self) -> dict[str, Any]:
        with self._lock:
            return {
                "total": sum(self.by_reason.values()),
                "by_reason": dict(sorted(self.by_reason.items())),
                "by_sender": dict(sorted(self.by_sender.items())),
            }


class Opener:
    """Checks frames for one process (thread-safe). `open` returns the checked frame or
    raises `Rejected`; `admit` does the same but counts and logs the rejection and returns
    None, for callers that only drop."""

    def __init__(self, mission: str, anchor: bytes, where: str) -> None:
        self.mission = mission
        self._anchor = Ed25519PublicKey.from_public_bytes(anchor)
        self._certs: dict[bytes, Certificate] = {}
        self._keys: dict[bytes, Ed25519PublicKey] = {}
        self._bad: set[bytes] = set()  # certificates that failed: a flood of one costs a lookup
        self._newest: dict[str, int] = {}
        # by sender, generation and channel: a process takes its channels in on threads of
        # their own (`field.drain`), each in order but at its own lag behind the others
        self._seen: dict[tuple[str, int, str], tuple[int, set[int]]] = {}
        self._lock = threading.Lock()
        self.rejections = Rejections(where)

    def admit(self, channel: Channel, payload: bytes, limit: int = MAX_FRAME) -> Opened | None:
        try:
            return self.open(channel, payload, limit)
        except Rejected as exc:
            self.rejections.count(exc)
            return None

    def open(self, channel: Channel, payload: bytes, limit: int = MAX_FRAME) -> Opened:
        if len(payload) > limit:
            raise Rejected("oversized", detail=f"{len(payload)} bytes > {limit}")
        if len(payload) < _HEAD.size + _SIG:
            raise Rejected("unsigned", detail="too short for a frame")
        magic, seq, n = _HEAD.unpack_from(payload)
        if magic != MAGIC:
            raise Rejected("unsigned", detail="no frame header")
        if n > MAX_CERT or len(payload) < _HEAD.size + n + _SIG:
            raise Rejected("malformed", detail="certificate length")
        raw_cert = payload[_HEAD.size : _HEAD.size + n]
        sig = payload[_HEAD.size + n : _HEAD.size + n + _SIG]
        body = payload[_HEAD.size + n + _SIG :]
        cert, key = self._certificate(raw_cert)
        who = cert.name
        with self._lock:
            newest = self._newest.get(who, 0)
        if cert.gen < newest:
            raise Rejected("stale", who, f"generation {cert.gen} < {newest}")
        if not isinstance(channel, str):
            channel = channel(who)
        try:
            key.verify(sig, _signed_text(channel, seq, raw_cert, body))
        except InvalidSignature:
            raise Rejected("forged", who, f"bad signature on {channel}") from None
        self._fresh(cert, seq, channel)
        if nesting_depth(body) > MAX_DEPTH:
            raise Rejected("too deep", who, f"nesting over {MAX_DEPTH}")
        return Opened(cert, seq, body)

    def _certificate(self, raw: bytes) -> tuple[Certificate, Ed25519PublicKey]:
        cert = self._certs.get(raw)
        if cert is not None:
            return cert, self._keys[raw]
        if len(raw) <= _SIG:
            raise Rejected("malformed", detail="certificate too short")
        if raw in self._bad:
            raise Rejected("stranger", detail="certificate not issued by this mission")
        try:
            self._anchor.verify(raw[:_SIG], b"regolith-cert\0" + raw[_SIG:])
        except InvalidSignature:
            with self._lock:
                if len(self._bad) > 4096:
                    self._bad.clear()
                self._bad.add(raw)
            raise Rejected("stranger", detail="certificate not issued by this mission") from None
        try:  # signed by the authority: well-formed by construction, checked all the same
            d = json.loads(raw[_SIG:])
            cert = Certificate(
                str(d["m"]), str(d["n"]), str(d["r"]), int(d["g"]), base64.b64decode(d["k"])
            )
            key = Ed25519PublicKey.from_public_bytes(cert.public)
        except (ValueError, KeyError, TypeError) as exc:
            raise Rejected("malformed", detail=f"certificate: {exc}") from None
        if cert.mission != self.mission:
            raise Rejected("stranger", cert.name, f"certificate of mission {cert.mission!r}")
        with self._lock:
            if len(self._certs) > 4096:
                self._certs.clear()
                self._keys.clear()
            self._certs[raw], self._keys[raw] = cert, key
        return cert, key

    def _fresh(self, cert: Certificate, seq: int, channel: str) -> None:
        """A sequence number this process has not seen from that sender's generation on that
        channel, and not older than the window there: a recorded frame sent again is dropped
        (sent on another channel, its signature fails: the channel is signed)."""
        with self._lock:
            if cert.gen > self._newest.get(cert.name, 0):
                self._newest[cert.name] = cert.gen
                for k in [k for k in self._seen if k[0] == cert.name]:
                    del self._seen[k]
            top, seen = self._seen.get((cert.name, cert.gen, channel), (-1, set()))
            if seq in seen or seq <= top - REPLAY_WINDOW:
                raise Rejected("replayed", cert.name, f"sequence {seq}")
            seen.add(seq)
            if seq > top:
                top = seq
                if len(seen) > 2 * REPLAY_WINDOW:
                    seen = {s for s in seen if s > top - REPLAY_WINDOW}
            self._seen[(cert.name, cert.gen, channel)] = (top, seen)
