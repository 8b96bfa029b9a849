"""The progress wait: slow work passes, stuck work fails (with what it waited for)."""

from __future__ import annotations

import itertools

import pytest

from tests.progress import wait_progress


class Clock:
    """A fake clock (the helper reads time.monotonic): each sleep moves it on."""

    def __init__(self) -> None:
        self.now = 0.0

    def sleep(self, s: float) -> None:
        self.now += s


def test_slow_work_that_moves_passes_past_any_fixed_deadline(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    clock = Clock()
    monkeypatch.setattr("tests.progress.time.monotonic", lambda: clock.now)
    steps = itertools.count()
    done_at = 1000  # polls; 1,000 × 1 s is far past the 10 s stall limit, but it moves
    n = 0

    def probe() -> int | None:
        nonlocal n
        n = next(steps)
        return n if n >= done_at else None

    got = wait_progress(probe, lambda: n, "the work", stall_s=10, every=1.0, sleep=clock.sleep)
    assert got == done_at and clock.now >= 999


def test_stuck_work_fails_after_the_stall_limit(monkeypatch: pytest.MonkeyPatch) -> None:
    clock = Clock()
    monkeypatch.setattr("tests.progress.time.monotonic", lambda: clock.now)
    with pytest.raises(AssertionError, match=r"no progress for 10 s waiting for the sweep"):
        wait_progress(lambda: None, lambda: 3, "the sweep", stall_s=10, every=1, sleep=clock.sleep)
    assert 10 < clock.now < 13
