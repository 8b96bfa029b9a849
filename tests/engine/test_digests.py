"""Every pinned event-log digest up to scale 10 is what the engine gives today
(`tests/engine/digests.py` says which runs and how to pin them again)."""

from __future__ import annotations

import pytest

from tests.engine.digests import Case, cases, digest, pinned

PINNED = pinned()


@pytest.mark.parametrize("case", cases(slow=False), ids=lambda c: c.key)
def test_event_log_is_as_pinned(case: Case) -> None:
    assert digest(case) == PINNED[case.key]


def test_every_case_is_pinned() -> None:
    """A new policy adds cases: pin them (`python -m tests.engine.digests --write`)."""
    assert {c.key for c in cases(slow=True)} <= set(PINNED)
