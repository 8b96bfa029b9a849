"""Pinned event-log digests: the guard for every change that must not change a run.

A case is a mission (policy, busy-bid rule, scale, planner, bus, a robot failing or not);
its digest is the SHA-256 of its whole event log with the log's length. The speed work on
the engine (docs/benchmarks.md, Engine) keeps every one of them identical. The cases up to
scale 10 run in the test suite (`tests/engine/test_digests.py`); scale 30 is minutes, so
it runs from the command line before and after a change to the engine's hot paths:

    .venv/bin/python -m tests.engine.digests --check            # every case, scale 30 too
    .venv/bin/python -m tests.engine.digests --check --fast     # the suite's cases only
    .venv/bin/python -m tests.engine.digests --write            # pin again (say why!)

A change that alters a digest on purpose says so in its commit and docs and is pinned
again with `--write`.
"""

from __future__ import annotations

import argparse
import hashlib
import json
import multiprocessing as mp
import sys
import time
from dataclasses import dataclass
from pathlib import Path

PINNED = Path(__file__).with_name("digests.json")
SEED = 0
FAIL_AT_S = 500.0
"""When the failing cases lose their robot (abruptly): mid-mission at every scale here."""
SLOW_SCALE = 30


@dataclass(frozen=True)
class Case:
    policy: str
    busy_bid: str = "once"
    scale: int = 1
    planner: str = "ompl"
    bus: str = "ideal"  # ideal | lossy | late
    fail: bool = False
    ops: bool = False  # OPERATIONS: scouts and excavators fail and return, robots join

    @property
    def key(self) -> str:
        return (
            f"{self.policy}/{self.busy_bid}/x{self.scale}/{self.planner}/{self.bus}"
            f"{'/fail' if self.fail else ''}{'/ops' if self.ops else ''}"
        )


OPERATIONS: list[tuple[float, str, tuple[object, ...]]] = [
    (300.0, "disable_robot", ("scout-1", "abrupt")),
    (400.0, "add_robot", ("scout", None)),
    (600.0, "disable_robot", ("excavator-2", "abrupt")),
    (700.0, "add_robot", ("hauler", None)),
    (800.0, "disable_robot", ("scout-2", "graceful")),
    (900.0, "enable_robot", ("scout-1",)),
    (1000.0, "enable_robot", ("excavator-2",)),
    (1100.0, "add_robot", ("excavator", None)),
]
"""The operator's actions of the `ops` cases: scouts hand over and take back cells, failed
auctioneers' tasks are adopted, newcomers learn the auctions under way."""

BUSES = {
    "ideal": {},
    "lossy": {"loss": 0.05},
    "late": {"latency_s": 0.3, "jitter_s": 0.2},
}


def cases(slow: bool = True) -> list[Case]:
    """Every policy × busy-bid rule at scales 1 and 3, with and without a failure; every
    policy on a lossy and on a late bus; the exact planner at scale 3; scale 10 and (slow)
    scale 30 under FCFS and Policy 4."""
    from engine import POLICIES

    out: list[Case] = []
    for policy in POLICIES:
        for busy_bid in ("once", "silent", "every_round"):
            for scale in (1, 3):
                for fail in (False, True):
                    out.append(Case(policy, busy_bid, scale, fail=fail))
        for bus in ("lossy", "late"):
            out.append(Case(policy, bus=bus))
            out.append(Case(policy, bus=bus, fail=True))
        for bus in ("ideal", "lossy"):
            out.append(Case(policy, "silent", 3, bus=bus, ops=True))
    for policy in ("fcfs", "lookahead"):
        out.append(Case(policy, "silent", 3, planner="exact"))
        out.append(Case(policy, "silent", 10))
        out.append(Case(policy, "once", 10, fail=True))
        if slow:
            out.append(Case(policy, "silent", SLOW_SCALE, planner="exact"))
    return out


def digest(case: Case) -> str:
    """`"<status> <events> <sha256>"` of the case's whole run."""
    from engine import Mission, reference_scenario
    from engine.scenario import BusConfig, Protocol

    scenario = reference_scenario().scaled(case.scale)
    protocol = Protocol.model_validate(
        {**scenario.protocol.model_dump(), "busy_bid": case.busy_bid}
    )
    scenario = scenario.model_copy(
        update={"protocol": protocol, "bus": BusConfig(**BUSES[case.bus])}
    )
    m = Mission(scenario, SEED, case.policy, case.planner)  # type: ignore[arg-type]
    if case.fail:
        m.advance(FAIL_AT_S)
        if not m.done:
            m.disable_robot("hauler-1", "abrupt")
    for t, action, args in OPERATIONS if case.ops else ():
        m.advance(t)
        if not m.done:
            getattr(m, action)(*args)
    m.run()
    h = hashlib.sha256()
    for e in m.events:
        h.update(json.dumps(e.to_dict(), sort_keys=True).encode())
    return f"{m.status} {len(m.events)} {h.hexdigest()}"


def pinned() -> dict[str, str]:
    return json.loads(PINNED.read_text()) if PINNED.exists() else {}


def _one(case: Case) -> tuple[str, str, float]:
    t0 = time.perf_counter()
    return case.key, digest(case), time.perf_counter() - t0


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawTextHelpFormatter)
    mode = ap.add_mutually_exclusive_group(required=True)
    mode.add_argument("--check", action="store_true", help="compare with the pinned digests")
    mode.add_argument("--write", action="store_true", help="pin the digests anew")
    ap.add_argument("--fast", action="store_true", help=f"leave out scale {SLOW_SCALE}")
    ap.add_argument("--jobs", type=int, default=2, help="processes (default 2)")
    args = ap.parse_args(argv)
    todo = cases(slow=not args.fast)
    # the slow cases first, so they overlap the many small ones
    todo.sort(key=lambda c: -c.scale)
    with mp.get_context("spawn").Pool(args.jobs) as pool:
        results = {}
        for key, value, took in pool.imap_unordered(_one, todo):
            results[key] = value
            print(f"{took:7.1f} s  {key}", file=sys.stderr, flush=True)
    if args.write:
        merged = {**pinned(), **results}
        PINNED.write_text(json.dumps(dict(sorted(merged.items())), indent=1) + "\n")
        print(f"pinned {len(results)} digests in {PINNED}")
        return 0
    old = pinned()
    bad = [k for k in sorted(results) if old.get(k) != results[k]]
    for k in bad:
        print(f"CHANGED {k}: pinned {old.get(k)!r}, now {results[k]!r}")
    print(f"{len(results) - len(bad)} of {len(results)} digests as pinned")
    return 1 if bad else 0


if __name__ == "__main__":
    raise SystemExit(main())
