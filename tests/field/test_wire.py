"""The field wire format: every engine message survives the trip; anything else is dropped,
never raised (a robot must not crash on what it hears)."""

from __future__ import annotations

import json
import logging
import math
import time
from dataclasses import replace

import pytest
from hypothesis import given
from hypothesis import strategies as st

from engine.messages import Announce, Bid, Heartbeat, Hello, Message, PolicyChange, TaskDone
from field.fleet import free_port
from field.link import Link
from field.transport import Faults, ZenohBus, open_session
from field.trust import Authority
from field.wire import (
    MESSAGE_TYPES,
    VERSION,
    InjectTask,
    decode,
    decode_inject,
    decode_json,
    encode,
    message_key,
)

SAMPLES: list[Message] = [
    Announce(
        sender="excavator-1",
        auction_id="a1",
        auctioneer="excavator-1",
        task_type="transport",
        location=(1.5, 2.0),
        task_id="t1",
        opened_at=3.0,
        round=1,
    ),
    Bid(
        sender="hauler-2",
        auction_id="a1",
        auctioneer="excavator-1",
        bidder="hauler-2",
        location=(1.5, 2.0),
        utility=-math.inf,
        round=1,
    ),
    Heartbeat(
        sender="scout-1",
        rtype="scout",
        t=10.0,
        x=1.0,
        y=2.0,
        state="scanning",
        path=((1.0, 2.0), (3.0, 4.0)),
        progress=7,
    ),
    TaskDone(sender="hauler-2", auction_id="a1", task_id="t1", outcome="void"),
    Hello(sender="excavator-5", rtype="excavator"),
    PolicyChange(sender="operator", policy="nearest"),
]


def test_every_engine_message_type_has_a_wire_name() -> None:
    assert {"announce", "bid", "award", "ack", "close", "heartbeat", "hello"} <= set(MESSAGE_TYPES)


@pytest.mark.parametrize("msg", SAMPLES, ids=lambda m: type(m).__name__)
def test_round_trip(msg: Message) -> None:
    key, payload = encode("m1", msg, 7)
    assert key == message_key("m1", type(msg).__name__.lower(), msg.sender)
    env = json.loads(payload)
    assert env["v"] == VERSION and env["seq"] == 7 and env["sender"] == msg.sender
    assert decode(payload, "m1") == msg


def _envelope(**over: object) -> bytes:
    _, payload = encode("m1", SAMPLES[3], 0)
    env = json.loads(payload)
    env.update(over)
    return json.dumps(env).encode()


def _body(sample: int, **over: object) -> bytes:
    """An envelope of `SAMPLES[sample]` whose body is changed by `over`: the message's own
    checks (`engine.messages.validate`), not the envelope's."""
    msg = SAMPLES[sample]
    _, payload = encode("m1", msg, 0)
    env = json.loads(payload)
    env["body"].update(over)
    return json.dumps(env).encode()


@pytest.mark.parametrize(
    "payload",
    [
        b"",
        b"\xff\xfe\x00garbage",
        b"[]",
        b"null",
        b'{"v": 1}',
        b"[" * 5000,
        _envelope(v=2),
        _envelope(type="teleport"),
        _envelope(extra=1),
        _envelope(sender="hauler/../x"),
        _envelope(sender="someone-else"),  # body's sender is not the envelope's
        _envelope(body={"sender": "hauler-2"}),  # fields missing
        _body(3, outcome="exploded"),
        _body(3, note="an unknown field"),
        _body(0, task_type="teleport"),
        _body(0, auctioneer="x" * 65),
        _body(0, location=[1.0]),
        _body(1, utility="high"),
        _body(2, tasks="not-a-list"),
        _body(2, load=[1]),
        _envelope(seq=-1),
    ],
)
def test_malformed_is_dropped(payload: bytes, caplog: pytest.LogCaptureFixture) -> None:
    """Dropped, and said at debug level only: the caller counts it and logs it once per
    sender per interval (field.trust.Rejections), not once per message."""
    with caplog.at_level(logging.DEBUG, logger="regolith.field.wire"):
        assert decode(payload, "m1") is None
    assert "dropped" in caplog.text and all(r.levelno == logging.DEBUG for r in caplog.records)


def test_other_mission_is_dropped() -> None:
    _, payload = encode("m2", SAMPLES[0], 0)
    assert decode(payload, "m1") is None


@given(st.binary(max_size=300))
def test_random_bytes_never_raise(payload: bytes) -> None:
    assert decode(payload) is None or isinstance(decode(payload), Message)
    assert decode_json(payload) is None or decode_json(payload)["v"] == VERSION


def test_an_operator_task_round_trips_and_a_bad_one_is_dropped() -> None:
    task = InjectTask(v=1, cmd="inject_task", task_type="transport", x=1.5, y=2.0, task_id="t")
    good = json.loads(task.model_dump_json())
    assert decode_inject(good) == task
    for bad in (
        {**good, "v": 2},  # another version
        {**good, "task_type": "scan"},  # not a task an operator may inject
        {**good, "x": "NaN"},  # not a finite number
        {**good, "extra": 1},  # an unknown field
        {k: v for k, v in good.items() if k != "task_id"},  # a missing one
    ):
        assert decode_inject(bad) is None, bad


@given(st.dictionaries(st.text(max_size=10), st.integers() | st.text(max_size=5), max_size=8))
def test_random_objects_are_never_an_operator_task(data: dict) -> None:
    assert decode_inject(data) is None


def test_faults_validate_and_draw() -> None:
    with pytest.raises(ValueError, match="loss"):
        Faults(loss=0.95)
    f = Faults(loss=0.5, latency_s=0.01, seed=3)
    draws = [f.draw() for _ in range(400)]
    lost = sum(d is None for d in draws)
    assert 100 < lost < 300 and f.dropped == lost
    assert all(d == pytest.approx(0.01) for d in draws if d is not None)


def test_zenoh_bus_between_two_sessions() -> None:
    """Two real peer sessions over TCP on 127.0.0.1: what one publishes the other's inbox
    holds, validated; garbage put on the same keys is dropped; the sender never hears itself."""
    from engine.liveness import Liveness

    endpoint = f"tcp/127.0.0.1:{free_port()}"
    a = open_session(listen=endpoint)
    b = open_session(connect=endpoint)
    authority = Authority("m1")
    try:
        bus_a = ZenohBus(Link(a, authority.issue("hauler-2", "hauler"), "a"), Liveness())
        bus_b = ZenohBus(Link(b, authority.issue("scout-1", "scout"), "b"), Liveness())
        bus_a.subscribe("hauler-2", lambda m: None)
        heard: list[Message] = []
        bus_b.subscribe("scout-1", heard.append)
        bus_b._liveness.add("scout-1")
        deadline = time.monotonic() + 10
        got: list[Message] = []
        while time.monotonic() < deadline and not got:
            a.put(message_key("m1", "bid", "x"), b"not json")  # also reaches b: dropped
            bus_a.publish(SAMPLES[3])
            time.sleep(0.05)
            got = bus_b.inbox.due()
        assert bus_a.inbox.due() == []  # its own messages are not delivered back
        for m in got:
            bus_b.deliver(m, 1.0)
        assert heard and all(m == SAMPLES[3] for m in heard)
        assert bus_b._liveness.last_heard("scout-1", "hauler-2") == 1.0
    finally:
        b.close()
        a.close()


def test_a_member_speaks_only_for_what_is_its_own() -> None:
    """Signed in its own name is not enough: an auction's messages only from its
    auctioneer, a bid and an acknowledgement only from the bidder, a heartbeat of its own
    type, no policy change from a robot (field.transport.may_send)."""
    from engine.messages import Ack, Announce, Bid, Close, Heartbeat, PolicyChange
    from field.transport import may_send

    loc = (1.0, 2.0)
    own = Close(
        sender="excavator-1",
        auction_id="excavator-1/a1",
        auctioneer="excavator-1",
        task_type="transport",
        location=loc,
        task_id="t",
        allocated_to="hauler-1",
    )
    assert may_send(own, "excavator")
    for msg, role in (
        (replace(own, sender="hauler-7", auctioneer="hauler-7"), "hauler"),
        (
            Announce(
                sender="hauler-7",
                auction_id="excavator-1/a2",
                auctioneer="hauler-7",
                task_type="transport",
                location=loc,
                task_id="t",
                opened_at=0.0,
            ),
            "hauler",
        ),
        (
            Bid(
                sender="hauler-7",
                auction_id="excavator-1/a1",
                auctioneer="excavator-1",
                bidder="hauler-1",
                location=loc,
                utility=1e300,
                round=0,
            ),
            "hauler",
        ),
        (
            Ack(
                sender="hauler-7",
                auction_id="excavator-1/a1",
                auctioneer="excavator-1",
                winner="hauler-1",
                location=loc,
                accepted=False,
            ),
            "hauler",
        ),
        (
            Heartbeat(sender="hauler-7", rtype="excavator", t=0.0, x=0.0, y=0.0, state="idle"),
            "hauler",
        ),
        (PolicyChange(sender="operator", policy="central-greedy"), "operator"),
    ):
        assert not may_send(msg, role), msg
