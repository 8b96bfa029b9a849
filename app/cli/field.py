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
from app.cli.progress import ProgressLine
from engine.policies import resolve_policy
from engine.scenario import ROBOT_TYPES, ScenarioError, load_scenario, reference_scenario
from engine.team import robot_type
from field.refusals import FieldRefusal, check_field

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
    name: Annotated[
        str,
        typer.Option(metavar="NAME", help="This robot's name: scout-N, excavator-N, hauler-N"),
    ],
    mission: Annotated[str, typer.Option(metavar="ID", help="The mission's id (its key space)")],
    connect: Annotated[
        str, typer.Option(metavar="ENDPOINT", help="Zenoh endpoint, e.g. tcp/10.0.0.5:7447")
    ],
    credentials: Annotated[
        str,
        typer.Option(
            metavar="FILE", help="This robot's credential file from mission control ('-': stdin)"
        ),
    ],
    speed: Annotated[
        float | None,
        typer.Option(metavar="K", help="Check: the mission's speed factor K", min=0.001),
    ] = None,
    listen: Annotated[
        str | None, typer.Option(metavar="ENDPOINT", help="Also listen on this endpoint")
    ] = None,
    stall: Annotated[
        str | None,
        typer.Option(metavar="FOR@EVERY", help="Fault injection: stop FOR s every ~EVERY s"),
    ] = None,
    journal: Annotated[
        Path | None,
        typer.Option(
            metavar="DIR", help="Keep what this robot reports here too (default: memory only)"
        ),
    ] = None,
) -> None:
    """Run one robot as this process, talking only over Zenoh."""
    from field.agent import Agent
    from field.asking import AgentError
    from field.transport import Stalls
    from field.trust import Credential

    logging.basicConfig(level=logging.WARNING, format=f"{name}: %(message)s")
    try:
        cred = Credential.from_json(_read_credential(credentials))
        stalls = None if stall is None else Stalls.parse(stall, zlib.crc32(name.encode()))
        a = Agent(
            name, mission, connect, cred, speed=speed, listen=listen, stalls=stalls, journal=journal
        )
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


Seed = Annotated[
    int, typer.Option(metavar="N", min=0, help="Seed of the world and every random draw")
]
ScenarioFile = Annotated[
    Path | None,
    typer.Option(metavar="FILE", help="Scenario file (.toml or .json); default: reference"),
]


def fleet_run(
    policy: Annotated[
        str, typer.Option(metavar="POLICY", help="Policy number or name (decentralized)")
    ],
    seed: Seed = 0,
    scenario: ScenarioFile = None,
    speed: Annotated[
        float, typer.Option(metavar="K", help="Simulated seconds per wall second", min=1)
    ] = 20.0,
    kill: Annotated[
        list[str], typer.Option(metavar="NAME@T", help="SIGKILL an agent at T s; repeat")
    ] = [],  # noqa: B006
    add: Annotated[
        list[str],
        typer.Option(metavar="TYPE@T", help="Start a new scout|excavator|hauler at T s; repeat"),
    ] = [],  # noqa: B006
    restart: Annotated[
        list[str], typer.Option(metavar="NAME@T", help="Start NAME again at T s; repeat")
    ] = [],  # noqa: B006
    as_json: Annotated[bool, typer.Option("--json", help="Print one JSON object")] = False,
) -> None:
    """Run one field mission end to end: world service, one process per robot, the faults.

    Prints a summary (or, with --json, one JSON object, the auctions included). Exit code 0
    when the mission completed, 1 otherwise, 2 for a bad argument. On a terminal, stderr
    shows the progress (simulated time, minerals, sites) while it runs."""
    from field.fleet_run import run_fleet

    _exit_on_sigterm()
    try:
        pol = resolve_policy(policy)
    except ValueError as exc:
        fail("fleet run", f"--policy: {exc}")
    try:
        check_field(policy=pol)
    except FieldRefusal as exc:
        fail("fleet run", f"--policy: {exc.reason}")
    adds = _at("--add", add, "TYPE")
    for rtype, _t in adds:
        if rtype not in ROBOT_TYPES:
            fail("fleet run", f"--add: {rtype!r} must be one of {', '.join(ROBOT_TYPES)}")
    scen = _scenario(scenario)
    line = ProgressLine(sys.stderr, every_s=0) if sys.stderr.isatty() and not as_json else None

    def show(st: dict[str, Any]) -> None:
        if line is not None:
            line.write(
                st["t"], st["delivered"], st["minerals_total"], st["sites_found"], st["sites_total"]
            )

    try:
        out = run_fleet(
            scen,
            seed,
            pol,
            speed,
            _at("--kill", kill, "NAME"),
            adds,
            _at("--restart", restart, "NAME"),
            progress=show,
        )
    except ValueError as exc:
        fail("fleet run", str(exc))
    finally:
        if line is not None:
            line.clear()
    typer.echo(json.dumps(out) if as_json else fleet_summary(out))
    if not out["completed"]:
        raise typer.Exit(1)


def _dropped(r: dict[str, Any] | None) -> str:
    """What the mission's processes dropped from the bus or refused (docs/field.md, Trust)."""
    if not r:
        return "0"
    refused = r.get("world_refused", 0)
    reasons = ", ".join(f"{k} {n}" for k, n in r["by_reason"].items()) or "none"
    return f"{r['total'] + refused} (mission control: {reasons}; world refused {refused})"


def fleet_summary(m: dict[str, Any]) -> str:
    """A field run's figures for a person, in `regolith run`'s layout."""
    ms = m["makespan_s"]
    procs = m.get("processes", [])
    killed = sum(1 for p in procs if p.get("killed_at") is not None)
    tr = m.get("transport", {})
    lines = [
        f"policy {m['policy']}, seed {m['seed']}, scenario {m['scenario']}, field mode at "
        f"{tr.get('speed', 0):g}x: {m['status']}",
        f"  makespan        {ms:.1f} s" if ms is not None else "  makespan        -",
        f"  simulated time  {m['sim_time_s']:.1f} s",
        f"  sites found     {m['sites_found']}/{m['sites_total']}",
        f"  minerals        {m['minerals_delivered']}/{m['minerals_total']} delivered",
        f"  auctions {m['auctions']}, bids {m['bids']}, re-auctions {m['reauctions']}, "
        f"re-announcements {m['reannouncements']}",
        f"  messages        {m['messages']} over Zenoh",
        f"  dropped         {_dropped(tr.get('rejections'))}",
        f"  processes       {len(procs)} agents started, {killed} killed",
    ]
    for a in m.get("actions", []):
        lines.append(f"  at {a['t']:8.1f} s   {a['kind']} {a['robot']}")
    lines.append(f"  wall time       {m['wall_s']:.1f} s")
    return "\n".join(lines)


def fleet_up(
    policy: Annotated[
        str, typer.Option(metavar="POLICY", help="Policy number or name (decentralized)")
    ] = "nearest",
    seed: Seed = 0,
    scenario: ScenarioFile = None,
    speed: Annotated[
        float, typer.Option(metavar="K", min=1, help="Simulated seconds per wall second")
    ] = 20.0,
    port: Annotated[
        int, typer.Option(metavar="PORT", help="The endpoint's TCP port", min=1, max=65535)
    ] = 7447,
    host: Annotated[
        str, typer.Option(metavar="HOST", help="The address to listen on")
    ] = "127.0.0.1",
    issue: Annotated[
        list[str],
        typer.Option(
            metavar="NAME", help="Write a credential for a robot that joins from elsewhere"
        ),
    ] = [],  # noqa: B006
    credentials_dir: Annotated[
        Path, typer.Option(metavar="DIR", help="Where --issue writes NAME.cred (mode 0600)")
    ] = Path("credentials"),
) -> None:
    """Start the world service and one agent per robot here, until the mission completes."""
    from field.fleet import Fleet
    from field.wire import check_segment

    for name in issue:
        try:
            rtype = robot_type(check_segment(name, "--issue"))
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
            while not fleet.world.terrain.finished.triggered:
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
