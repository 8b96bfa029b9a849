"""The collector pause of headless runs: restored as it was, however holders nest or overlap."""

from __future__ import annotations

import gc
import threading

import pytest

from engine import reference_scenario, run_mission
from engine.collector import collector_paused
from engine.errors import CommandRejected


def test_nested_holders_restore_the_collector_only_when_the_last_leaves() -> None:
    assert gc.isenabled()
    with collector_paused():
        assert not gc.isenabled()
        with collector_paused():
            assert not gc.isenabled()
        assert not gc.isenabled()  # the outer holder still runs
    assert gc.isenabled()


def test_a_collector_switched_off_by_the_caller_stays_off() -> None:
    gc.disable()
    try:
        with collector_paused():
            pass
        assert not gc.isenabled()
    finally:
        gc.enable()


def test_overlapping_threads_leave_it_on_once_all_are_done() -> None:
    entered, release = threading.Barrier(3), threading.Event()

    def hold() -> None:
        with collector_paused():
            entered.wait()
            release.wait()

    threads = [threading.Thread(target=hold) for _ in range(2)]
    for t in threads:
        t.start()
    entered.wait()
    assert not gc.isenabled()
    release.set()
    for t in threads:
        t.join()
    assert gc.isenabled()


def test_a_headless_mission_leaves_the_collector_on_even_when_it_raises() -> None:
    metrics = run_mission(reference_scenario(), 0, "fcfs", planner="straight")
    assert metrics["completed"]
    assert gc.isenabled()
    with pytest.raises(CommandRejected):
        run_mission(reference_scenario(), 0, "fcfs", [{"t": 1.0, "kind": "nonsense"}])
    assert gc.isenabled()
