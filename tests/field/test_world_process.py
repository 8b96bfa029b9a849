"""The world's process starts its team before it answers mission control
(field/world_process.py).

Mission control attaches as soon as the world's process answers, and an operator may add or
restart a robot at once. On a loaded machine (two CPU hogs beside the fleet tests) an `add`
was answered while the team was still being started: it was named `hauler-1`, the team's own
`hauler-1` was started again after it, and the server's process budget, counting the few
agents up by its first view, let a fourteenth process in under a budget of thirteen. The
agents here are `sleep` processes started slowly, so the roster is reliably under way when
the request comes."""

from __future__ import annotations

import subprocess
import threading
import time
from pathlib import Path

import pytest

from engine.scenario import reference_scenario
from field.fleet import Fleet, free_port
from field.trust import Authority
from field.world_process import Settings, WorldProcess


def test_a_request_during_the_teams_start_waits_for_the_whole_team(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    started: list[str] = []
    under_way = threading.Event()

    def slow_start(fleet: Fleet, name: str) -> tuple[subprocess.Popen[bytes], int]:
        started.append(name)
        if len(started) == 3:
            under_way.set()
        time.sleep(0.05)
        return subprocess.Popen(["sleep", "600"], start_new_session=True), 1

    monkeypatch.setattr(Fleet, "_start", slow_start)
    authority = Authority("mteamstart")
    settings = Settings(
        authority.mission,
        authority.secret,
        reference_scenario(),
        0,
        "nearest",
        50.0,
        free_port(),
        tmp_path,
    )
    world = WorldProcess(settings)
    try:
        team = threading.Thread(target=world.start_team)
        team.start()
        assert under_way.wait(30)
        with world._lock:  # as a request from mission control takes it
            added = world.handle("add", {"type": "hauler"})
            view = world.handle("agents", {})
        team.join(30)
        roster = list(world.fleet.world.roster)
        assert added == "hauler-7"
        assert sorted(started) == sorted(["operator", *roster, "hauler-7"])  # each once
        assert started[-1] == "hauler-7"  # after the whole team
        # what mission control's first view says: the whole team running
        assert sorted(p["name"] for p in view["procs"] if p["alive"]) == sorted(
            [*roster, "hauler-7"]
        )
        assert view["operator"]["alive"]
    finally:
        world.close()
