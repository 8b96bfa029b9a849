"""The world service's record of minerals, under lost replies and under robots that ask for
what they may not do. Agents ask again when a reply is late, and an excavator that hears
nothing from a hauler asks the world to settle the hand-over. Random interleavings of first
asks, repeated asks, settles, deliveries and refused requests must move every mineral once:
the record adds up to the total, a hand-over either happened (the hauler has the mineral,
the excavator not) or never will, and a delivery asked twice counts once."""

from __future__ import annotations

import base64
from collections.abc import Iterator

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from engine.scenario import reference_scenario
from field.link import Link
from field.transport import open_session
from field.trust import Authority, Certificate, Sealer
from field.wire import body_key, encode_json
from field.world_rules import Refused
from field.world_service import WorldService
from field.world_view import WorldView

MISSION = "mtest-once"


@pytest.fixture(scope="module")
def session() -> Iterator[object]:
    s = open_session()
    yield s
    s.close()  # type: ignore[attr-defined]


class Team:
    """A world service and signed identities for the robots that ask it."""

    def __init__(self, session: object) -> None:
        self.authority = Authority(MISSION)
        link = Link(session, self.authority.control, "test")  # type: ignore[arg-type]
        self.w = WorldService(link, reference_scenario(), 0, "nearest", 1000.0)
        self.creds = {n: self.authority.issue(n, n.rsplit("-", 1)[0]) for n in ROBOTS}
        self.sealers = {n: Sealer(c) for n, c in self.creds.items()}

    def cert(self, name: str) -> Certificate:
        return self.creds[name].certificate()

    def ask(self, who: str, op: str, /, **args: object) -> object:
        return self.w.handle(op, dict(args), self.cert(who))

    def consent(self, giver: str, hauler: str, once: str) -> str:
        """The giving excavator's signed `Transfer` to `hauler`, as the hauler forwards it."""
        args = {"msg": "transfer", "task_id": "t", "once": once}
        req = {"op": "handover", "args": args, "caller": {}}
        frame = self.sealers[giver].seal(body_key(MISSION, hauler), encode_json(req))
        return base64.b64encode(frame).decode()


ROBOTS = ("scout-1", "excavator-1", "excavator-2", "hauler-1", "hauler-2")


def _dig(team: Team, by: str) -> None:
    site = team.w.terrain.sites[0]
    team.ask(by, "site_set", id=site.id, remaining=site.remaining - 1, by=by)


def _total(w: WorldService) -> int:
    return sum(w.minerals_in().values())


# one step: (what, which of four hand-overs / deliveries)
_STEPS = st.lists(
    st.tuples(st.sampled_from(["handover", "settle", "deliver", "dig"]), st.integers(0, 3)),
    max_size=30,
)


@settings(max_examples=40, deadline=None)
@given(steps=_STEPS)
def test_each_once_id_moves_a_mineral_at_most_once(session: object, steps: list) -> None:
    team = Team(session)
    w = team.w
    try:
        total = _total(w)
        _dig(team, "excavator-1")
        taken: dict[int, bool] = {}  # what each hand-over id ended as
        delivered: set[int] = set()
        for what, i in steps:
            once = f"excavator-1@z/handover-{i}"
            loads = dict(w.loads)
            if what == "dig":
                if loads.get("excavator-1", 0) == 0:
                    _dig(team, "excavator-1")
            elif what == "handover":
                args = {"once": once, "by": "hauler-1", "src": "excavator-1", "x": 0, "y": 0}
                args["consent"] = team.consent("excavator-1", "hauler-1", once)
                can = loads.get("excavator-1", 0) > 0 and loads.get("hauler-1", 0) == 0
                try:
                    got = team.ask("hauler-1", "handover", **args)
                except Refused:
                    assert i not in taken and not can  # refused only when it cannot happen
                    continue
                assert got == taken.setdefault(i, True)  # a settled-as-not-done one is refused
            elif what == "settle":
                assert team.ask("excavator-1", "settle", once=once) == taken.setdefault(i, False)
            elif loads.get("hauler-1", 0) > 0 or i in delivered:
                team.ask("hauler-1", "deliver", once=f"hauler-1@z/deliver-{i}", by="hauler-1")
                delivered.add(i)
            assert _total(w) == total  # conserved at every step
        moved = sum(taken.values())
        assert w.loads.get("hauler-1", 0) == moved - len(delivered)
        assert w.terrain.delivered == len(delivered)
    finally:
        w.close()


def test_an_operation_without_an_id_is_carried_out_each_time(session: object) -> None:
    """The ids are what makes a repeat harmless: the same drop asked twice without one drops
    two minerals (so every agent call that moves a mineral carries one: `field.remote`)."""
    team = Team(session)
    w = team.w
    try:
        for _ in range(3):
            _dig(team, "excavator-1")
        for _ in range(2):
            team.ask("excavator-1", "drop", x=1.0, y=2.0, by="excavator-1")
        assert w.minerals_in()["ground"] == 2
        for _ in range(2):
            team.ask("excavator-1", "drop", x=1.0, y=2.0, by="excavator-1", once="excavator-1@z/d")
        assert w.minerals_in()["ground"] == 3
        assert w.loads["excavator-1"] == 0
    finally:
        w.close()


def test_robots_may_ask_only_what_concerns_them(session: object) -> None:
    """Each refusal leaves the world's record as it was (every mineral where it lay)."""
    team = Team(session)
    w = team.w
    site = w.terrain.sites[0]
    try:
        before = w.minerals_in()
        refusals = [
            ("hauler-1", "deliver", {"by": "hauler-1", "once": "hauler-1@z/1"}),  # carries none
            ("hauler-1", "deliver", {"by": "hauler-2", "once": "hauler-2@z/1"}),  # another's name
            ("scout-1", "site_set", {"id": site.id, "remaining": 0, "by": "scout-1"}),
            ("excavator-1", "site_set", {"id": site.id, "remaining": 0, "by": "excavator-1"}),
            (
                "excavator-1",
                "site_set",
                {"id": site.id, "worker": "excavator-2", "by": "excavator-1"},
            ),
            ("scout-1", "found", {"id": site.id, "by": "scout-1"}),  # never shown this site
            ("scout-1", "scan", {"cell": 10**8, "by": "scout-1"}),
            ("scout-1", "scan", {"cell": -1, "by": "scout-1"}),
            ("hauler-1", "scan", {"cell": 0, "by": "hauler-1"}),
            ("hauler-1", "spawn", {"name": "hauler-2"}),
            ("hauler-1", "settle", {"once": "excavator-1@z/handover-1"}),
            (
                "hauler-1",
                "handover",
                {"once": "excavator-1@z/h", "by": "hauler-1", "src": "excavator-1", "x": 0, "y": 0},
            ),  # nothing to take
        ]
        for name, op, args in refusals:
            with pytest.raises(Refused):
                team.ask(name, op, **args)
        assert w.minerals_in() == before and w.terrain.sites_found == 0
        _dig(team, "excavator-1")
        # a hand-over without the excavator's signed consent, or with another's
        args = {"once": "excavator-1@z/h", "by": "hauler-1", "src": "excavator-1", "x": 0, "y": 0}
        for consent in (
            "",
            team.consent("excavator-2", "hauler-1", "excavator-1@z/h"),
            team.consent("excavator-1", "hauler-2", "excavator-1@z/h"),
            team.consent("excavator-1", "hauler-1", "excavator-1@z/other"),
        ):
            with pytest.raises(Refused):
                team.ask("hauler-1", "handover", **args, consent=consent)
        assert w.loads.get("hauler-1", 0) == 0
        args["consent"] = team.consent("excavator-1", "hauler-1", "excavator-1@z/h")
        assert team.ask("hauler-1", "handover", **args) is True
        assert (w.loads["excavator-1"], w.loads["hauler-1"]) == (0, 1)
        # another excavator cannot dig a site that is worked, nor take it over
        team.ask("excavator-1", "site_set", id=site.id, worker="excavator-1", by="excavator-1")
        with pytest.raises(Refused):
            team.ask("excavator-2", "site_set", id=site.id, worker="excavator-2", by="excavator-2")
        with pytest.raises(Refused):
            team.ask(
                "excavator-2",
                "site_set",
                id=site.id,
                remaining=site.remaining - 1,
                by="excavator-2",
            )
    finally:
        w.close()


def test_a_dig_asked_again_after_a_late_reply_is_not_a_second_dig(session: object) -> None:
    """An agent asks again when a reply is late; the first ask may have been carried out.
    Under its `once` id the repeat is answered as the first, not refused as a dig of two
    (that left an excavator believing it held a mineral the world did not: a stalled run)."""
    team = Team(session)
    w = team.w
    site = w.terrain.sites[0]
    try:
        team.ask("excavator-1", "site_set", id=site.id, worker="excavator-1", by="excavator-1")
        before = site.remaining
        args = {"id": site.id, "remaining": before - 1, "by": "excavator-1"}
        first = team.ask("excavator-1", "site_set", **args, once="excavator-1@z/dig-1")
        again = team.ask("excavator-1", "site_set", **args, once="excavator-1@z/dig-1")
        assert first == again and site.remaining == before - 1
        assert w.loads["excavator-1"] == 1
    finally:
        w.close()


def test_mission_control_never_shows_an_older_view_over_a_newer_one(session: object) -> None:
    """Mission control asks for views from two threads (its poller, and a pause that shows
    the world at the pause): their answers can cross. A view read earlier arriving later must
    not put back what the newer one showed (a delivery count going 7, 6, 7)."""
    team = Team(session)
    w = team.w
    try:
        site = w.terrain.sites[0]
        views = [w.view()]
        for _ in range(3):
            team.ask("excavator-1", "site_set", id=site.id, worker="excavator-1", by="excavator-1")
            _dig(team, "excavator-1")
            team.ask("excavator-1", "drop", x=1.0, y=1.0, by="excavator-1")
            views.append(w.view())
        shown = WorldView(reference_scenario(), 0, "nearest")
        order = [2, 0, 3, 1, 3]
        took = [shown.show(views[i]) for i in order]
        assert took == [True, False, True, False, False]
        assert shown.terrain.sites[0].remaining == views[3]["picture"]["sites"][0]["remaining"]
        assert len(shown.terrain.ground) == 3
    finally:
        w.close()
