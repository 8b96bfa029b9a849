"""The field mission clock (field/clock.py): piecewise mission time that mission control can
pause and re-pace, never backwards, whose states travel as JSON and are adopted only when
newer; hostile or malformed states change nothing. And the world service's side: no change
to the world while paused, reads still answered, and the state handed out in `spawn` and
`status` (tests/field/test_fleet.py runs it with real agent processes)."""

from __future__ import annotations

import json
import math
import random
from collections.abc import Iterator
from typing import Any

import pytest
import simpy

from field.clock import ClockState, MissionClock, advance_to, clock_of, poll_every
from field.transport import open_session
from field.world_rules import Paused
from tests.field.test_world_service import Team, _dig


class Wall:
    """A wall clock the test moves by hand."""

    def __init__(self, t: float = 1_000.0) -> None:
        self.t = t

    def __call__(self) -> float:
        return self.t


def test_piecewise_time_pause_and_repace() -> None:
    wall = Wall()
    c = MissionClock(ClockState(0, wall.t, 0.0, 10.0, False), wall)
    wall.t += 2
    assert c.now() == pytest.approx(20.0)
    s = c.set(paused=True)
    assert (s.version, s.t, s.paused, s.speed) == (1, pytest.approx(20.0), True, 10.0)
    wall.t += 50  # paused: time stands
    assert c.now() == pytest.approx(20.0)
    c.set(speed=25.0)  # re-paced while paused: still standing
    wall.t += 3
    assert c.now() == pytest.approx(20.0) and c.paused and c.speed == 25.0
    c.set(paused=False)
    wall.t += 2
    assert c.now() == pytest.approx(70.0)  # 20 + 2 × 25: the pause cost nothing
    assert c.state.version == 3


def test_random_changes_never_turn_time_back() -> None:
    """Any sequence of pauses, speeds and wall steps (also backwards: NTP) moves mission
    time forward or not at all, and a follower adopting every state in any order ends on
    the newest and never runs backwards either."""
    rng = random.Random()
    wall = Wall()
    owner = MissionClock(ClockState(0, wall.t, 0.0, 50.0, False), wall)
    follower = MissionClock(wall=wall)
    states = [owner.state.to_dict()]
    last_owner = last_follower = 0.0
    for _ in range(300):
        r = rng.random()
        if r < 0.3:
            states.append(owner.set(paused=rng.random() < 0.5).to_dict())
        elif r < 0.5:
            states.append(owner.set(speed=rng.choice([1.0, 20.0, 50.0, 100.0])).to_dict())
        else:
            wall.t += rng.uniform(-0.5, 2.0)
        sent = rng.choice(states)
        follower.adopt(json.loads(json.dumps(sent)))  # as it travels
        assert owner.now() >= last_owner and follower.now() >= last_follower
        last_owner, last_follower = owner.now(), follower.now()
    for s in states:
        follower.adopt(s)
    assert follower.state == owner.state


def test_a_state_round_trips_as_json_and_only_a_newer_one_is_adopted() -> None:
    s = ClockState(7, 1.7e9, 123.5, 20.0, True)
    assert ClockState.parse(json.loads(json.dumps(s.to_dict()))) == s
    c = MissionClock(s)
    assert not c.adopt({**s.to_dict(), "paused": False})  # same version: not newer
    assert not c.adopt({**s.to_dict(), "version": 6, "paused": False})  # older
    assert c.paused
    assert c.adopt({**s.to_dict(), "version": 8, "paused": False, "speed": 5.0})
    assert not c.paused and c.speed == 5.0


GOOD = {"version": 3, "wall": 1.7e9, "t": 10.0, "speed": 20.0, "paused": False}


@pytest.mark.parametrize(
    "bad",
    [
        None,
        "clock",
        [GOOD],
        42,
        {},
        {**GOOD, "speed": math.nan},
        {**GOOD, "speed": math.inf},
        {**GOOD, "speed": -20.0},
        {**GOOD, "speed": 0},
        {**GOOD, "speed": 1e300},
        {**GOOD, "speed": "20"},
        {**GOOD, "speed": True},
        {**GOOD, "t": -1.0},
        {**GOOD, "t": math.nan},
        {**GOOD, "wall": math.inf},
        {**GOOD, "version": -1},
        {**GOOD, "version": 3.5},
        {**GOOD, "version": True},
        {**GOOD, "version": "9"},
        {**GOOD, "paused": "yes"},
        {**GOOD, "paused": 1},
        {k: v for k, v in GOOD.items() if k != "paused"},
    ],
)
def test_a_malformed_state_is_dropped(bad: Any) -> None:
    c = MissionClock(ClockState(2, 1.7e9, 5.0, 10.0, True))
    before = c.state
    assert ClockState.parse(bad) is None
    assert not c.adopt(bad)
    assert c.state == before
    assert ClockState.parse(GOOD) is not None and c.adopt(GOOD)  # (the same, well formed)


def test_owner_refuses_a_pace_it_cannot_keep() -> None:
    c = MissionClock.start(20.0)
    for bad in (0.0, -1.0, math.nan, math.inf):
        with pytest.raises(ValueError, match="speed"):
            c.set(speed=bad)
    assert c.speed == 20.0 and c.state.version == 0


def test_a_follower_polls_often_while_paused_or_just_after_a_change() -> None:
    c = MissionClock.start(20.0)
    assert poll_every(c, 2.0) == 2.0
    c.set(paused=True)
    assert poll_every(c, 2.0) < 2.0
    c.changed_at -= 3600  # long ago: still paused
    assert poll_every(c, 2.0) < 2.0
    c.set(paused=False)
    assert poll_every(c, 2.0) < 2.0  # just resumed
    c.changed_at -= 3600
    assert poll_every(c, 2.0) == 2.0
    assert clock_of({"ok": True, "clock": GOOD}) == GOOD and clock_of(None) is None


@pytest.fixture
def team() -> Iterator[Team]:
    session = open_session()
    t = Team(session)
    try:
        yield t
    finally:
        t.w.close()
        session.close()  # type: ignore[no-untyped-call]


def test_the_world_does_not_change_while_paused(team: Team) -> None:
    """Every operation that moves a mineral or changes the world is answered `Paused` (not a
    refusal: the asker asks again), changes nothing and counts no refusal; reads go on; after
    the resume the same requests are carried out."""
    w = team.w
    _dig(team, "excavator-1")
    state = w.set_clock(paused=True)
    assert state["paused"] and w.status()["clock"] == state
    assert team.ask("hauler-2", "spawn", name="hauler-2")["clock"] == state  # type: ignore[index]
    before = (w.minerals_in(), w.status()["sites_found"], w.status()["scanned"], dict(w.loads))
    site = w.terrain.sites[0]
    asks = [
        ("excavator-1", "deliver", {"by": "excavator-1", "once": "d1"}),
        ("excavator-1", "drop", {"x": 1.0, "y": 1.0, "by": "excavator-1", "once": "p1"}),
        ("excavator-2", "site_set", {"id": site.id, "remaining": site.remaining - 1}),
        ("scout-1", "found", {"id": site.id, "by": "scout-1"}),
        ("scout-1", "scan", {"cell": 3, "by": "scout-1"}),
        ("hauler-1", "pick", {"id": "g1", "by": "hauler-1", "once": "k1"}),
        ("hauler-1", "handover", {"by": "hauler-1", "src": "excavator-1", "once": "h1"}),
    ]
    for who, op, args in asks:
        with pytest.raises(Paused):
            team.ask(who, op, **args)
    assert team.ask("scout-1", "ground") == [] and team.ask("scout-1", "status")["clock"] == state
    t = w.clock.now()
    after = (w.minerals_in(), w.status()["sites_found"], w.status()["scanned"], dict(w.loads))
    assert after == before and w.refused == 0 and w.clock.now() == t
    w.set_clock(paused=False)
    team.ask("scout-1", "scan", cell=3, by="scout-1")
    assert w.status()["scanned"] == before[2] + 1 and w.clock.now() > t


@pytest.mark.parametrize("seed", range(20))
def test_advance_to_leaves_the_next_event_to_come_at_the_head(seed: int) -> None:
    """An agent's clock loop waits until `env.peek()`: after `advance_to(t)` every event due
    by `t` has happened, the clock is at `t`, and the head is an event still to come (not
    the spent one simpy's `run(until)` puts back, which made every agent spin at 1 ms)."""
    rng = random.Random(seed)
    env = simpy.Environment()
    fired: list[float] = []

    def timer(at: float) -> Iterator[Any]:
        yield env.timeout(at)
        fired.append(env.now)

    times = sorted(rng.uniform(0, 100) for _ in range(rng.randint(0, 12)))
    for at in times:
        env.process(timer(at))
    t = 0.0
    for _ in range(15):
        t += rng.choice([0.0, rng.uniform(0, 1), rng.uniform(0, 20)])
        advance_to(env, t)
        assert env.now == t
        assert fired == [x for x in times if x <= t]
        assert env.peek() > t
