"""The world service's record of minerals under lost replies: agents ask again when a reply
is late, and an excavator that hears nothing from a hauler asks the world to settle the
hand-over. Random interleavings of first asks, repeated asks and settles must move every
mineral once: the record adds up to the total, a hand-over either happened (the hauler has
the mineral, the excavator not) or never will, and a delivery asked twice counts once."""

from __future__ import annotations

from collections.abc import Iterator

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from engine.scenario import reference_scenario
from field.transport import open_session
from field.world_service import WorldService


@pytest.fixture(scope="module")
def session() -> Iterator[object]:
    s = open_session()
    yield s
    s.close()  # type: ignore[attr-defined]


def _world(session: object) -> WorldService:
    return WorldService(session, "mtest-once", reference_scenario(), 0, "nearest", 1000.0)


def _dig(w: WorldService, by: str) -> None:
    site = w.field.sites[0]
    w.handle("site_set", {"id": site.id, "remaining": site.remaining - 1, "by": by})


def _total(w: WorldService) -> int:
    return sum(w.minerals_in().values())


# one step: (what, which of four hand-overs / deliveries, how)
_STEPS = st.lists(
    st.tuples(st.sampled_from(["handover", "settle", "deliver"]), st.integers(0, 3)),
    max_size=30,
)


@settings(max_examples=40, deadline=None)
@given(steps=_STEPS)
def test_each_once_id_moves_a_mineral_at_most_once(session: object, steps: list) -> None:
    w = _world(session)
    try:
        total = _total(w)
        for _ in range(4):
            _dig(w, "excavator-1")
        assert w.loads["excavator-1"] == 4
        taken: dict[int, bool] = {}  # what each hand-over id ended as
        delivered: set[int] = set()
        for what, i in steps:
            once = f"excavator-1/handover-{i}"
            if what == "handover":
                args = {"once": once, "by": "hauler-1", "src": "excavator-1", "x": 0, "y": 0}
                got = w.handle("handover", args)
                assert got == taken.setdefault(i, True)  # a settled-as-not-done one is refused
            elif what == "settle":
                assert w.handle("settle", {"once": once}) == taken.setdefault(i, False)
            elif w.loads.get("hauler-1", 0) > 0 or i in delivered:
                w.handle("deliver", {"once": f"hauler-1/deliver-{i}", "by": "hauler-1"})
                delivered.add(i)
            assert _total(w) == total  # conserved at every step
        moved = sum(taken.values())
        assert w.loads["excavator-1"] == 4 - moved
        assert w.loads.get("hauler-1", 0) == moved - len(delivered)
        assert w.field.delivered == len(delivered)
    finally:
        w.close()


def test_an_operation_without_an_id_is_carried_out_each_time(session: object) -> None:
    """The ids are what makes a repeat harmless: the same drop asked twice without one drops
    two minerals (so every agent call that moves a mineral carries one: `field.remote`)."""
    w = _world(session)
    try:
        for _ in range(3):
            _dig(w, "hauler-1")
        for _ in range(2):
            w.handle("drop", {"x": 1.0, "y": 2.0, "by": "hauler-1"})
        assert w.minerals_in()["ground"] == 2
        for _ in range(2):
            w.handle("drop", {"x": 1.0, "y": 2.0, "by": "hauler-1", "once": "d-1"})
        assert w.minerals_in()["ground"] == 3
        assert w.loads["hauler-1"] == 0
    finally:
        w.close()
