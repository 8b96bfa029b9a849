"""`regolith agent` (one robot's process) and `regolith fleet up|run` (a field mission on this
machine: the world service and one agent process per robot). docs/field.md."""

from __future__ import annotations

import json
import logging
import os
import re
import signal
import sys
import time
import zlib
from pathlib import Path
from typing import Annotated, Any

import typer

from app.cli.errors import fail
from engine.policies import POLICIES, resolve_policy
from engine.scenario import ROBOT_TYPES, ScenarioError, load_scenario, reference_scenario

_AT = re.compile(r"^(?P<what>[a-z]+(?:-\d+)?)@(?P<t>[0-9]*\.?[0-9]+)$")


def _at(option: str, values: list[str], kind: str) -> list[tuple[str, float]]:
    out = []
    for v in values:
        m = _AT.match(v.strip())
        if m is None:
            fail("fleet run", f"{option}: {v!r} must be {kind}@SECONDS")
        out.append((m["what"], float(m["t"])))
    return out


def agent(
    name: Annotated[str, typer.Option(help="This robot's name: scout-N, excavator-N, hauler-N")],
    mission: Annotated[str, typer.Option(help="The mission's id (its key space)")],
    connect: Annotated[str, typer.Option(help="Zenoh endpoint, e.g. tcp/10.0.0.5:7447")],
    credentials: Annotated[
        str,
        typer.Option(help="This robot's credential file from mission control ('-': stdin)"),
    ],
    speed: Annotated[
        float | None, typer.Option(help="Check: the mission's speed factor K", min=0.001)
    ] = None,
    listen: Annotated[str | None, typer.Option(help="Also listen on this endpoint")] = None,
    stall: Annotated[
        str | None, typer.Option(help="Fault injection: stop FOR s every ~EVERY s (FOR@EVERY)")
    ] = None,
) -> None:
    """Run one robot as this process, talking only over Zenoh."""
    from field.agent import Agent, AgentError
    from field.transport import Stalls
    from field.trust import Credential

    logging.basicConfig(level=logging.WARNING, format=f"{name}: %(message)s")
    try:
        cred = Credential.from_json(_read_credential(credentials))
        stalls = None if stall is None else Stalls.parse(stall, zlib.crc32(name.encode()))
        a = Agent(name, mission, connect, cred, speed=speed, listen=listen, stalls=stalls)
    except (AgentError, ValueError) as exc:
        fail("agent", str(exc).splitlines()[0])
    signal.signal(signal.SIGTERM, lambda *_: a.stopped.set())
    try:
        a.run()
    except KeyboardInterrupt:
        pass
    finally:
        a.close()


def _read_credential(where: str) -> str:
    """One line from standard input ('-'), else the file (at most 16 KB either way)."""
    if where == "-":
        return sys.stdin.readline(16384)
    try:
        with open(where, encoding="utf-8") as f:
            return f.read(16384)
    except OSError as exc:
        raise ValueError(f"--credentials: {where}: {exc.strerror}") from None


def _scenario(path: Path | None) -> Any:
    try:
        return load_scenario(path) if path is not None else reference_scenario()
    except ScenarioError as exc:
        fail("fleet run", str(exc))


def fleet_run(
    policy: Annotated[str, typer.Option(help="Policy number or name")],
    seed: Annotated[int, typer.Option(min=0)] = 0,
    scenario: Annotated[Path | None, typer.Option(help="Scenario file; default: reference")] = None,
    speed: Annotated[float, typer.Option(help="Simulated seconds per wall second", min=1)] = 20.0,
    kill: Annotated[list[str], typer.Option(help="SIGKILL an agent at T s: NAME@T")] = [],  # noqa: B006
    add: Annotated[list[str], typer.Option(help="Start a new TYPE agent at T s")] = [],  # noqa: B006
    restart: Annotated[list[str], typer.Option(help="Start NAME again at T s")] = [],  # noqa: B006
    as_json: Annotated[bool, typer.Option("--json", help="Print one JSON object")] = False,
) -> None:
    """Run one field mission end to end: world service, one process per robot, the faults."""
    from field.fleet import run_fleet

    _exit_on_sigterm()
    try:
        pol = resolve_policy(policy)
    except ValueError as exc:
        fail("fleet run", f"--policy: {exc}")
    if not POLICIES[pol].decentralized:
        fail("fleet run", f"--policy: {pol} is centralized; field mode runs decentralized ones")
    adds = _at("--add", add, "TYPE")
    for rtype, _t in adds:
        if rtype not in ROBOT_TYPES:
            fail("fleet run", f"--add: {rtype!r} must be one of {', '.join(ROBOT_TYPES)}")
    scen = _scenario(scenario)
    try:
        out = run_fleet(
            scen,
            seed,
            pol,
            speed,
            _at("--kill", kill, "NAME"),
            adds,
            _at("--restart", restart, "NAME"),
        )
    except ValueError as exc:
        fail("fleet run", str(exc))
    if not as_json:
        out.pop("auction_records", None)
    typer.echo(json.dumps(out) if as_json else json.dumps(out, indent=1))
    if not out["completed"]:
        raise typer.Exit(1)


def fleet_up(
    policy: Annotated[str, typer.Option(help="Policy number or name")] = "nearest",
    seed: Annotated[int, typer.Option(min=0)] = 0,
    scenario: Annotated[Path | None, typer.Option(help="Scenario file; default: reference")] = None,
    speed: Annotated[float, typer.Option(min=1)] = 20.0,
    port: Annotated[int, typer.Option(help="The endpoint's TCP port", min=1, max=65535)] = 7447,
    host: Annotated[str, typer.Option(help="The address to listen on")] = "127.0.0.1",
    issue: Annotated[
        list[str], typer.Option(help="Write a credential for a robot elsewhere: NAME")
    ] = [],  # noqa: B006
    credentials_dir: Annotated[
        Path, typer.Option(help="Where --issue writes NAME.cred (mode 0600)")
    ] = Path("credentials"),
) -> None:
    """Start the world service and one agent per robot here, until the mission completes."""
    from field.fleet import Fleet
    from field.wire import check_segment

    for name in issue:
        try:
            rtype = check_segment(name, "--issue").rsplit("-", 1)[0]
        except ValueError as exc:
            fail("fleet up", str(exc))
        if rtype not in ROBOT_TYPES:
            fail("fleet up", f"--issue: {name!r} must be scout-N, excavator-N or hauler-N")

    _exit_on_sigterm()
    scen = _scenario(scenario)
    try:
        fleet = Fleet(scen, seed, resolve_policy(policy), speed, port=port, listen_host=host)
    except ValueError as exc:
        fail("fleet up", str(exc))
    with fleet:
        typer.echo(f"mission {fleet.mission} on {fleet.endpoint} at {speed:g}×", err=True)
        for name in issue:
            path = _write_credential(credentials_dir, name, fleet.credential(name).to_json())
            typer.echo(f"credential for {name}: {path}", err=True)
        fleet.up()
        try:
            while not fleet.world.field.finished.triggered:
                time.sleep(0.2)
        except KeyboardInterrupt:
            sys.exit(130)
        typer.echo(json.dumps(fleet.world.status()))


def _write_credential(folder: Path, name: str, text: str) -> Path:
    """NAME.cred, readable by this user only (it lets its holder speak as that robot)."""
    folder.mkdir(parents=True, exist_ok=True)
    path = folder / f"{name}.cred"
    fd = os.open(path, os.O_WRONLY | os.O_CREAT | os.O_TRUNC, 0o600)
    with os.fdopen(fd, "w", encoding="utf-8") as f:
        f.write(text + "\n")
    return path


def _exit_on_sigterm() -> None:
    """SIGTERM unwinds like Ctrl-C, so the fleet's `close` reaps every agent it started."""
    signal.signal(signal.SIGTERM, lambda *_: sys.exit(143))


def register(cli: typer.Typer) -> None:
    cli.command(name="agent")(agent)
    fleet = typer.Typer(
        help="Field missions on this machine (docs/field.md).", no_args_is_help=True
    )
    fleet.command(name="run")(fleet_run)
    fleet.command(name="up")(fleet_up)
    cli.add_typer(fleet, name="fleet")
