"""`regolith run`: one mission headless, with optional faults, as a summary or one JSON object."""

from __future__ import annotations

import json
import math
import re
import sys
import time
from pathlib import Path
from typing import Annotated, Any

import typer

from app.cli.errors import USAGE_EXIT
from app.cli.progress import ProgressLine, run_with_progress
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

NOT_COMPLETED_EXIT = 1  # the mission ended without completing (timeout, stalled)

_AT = re.compile(r"^(?P<what>[a-z]+(?:-\d+)?)@(?P<t>[0-9]*\.?[0-9]+)(?::(?P<mode>[a-z]+))?$")


def fail_usage(message: str) -> typer.Exit:
    """Print a one-line error (app/cli/errors.py); raise what this returns: exit code 2."""
    typer.echo(f"regolith run: {message}", err=True)
    return typer.Exit(code=USAGE_EXIT)


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
        "  lower bound     " + _bound_text(m),
    ]
    for kind, st in m["auction_open_s"].items():
        if st["count"]:
            lines.append(
                f"  open time {kind:<17} n={st['count']} mean {st['mean']:.1f} s "
                f"p50 {st['p50']:.1f} s max {st['max']:.1f} s"
            )
    lines.append(
        f"  auctions {m['auctions']}, bids {m['bids']}, declines {m['declines']}, "
        f"re-announcements {m['reannouncements']}"
    )
    # `messages` counts broadcasts, `messages_lost` the copies a lossy bus did not deliver
    # (a broadcast goes to every other robot, each copy lost on its own): say so
    lost = f"; {m['messages_lost']} copies lost (one per robot that missed one)"
    lines.append(f"  messages        {m['messages']} broadcast{lost if m['messages_lost'] else ''}")
    if m["failures"] or m["minerals_dropped"]:
        lines.append(
            f"  failures {m['failures']}, re-auctions {m['reauctions']}, minerals dropped "
            f"{m['minerals_dropped']} / recovered {m['minerals_recovered']}"
        )
    lines.extend(_realism_lines(m))
    lines.append(f"  wall time       {m['wall_s']:.3f} s")
    return "\n".join(lines)


def _realism_lines(m: dict[str, Any]) -> list[str]:
    """The realism options' figures, for those that are on (docs/model.md)."""
    out = []
    if "energy_used_kj" in m:
        used = ", ".join(f"{k} {v:.0f}" for k, v in m["energy_used_kj"].items())
        charging = ", ".join(f"{k} {v:.0f}" for k, v in m["charging_s"].items())
        out.append(f"  energy (kJ)     {used}; {m['charges']} charges, {m['ran_dry']} ran dry")
        out.append(f"  charging (s)    {charging}")
    if "dock_wait_s" in m:
        out.append(
            f"  dock queue      {m['dock_queued']} haulers waited, {m['dock_wait_s']:.0f} s in "
            f"all (max {m['dock_wait_max_s']:.0f} s)"
        )
    if "radio_reach" in m:
        out.append(
            f"  radio           reach {m['radio_reach']:.1%}, failure verdicts "
            f"{m['failure_detections']} ({m['false_failures']} false)"
        )
    return out


def _bound_text(m: dict[str, Any]) -> str:
    """Both makespan lower bounds and the makespan over each, or why there are none."""
    lb, ap = m.get("lower_bound_s"), m.get("lower_bound_apriori_s")
    if lb is None and ap is None:
        return "- (only for a completed run without faults or operator actions)"
    parts = []
    for value, ratio, what in (
        (lb, m.get("makespan_ratio"), "per run"),
        (ap, m.get("makespan_ratio_apriori"), "a priori"),
    ):
        if value is not None:
            times = f" (makespan {ratio:.2f}×)" if ratio is not None else ""
            parts.append(f"{value:.1f} s {what}{times}")
    return ", ".join(parts)


def add_bounds(metrics: dict[str, Any], scen: Scenario, seed: int, faults: bool) -> None:
    """The run's makespan lower bounds (experiments/bound.py), as a sweep's runs.csv has them.

    `lower_bound_s` is the per-run bound (the run's own site discovery times),
    `lower_bound_apriori_s` the world's a-priori one; each with `makespan_ratio…`. Null for a
    run that did not complete, and with faults or operator actions (the bound assumes the
    scenario's team, fault-free) or uncertain work (it assumes the mean durations). On a lossy
    or slow bus the a-priori bound does not rely on the scouts' spiral (as in a sweep); the
    per-run bound does not need it.
    """
    keys = ("lower_bound_s", "lower_bound_apriori_s", "lower_bound_term")
    keys += ("makespan_ratio", "makespan_ratio_apriori")
    metrics.update(dict.fromkeys(keys))
    if faults or metrics.get("status") != "completed" or scen.uncertainty.enabled:
        return  # (drawn durations and speeds can beat the bound's fixed ones)
    from experiments.bound import bound_world, lower_bound, run_bound

    world = bound_world(scen, seed)
    apriori, per_run = lower_bound(world), run_bound(world, metrics.get("sites_found_at"))
    mk = float(metrics["makespan_s"])
    metrics["lower_bound_apriori_s"] = apriori.value
    metrics["makespan_ratio_apriori"] = mk / apriori.value if apriori.value > 0 else None
    if per_run is not None:
        metrics["lower_bound_s"] = per_run.value
        metrics["lower_bound_term"] = max(per_run.terms, key=lambda k: per_run.terms[k])
        metrics["makespan_ratio"] = mk / per_run.value if per_run.value > 0 else None


def _finite(v: Any) -> Any:
    if isinstance(v, float) and not math.isfinite(v):
        return None
    if isinstance(v, dict):
        return {k: _finite(x) for k, x in v.items()}
    return v


def run(
    policy: Annotated[
        str, typer.Option(metavar="POLICY", help=f"Policy number or name: {policy_help()}")
    ],
    seed: Annotated[
        int, typer.Option(min=0, metavar="N", help="Seed of the world and every random draw")
    ] = 0,
    scenario: Annotated[
        Path | None,
        typer.Option(metavar="FILE", help="Scenario file (.toml or .json); default: reference"),
    ] = None,
    scale: Annotated[
        int, typer.Option(metavar="K", help="K× team, sites, minerals; √K× area side")
    ] = 1,
    json_out: Annotated[bool, typer.Option("--json", help="Print one JSON object")] = False,
    loss: Annotated[
        float | None, typer.Option(metavar="P", help="Bus loss probability 0..0.9")
    ] = None,
    latency: Annotated[
        float | None, typer.Option(metavar="SECONDS", help="Bus latency (s)")
    ] = None,
    jitter: Annotated[
        float | None, typer.Option(metavar="SECONDS", help="Bus latency jitter (s)")
    ] = None,
    fail: Annotated[
        list[str],
        typer.Option(metavar="NAME@T[:MODE]", help="Fail a robot at T s: graceful|abrupt; repeat"),
    ] = [],  # noqa: B006 - typer needs a literal default
    enable: Annotated[
        list[str], typer.Option(metavar="NAME@T", help="Bring a robot back at T s; repeat")
    ] = [],  # noqa: B006
    add: Annotated[
        list[str], typer.Option(metavar="TYPE@T", help="Add a scout|excavator|hauler; repeat")
    ] = [],  # noqa: B006
    planner: Annotated[
        str,
        typer.Option(
            metavar="PLANNER", help="ompl (RRT-Connect, the study's) | exact (shortest paths)"
        ),
    ] = "ompl",
) -> None:
    """Run one mission headless and print its figures.

    Exit code 0 when the mission completed, 1 when it ended otherwise (timeout, stalled:
    the figures are printed all the same), 2 for a bad argument. On a terminal, stderr shows
    the progress (simulated time, minerals, sites) while it runs.
    """
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
    if planner not in ("ompl", "exact"):
        raise fail_usage(f"--planner: must be ompl or exact, not {planner!r}")
    t0 = time.perf_counter()
    try:
        if not json_out and sys.stderr.isatty():
            line = ProgressLine(sys.stderr)
            metrics = run_with_progress(scen, seed, policy_name, actions, line, planner)  # type: ignore[arg-type]
        else:
            metrics = run_mission(scen, seed, policy_name, actions, planner=planner)  # type: ignore[arg-type]
    except (EngineError, ScenarioError) as exc:
        # an action the mission refuses (unknown robot, bad time …), or a world the scenario
        # cannot make for this seed (sites that do not fit): the user's input, not a bug
        raise fail_usage(str(exc)) from None
    # the machine's time, reported beside the mission's figures (never part of them)
    metrics["wall_s"] = time.perf_counter() - t0
    metrics["planner"] = planner
    add_bounds(metrics, scen, seed, faults=bool(actions))
    if json_out:
        typer.echo(json.dumps(_finite(metrics), sort_keys=True))
    else:
        typer.echo(summary(metrics))
    if metrics["status"] != "completed":
        raise typer.Exit(NOT_COMPLETED_EXIT)
