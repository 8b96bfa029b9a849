"""The function a worker process (local pool or Dask worker) runs for one policy × seed.

Importing this module imports the engine and fingerprints it at once, so the fingerprint
describes the code this process actually runs (a fork-server child inherits both from the
server). Results of two engine builds must never be mixed in one analysis: the manifest pins
the build a sweep started with and every run reports the build of the worker that made it.
"""

from __future__ import annotations

import hashlib
import importlib.util
import os
import socket
import time
from collections.abc import Callable, Mapping
from pathlib import Path
from typing import Any

import engine

RunFn = Callable[[Any, int, str], Mapping[str, Any]]
"""`run_mission(scenario, seed, policy) -> metrics`; the engine's, or a stand-in in tests."""


def _fingerprint() -> str:
    """A hash of the engine package's source files (paths and bytes)."""
    spec = importlib.util.find_spec(engine.__name__)
    roots = list(spec.submodule_search_locations or []) if spec else []
    h = hashlib.sha256()
    for root in roots:
        for path in sorted(Path(root).rglob("*.py")):
            h.update(path.relative_to(root).as_posix().encode())
            h.update(b"\0")
            h.update(path.read_bytes())
    return h.hexdigest()[:12]


ENGINE_BUILD = _fingerprint()


def engine_fingerprint() -> str:
    """The engine build loaded in this process."""
    return ENGINE_BUILD


def execute_run(
    run_fn: RunFn | None, scenario: Any, seed: int, policy: str, planner: str = "ompl"
) -> dict[str, Any]:
    """Run one mission and return its metrics with where, how long and on which build.

    `planner` goes to the engine's `run_mission`; a stand-in `run_fn` (tests) plans nothing."""
    t0 = time.perf_counter()
    if run_fn is not None:
        metrics = dict(run_fn(scenario, seed, policy))
    else:
        metrics = engine.run_mission(scenario, seed, policy, planner=planner)  # type: ignore[arg-type]
    return {
        "engine": ENGINE_BUILD,
        "metrics": metrics,
        "run_wall_s": round(time.perf_counter() - t0, 6),
        "host": socket.gethostname(),
        "pid": os.getpid(),
    }
