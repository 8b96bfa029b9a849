"""`regolith run`: one mission headless, with optional faults, as a summary or one JSON object."""

from __future__ import annotations

import json
import math
import re
import time
from pathlib import Path
from typing import Annotated, Any

import typer

from engine import (
    EngineError,
    ScenarioError,
    load_scenario,
    policy_help,
    reference_scenario,
    resolve_policy,
    run_mission,
)
from engine.scenario import Scenario

_AT = re.compile(r"^(?P<what>[a-z]+(?:-\d+)?)@(?P<t>[0-9]*\.?[0-9]+)(?::(?P<mode>[a-z]+))?$")


def fail_usage(message: str) -> typer.Exit:
    """Print a one-line error and leave with exit code 2 (bad usage), never a traceback."""
    typer.echo(f"error: {message}", err=True)
    return typer.Exit(code=2)


def build_scenario(scenario: Path | None, scale: int) -> Scenario:
    if scale < 1:
        raise fail_usage("--scale: must be a whole number >= 1")
    try:
        base = load_scenario(scenario) if scenario is not None else reference_scenario()
        return base.scaled(scale)
    except ScenarioError as exc:
        raise fail_usage(str(exc)) from None


def parse_actions(fail: list[str], enable: list[str], add: list[str]) -> list[dict[str, Any]]:
    """`NAME@T[:graceful|abrupt]`, `NAME@T` and `TYPE@T` into engine actions."""
    actions: list[dict[str, Any]] = []
    for flag, values in (("--fail", fail), ("--enable", enable), ("--add", add)):
        for v in values:
            m = _AT.match(v.strip())
            if m is None:
                raise fail_usage(f"{flag} {v!r}: expected NAME@SECONDS (e.g. hauler-2@600)")
            what, t, mode = m["what"], float(m["t"]), m["mode"]
            if flag == "--fail":
                mode = mode or "abrupt"
                if mode not in ("graceful", "abrupt"):
                    raise fail_usage(f"--fail {v!r}: mode must be graceful or abrupt")
                actions.append(
                    {"t": t, "kind": "disable_robot", "args": {"name": what, "mode": mode}}
                )
            elif mode is not None:
                raise fail_usage(f"{flag} {v!r}: takes no ':mode'")
            elif flag == "--enable":
                actions.append({"t": t, "kind": "enable_robot", "args": {"name": what}})
            else:
                if what not in ("scout", "excavator", "hauler"):
                    raise fail_usage(f"--add {v!r}: type must be scout, excavator or hauler")
                actions.append({"t": t, "kind": "add_robot", "args": {"type": what}})
    actions.sort(key=lambda a: a["t"])
    return actions


def summary(m: dict[str, Any]) -> str:
    ms = m["makespan_s"]
    lines = [
        f"policy {m['policy']}, seed {m['seed']}, scenario {m['scenario']}: {m['status']}",
        f"  makespan        {ms:.1f} s" if ms is not None else "  makespan        -",
        f"  sites found     {m['sites_found']}/{m['sites_total']}",
        f"  minerals        {m['minerals_delivered']}/{m['minerals_total']} delivered",
        "  distance (m)    " + ", ".join(f"{k} {v:.0f}" for k, v in m["distance"].items()),
    ]
    for kind, st in m["auction_open_s"].items():
        if st["count"]:
            lines.append(
                f"  open time {kind:<17} n={st['count']} mean {st['mean']:.1f} s "
                f"p50 {st['p50']:.1f} s max {st['max']:.1f} s"
            )
    lines.append(
        f"  auctions {m['auctions']}, bids {m['bids']}, declines {m['declines']}, "
        f"re-announcements {m['reannouncements']}, messages {m['messages']}"
    )
    if m["failures"] or m["messages_lost"]:
        lines.append(
            f"  failures {m['failures']}, re-auctions {m['reauctions']}, minerals dropped "
            f"{m['minerals_dropped']} / recovered {m['minerals_recovered']}, "
            f"messages lost {m['messages_lost']}"
        )
    lines.append(f"  wall time       {m['wall_s']:.3f} s")
    return "\n".join(lines)


def _finite(v: Any) -> Any:
    if isinstance(v, float) and not math.isfinite(v):
        return None
    if isinstance(v, dict):
        return {k: _finite(x) for k, x in v.items()}
    return v


def run(
    policy: Annotated[str, typer.Option(help=f"Policy number or name: {policy_help()}")],
    seed: Annotated[int, typer.Option(min=0, help="Seed of the world and every random draw")],
    scenario: Annotated[
        Path | None, typer.Option(help="Scenario file (.toml or .json); default: reference")
    ] = None,
    scale: Annotated[int, typer.Option(help="K× team, sites, minerals; √K× area side")] = 1,
    json_out: Annotated[bool, typer.Option("--json", help="Print one JSON object")] = False,
    loss: Annotated[float | None, typer.Option(help="Bus loss probability 0..0.9")] = None,
    latency: Annotated[float | None, typer.Option(help="Bus latency (s)")] = None,
    jitter: Annotated[float | None, typer.Option(help="Bus latency jitter (s)")] = None,
    fail: Annotated[list[str], typer.Option(help="NAME@T[:graceful|abrupt], repeatable")] = [],  # noqa: B006 - typer needs a literal default
    enable: Annotated[list[str], typer.Option(help="NAME@T, repeatable")] = [],  # noqa: B006
    add: Annotated[list[str], typer.Option(help="TYPE@T, repeatable")] = [],  # noqa: B006
) -> None:
    """Run one mission headless and print its figures."""
    try:
        policy_name = resolve_policy(policy)
    except ValueError as exc:
        raise fail_usage(str(exc)) from None
    scen = build_scenario(scenario, scale)
    bus = {
        k: v
        for k, v in (("loss", loss), ("latency_s", latency), ("jitter_s", jitter))
        if v is not None
    }
    if bus:
        try:
            from engine import parse_scenario

            data = scen.model_dump()
            data["bus"] = {**data["bus"], **bus}
            scen = parse_scenario(data)
        except ScenarioError as exc:
            raise fail_usage(str(exc).replace("bus.", "--").replace("_s:", ":")) from None
    actions = parse_actions(fail, enable, add)
    t0 = time.perf_counter()
    try:
        metrics = run_mission(scen, seed, policy_name, actions)
    except (EngineError, ScenarioError) as exc:
        # an action the mission refuses (unknown robot, bad time …), or a world the scenario
        # cannot make for this seed (sites that do not fit): the user's input, not a bug
        raise fail_usage(str(exc)) from None
    # the machine's time, reported beside the mission's figures (never part of them)
    metrics["wall_s"] = time.perf_counter() - t0
    if json_out:
        typer.echo(json.dumps(_finite(metrics), sort_keys=True))
    else:
        typer.echo(summary(metrics))
