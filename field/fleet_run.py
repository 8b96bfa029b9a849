"""`regolith fleet run`: one field mission end to end on this machine (its world service and
mission control in this process, one agent process per robot), with the faults it is given,
and its figures in `regolith run`'s layout."""

from __future__ import annotations

import time
from collections.abc import Callable
from typing import Any

from engine.scenario import Scenario
from field.fleet import Fleet

PROGRESS_S = 0.2


def run_fleet(
    scenario: Scenario,
    seed: int,
    policy: str,
    speed: float,
    kills: list[tuple[str, float]] = (),  # type: ignore[assignment]
    adds: list[tuple[str, float]] = (),  # type: ignore[assignment]
    restarts: list[tuple[str, float]] = (),  # type: ignore[assignment]
    wall_limit_s: float | None = None,
    progress: Callable[[dict[str, Any]], None] | None = None,
) -> dict[str, Any]:
    """Run one field mission end to end on this machine and return its figures;
    `progress(world status)` is called about every `PROGRESS_S` of wall time meanwhile."""
    t_wall = time.monotonic()
    plan = sorted(
        [(t, "kill", n) for n, t in kills]
        + [(t, "add", r) for r, t in adds]
        + [(t, "restart", n) for n, t in restarts]
    )
    limit = wall_limit_s or (scenario.stall_timeout_s * 2 / speed + 120.0)
    with Fleet(scenario, seed, policy, speed) as fleet:
        fleet.up()
        actions: list[dict[str, Any]] = []
        status = "timeout"
        shown = -PROGRESS_S
        while time.monotonic() - t_wall < limit:
            now = fleet.now()
            while plan and plan[0][0] <= now:
                _t, kind, arg = plan.pop(0)
                if kind == "kill":
                    fleet.kill(arg)
                elif kind == "add":
                    arg = fleet.add(arg)
                else:
                    fleet.spawn(arg)
                actions.append({"t": now, "kind": kind, "robot": arg})
            if fleet.world.terrain.finished.triggered:
                status = "completed"
                break
            if progress is not None and time.monotonic() - shown >= PROGRESS_S:
                shown = time.monotonic()
                progress(fleet.world.status())
            time.sleep(0.02)
        st = fleet.world.status()
        rec = fleet.intake
        with rec.lock:
            auctions = list(rec.auctions.values())
            out = {
                "policy": fleet.world.policy,
                "seed": seed,
                "scenario": scenario.name,
                "status": status,
                "completed": status == "completed",
                "makespan_s": st["finished_at"],
                "sim_time_s": st["t"],
                "minerals_total": st["minerals_total"],
                "minerals_delivered": st["delivered"],
                "sites_found": st["sites_found"],
                "sites_total": st["sites_total"],
                "auctions": len(auctions),
                "reauctions": sum(1 for a in auctions if a.get("reauction_of")),
                "bids": sum(len(a.get("bids") or ()) for a in auctions),
                "reannouncements": sum(a.get("reannouncements") or 0 for a in auctions),
                "messages": rec.messages,
                "failures": sum(1 for a in actions if a["kind"] == "kill"),
                "actions": actions,
                "auction_records": auctions,
                "wall_s": time.monotonic() - t_wall,
            }
        out["processes"] = [
            {
                "name": p.name,
                "pid": p.popen.pid,
                "started_at": p.started_at,
                "killed_at": p.killed_at,
            }
            for p in fleet.history
        ]
        out["transport"] = {
            "kind": "zenoh",
            "mode": "peer",
            "endpoint": fleet.endpoint,
            "mission": fleet.mission,
            "speed": speed,
            "messages": rec.messages,
            "malformed": rec.malformed,
            "rejections": {**rec.rejections(), "world_refused": fleet.world.refused},
            "by_type": dict(sorted(rec.by_type.items())),
            "world_queries": fleet.world.queries,
        }
    return out
