"""`regolith fleet run` and `regolith agent`: bad input is one line and exit code 2, and no
agent process is started for it."""

from __future__ import annotations

import subprocess
from pathlib import Path

import pytest
from typer.testing import CliRunner

from app.cli import cli

SCENARIOS = Path(__file__).resolve().parents[2] / "scenarios"


@pytest.mark.parametrize(
    ("args", "message"),
    [
        (["fleet", "run", "--policy", "central-greedy"], "--policy: central-greedy is centralized"),
        (["fleet", "run", "--policy", "9"], "--policy"),
        (["fleet", "run", "--policy", "3", "--kill", "hauler-2"], "--kill: 'hauler-2' must be"),
        (["fleet", "run", "--policy", "3", "--add", "rover@5"], "--add: 'rover' must be one of"),
        (["fleet", "run", "--policy", "3", "--speed", "0.5"], "--speed"),
    ],
)
def test_fleet_run_refuses_bad_input(args: list[str], message: str) -> None:
    res = CliRunner().invoke(cli, args)
    assert res.exit_code == 2, res.output
    assert message in res.output
    assert "Traceback" not in res.output and len(res.output.strip().splitlines()) == 1


def test_agent_refuses_a_bad_name_and_a_missing_mission() -> None:
    from field.trust import Authority

    cred = Authority("m").issue("hauler-1", "hauler").to_json()
    base = ["agent", "--mission", "m", "--connect", "tcp/127.0.0.1:1", "--credentials", "-"]
    res = CliRunner().invoke(cli, [*base, "--name", "hauler/1"], input=cred)
    assert res.exit_code == 2 and "name: 'hauler/1' must be" in res.output


@pytest.mark.parametrize(
    ("given", "message"),
    [
        ("not json", "credentials: "),
        ("hauler-2", "credentials: issued to 'hauler-1' of mission 'm', not 'hauler-2'"),
        ("/nonexistent/hauler.cred", "--credentials: /nonexistent/hauler.cred: No such file"),
    ],
)
def test_an_agent_without_its_own_credential_is_refused(given: str, message: str) -> None:
    """An agent speaks only with the credential mission control issued to that name: none,
    another robot's, or an unreadable file is a one-line error, exit 2, nothing started."""
    from field.trust import Authority

    cred = Authority("m").issue("hauler-1", "hauler").to_json()
    base = ["agent", "--mission", "m", "--connect", "tcp/127.0.0.1:1"]
    if given.startswith("/"):
        res = CliRunner().invoke(cli, [*base, "--name", "hauler-1", "--credentials", given])
    else:
        name = given if given.startswith("hauler") else "hauler-1"
        text = cred if given.startswith("hauler") else given
        res = CliRunner().invoke(cli, [*base, "--name", name, "--credentials", "-"], input=text)
    assert res.exit_code == 2, res.output
    assert message in res.output and len(res.output.strip().splitlines()) == 1


@pytest.mark.parametrize(
    ("policy", "speed", "paused", "loc"),
    [
        ("nearest", "max", False, "speed"),
        ("nearest", 0.5, False, "speed"),
        ("nearest", 0, True, "speed"),
        ("nearest", float("nan"), False, "speed"),
        ("central-greedy", 20.0, False, "policy"),
        ("offline", 20.0, False, "policy"),
    ],
)
def test_the_api_refuses_a_field_mission_it_cannot_run(
    policy: str, speed: float | str, paused: bool, loc: str
) -> None:
    """`POST /api/missions` with `field: true` answers 422 naming the field, before any
    process starts."""
    from app.services.errors import Invalid
    from app.services.field_rules import check_field
    from engine.scenario import reference_scenario

    with pytest.raises(Invalid) as err:
        check_field(reference_scenario(), policy, speed, paused)  # type: ignore[arg-type]
    assert err.value.loc == (loc,) and err.value.status_code == 422
    check_field(reference_scenario(), "nearest", 20.0, False)  # what it accepts
    check_field(reference_scenario(), "nearest", 20.0, True)  # paused, too (field/clock.py)


@pytest.mark.parametrize("option", ["energy", "docks", "uncertainty", "radio"])
def test_a_realism_option_is_refused_naming_it(option: str) -> None:
    """Field mode runs none of the realism options (its agents build their robots without
    them): the API answers 422 naming the option, before any process starts."""
    from app.services.errors import Invalid
    from app.services.field_rules import check_field
    from engine.scenario import load_scenario

    scenario = load_scenario(SCENARIOS / "realism" / f"{option}.toml")
    with pytest.raises(Invalid) as err:
        check_field(scenario, "nearest", 20.0, False)
    assert err.value.loc == ("scenario", option) and err.value.status_code == 422
    assert str(err.value).startswith(f"scenario.{option}: field mode runs without")


def test_fleet_run_refuses_uncertain_work() -> None:
    res = CliRunner().invoke(
        cli,
        [
            "fleet",
            "run",
            "--policy",
            "nearest",
            "--scenario",
            str(SCENARIOS / "realism" / "uncertainty.toml"),
        ],
    )
    assert res.exit_code == 2, res.output
    assert "scenario.uncertainty: field mode runs without the realism options" in res.output
    assert "Traceback" not in res.output and len(res.output.strip().splitlines()) == 1


@pytest.mark.slow
def test_an_agent_leaves_when_mission_control_dies_not_while_it_is_slow() -> None:
    """A world service that does not answer for longer than the old 10 s status poll allowed
    keeps its agents; a closed session loses them, even while a stranger on the bus declares
    mission control's liveliness token (an agent stays only on mission control's signed word)."""
    import time

    from engine.scenario import reference_scenario
    from field.agent import ABSENCE_S
    from field.fleet import Fleet
    from field.transport import open_session
    from field.wire import presence_key

    fleet = Fleet(reference_scenario(), 0, "nearest", 20.0)
    try:
        proc = fleet.spawn("scout-1").popen
        deadline = time.monotonic() + 60.0
        while "scout-1" not in fleet.world.spawned and time.monotonic() < deadline:
            time.sleep(0.1)
        time.sleep(1.0)  # (joined: its spawn was answered)
        fleet.world._lock.acquire()  # every world query waits: slow, not gone
        try:
            with pytest.raises(subprocess.TimeoutExpired):
                proc.wait(timeout=12.0)
        finally:
            fleet.world._lock.release()
        stranger = open_session(connect=fleet.endpoint)
        token = stranger.liveliness().declare_token(presence_key(fleet.mission))
        time.sleep(2.0)  # (the stranger meets the agent: peers connect to one another)
        fleet.session.close()  # mission control's session ends: gone (for ABSENCE_S and more)
        try:
            assert proc.wait(timeout=ABSENCE_S + 60.0) is not None
        finally:
            token.undeclare()
            stranger.close()
    finally:
        fleet.close()
