"""Signed frames (field/trust.py): only what a mission's authority issued opens, only on the
key it was signed for, only once, only from the newest start of a robot; size and nesting are
capped before anything is parsed; junk is counted and logged once per sender per interval."""

from __future__ import annotations

import json
import logging

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from field.trust import (
    MAX_DEPTH,
    MAX_FRAME,
    REPLAY_WINDOW,
    Authority,
    Credential,
    Opener,
    Rejected,
    Sealer,
    nesting_depth,
)

KEY = "regolith/m1/msg/bid/hauler-1"


@pytest.fixture
def authority() -> Authority:
    return Authority("m1")


def _opener(authority: Authority) -> Opener:
    return Opener("m1", authority.anchor, "test")


def _reason(opener: Opener, channel: str, payload: bytes) -> str:
    with pytest.raises(Rejected) as info:
        opener.open(channel, payload)
    return info.value.reason


def test_a_sealed_frame_opens_with_its_sender(authority: Authority) -> None:
    sealer = Sealer(authority.issue("hauler-1", "hauler"))
    opened = _opener(authority).open(KEY, sealer.seal(KEY, b'{"v":1}'))
    assert (opened.sender, opened.cert.role, opened.json()) == ("hauler-1", "hauler", {"v": 1})


def test_forgeries_are_refused_each_for_its_reason(authority: Authority) -> None:
    cred = authority.issue("hauler-1", "hauler")
    sealer, opener = Sealer(cred), _opener(authority)
    frame = sealer.seal(KEY, b'{"v":1,"utility":1}')
    assert _reason(opener, KEY, frame.replace(b'"utility":1', b'"utility":9')) == "forged"
    assert _reason(opener, "regolith/m1/msg/bid/hauler-2", frame) == "forged"  # another key
    opener.open(KEY, frame)
    assert _reason(opener, KEY, frame) == "replayed"
    stranger = Sealer(Authority("m1").issue("hauler-1", "hauler"))  # another authority
    assert _reason(opener, KEY, stranger.seal(KEY, b"{}")) == "stranger"
    other = Authority("m2")
    assert (
        _reason(
            Opener("m1", other.anchor, "t"),
            KEY,
            Sealer(other.issue("hauler-1", "hauler")).seal(KEY, b"{}"),
        )
        == "stranger"
    )
    assert _reason(opener, KEY, b'{"v":1,"type":"bid"}') == "unsigned"
    assert _reason(opener, KEY, frame[:40]) == "unsigned"
    assert _reason(opener, KEY, b"X" * (MAX_FRAME + 1)) == "oversized"
    deep = b"[" * (MAX_DEPTH + 1) + b"]" * (MAX_DEPTH + 1)
    assert _reason(opener, KEY, sealer.seal(KEY, deep)) == "too deep"


def test_a_restarted_robots_old_key_stops_counting(authority: Authority) -> None:
    opener = _opener(authority)
    old = Sealer(authority.issue("hauler-1", "hauler"))
    new = Sealer(authority.issue("hauler-1", "hauler"))
    early = old.seal(KEY, b"{}")
    opener.open(KEY, new.seal(KEY, b"{}"))
    assert _reason(opener, KEY, early) == "stale"


def test_frames_out_of_order_open_once_each(authority: Authority) -> None:
    sealer, opener = Sealer(authority.issue("hauler-1", "hauler")), _opener(authority)
    frames = [sealer.seal(KEY, b"{}") for _ in range(50)]
    for f in reversed(frames):
        opener.open(KEY, f)
    assert all(_reason(opener, KEY, f) == "replayed" for f in frames)


def test_a_channel_taken_in_far_behind_another_still_opens(authority: Authority) -> None:
    """A process takes each channel in on a thread of its own (field/drain.py): one of them
    may be thousands of a sender's frames behind another, and nothing in it is a replay."""
    sealer, opener = Sealer(authority.issue("excavator-1", "excavator")), _opener(authority)
    world, bus = "regolith/m1/world", "regolith/m1/msg/heartbeat/excavator-1"
    late = [sealer.seal(bus, b"{}") for _ in range(10)]
    for _ in range(3 * REPLAY_WINDOW):
        opener.open(world, sealer.seal(world, b"{}"))
    for f in late:
        opener.open(bus, f)
    assert all(_reason(opener, bus, f) == "replayed" for f in late)


def test_a_frame_older_than_its_channels_window_is_refused(authority: Authority) -> None:
    sealer, opener = Sealer(authority.issue("hauler-1", "hauler")), _opener(authority)
    early = sealer.seal(KEY, b"{}")
    for _ in range(REPLAY_WINDOW):
        opener.open(KEY, sealer.seal(KEY, b"{}"))
    assert _reason(opener, KEY, early) == "replayed"


def test_a_credential_travels_as_json(authority: Authority) -> None:
    cred = authority.issue("scout-2", "scout")
    back = Credential.from_json(cred.to_json())
    assert back == cred and back.certificate().name == "scout-2"
    for bad in ("", "{}", "[1]", json.dumps({"v": 1, "name": "x"}), "not json"):
        with pytest.raises(ValueError, match="credentials"):
            Credential.from_json(bad)
    with pytest.raises(ValueError, match="role"):
        authority.issue("control", "control")


def test_nesting_is_measured_without_parsing() -> None:
    assert nesting_depth(b'{"a": [1, {"b": "[[[[["}]}') == 3
    assert nesting_depth(b'"\\"[[[" ') == 0
    assert nesting_depth(b"[" * 500) == 500


def test_junk_is_logged_once_per_sender_and_interval(
    authority: Authority, caplog: pytest.LogCaptureFixture
) -> None:
    opener = _opener(authority)
    with caplog.at_level(logging.WARNING, logger="regolith.field.trust"):
        for i in range(500):
            assert opener.admit(KEY, b"junk %d" % i) is None
    assert opener.rejections.total == 500
    assert opener.rejections.snapshot()["by_reason"] == {"unsigned": 500}
    assert len(caplog.records) == 1


@settings(max_examples=300, deadline=None)
@given(st.binary(max_size=400))
def test_random_bytes_are_rejected_never_raised(payload: bytes) -> None:
    opener = Opener("m1", Authority("m1").anchor, "fuzz")
    assert opener.admit(KEY, payload) is None
    assert opener.admit(KEY, b"RGF1" + payload) is None


def test_a_query_its_asker_gave_up_on_is_not_answered() -> None:
    """Under a backlog, answering queries already given up on (each asked again) kept the
    world service behind for good: a query past its `until` is skipped, and counted."""
    from types import SimpleNamespace

    from field.link import Link
    from field.wire import encode_json

    authority = Authority("m1")
    link = Link(None, authority.control, "test")  # type: ignore[arg-type]
    asker = Sealer(authority.issue("hauler-1", "hauler"))
    key = "regolith/m1/world"

    def query(until: float) -> SimpleNamespace:
        body = encode_json({"op": "status", "rid": "r", "until": until})
        payload = SimpleNamespace(to_bytes=lambda: asker.seal(key, body))
        return SimpleNamespace(payload=payload, key_expr=key)

    import time

    assert link.take_query(query(time.time() + 2.0), key) is not None
    assert link.take_query(query(time.time() - 0.1), key) is None
    assert link.late == 1 and link.opener.rejections.total == 0


def test_a_frame_counts_for_the_key_its_receiver_expects_not_the_key_it_came_under() -> None:
    """Zenoh now and then hands a sample over under another declaration's prefix (a world
    event put on `regolith/<m>/event/world` reached a robot as `regolith/<m>/msg/world`):
    a queryable checks a request against its own key, so an honest one is still answered,
    and a frame signed for another key is still refused."""
    from types import SimpleNamespace

    from field.link import Link
    from field.wire import encode_json

    authority = Authority("m1")
    link = Link(None, authority.control, "test")  # type: ignore[arg-type]
    asker = Sealer(authority.issue("hauler-1", "hauler"))
    world, body = "regolith/m1/world", "regolith/m1/body/hauler-2"

    def query(signed_for: str) -> SimpleNamespace:
        data = encode_json({"op": "status", "rid": "r", "until": 4e9})
        payload = SimpleNamespace(to_bytes=lambda: asker.seal(signed_for, data))
        return SimpleNamespace(payload=payload, key_expr="regolith/m1/msg/world")  # mangled

    assert link.take_query(query(world), world) is not None
    assert link.take_query(query(body), world) is None  # meant for another queryable
    assert link.opener.rejections.by_reason == {"forged": 1}


def test_a_report_is_signed_for_its_signers_own_event_key() -> None:
    from field.intake import Intake
    from field.link import Link
    from field.wire import event_key

    authority = Authority("m1")
    intake = Intake(Link(None, authority.control, "test"))  # type: ignore[arg-type]
    hauler = Sealer(authority.issue("hauler-1", "hauler"))
    world = Sealer(authority.issue("world", "world"))
    opener = intake.link.opener
    assert opener.admit(intake._report_channel, hauler.seal(event_key("m1", "hauler-1"), b"{}"))
    assert opener.admit(intake._report_channel, world.seal(event_key("m1", "world"), b"{}"))
    # in another robot's name: refused, whatever key it is put on
    assert not opener.admit(intake._report_channel, hauler.seal(event_key("m1", "h-2"), b"{}"))
    # mission control's own certificate does not speak for the world
    control = Sealer(authority.control)
    assert not opener.admit(intake._report_channel, control.seal(event_key("m1", "world"), b"{}"))
    assert opener.rejections.by_reason == {"forged": 2}
