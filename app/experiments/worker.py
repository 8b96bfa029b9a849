"""The function a worker process (local pool or Dask worker) runs for one policy × seed.

Kept to the standard library at import time so workers start fast; the engine is imported
on the first run inside the worker, not pickled across.
"""

from __future__ import annotations

import os
import socket
import time
from collections.abc import Callable, Mapping
from typing import Any

RunFn = Callable[[Any, int, str], Mapping[str, Any]]
"""`run_mission(scenario, seed, policy) -> metrics`; the engine's, or a stand-in in tests."""


def execute_run(run_fn: RunFn | None, scenario: Any, seed: int, policy: str) -> dict[str, Any]:
    """Run one mission and return its metrics with where and how long it ran."""
    if run_fn is None:
        from engine import run_mission

        run_fn = run_mission
    t0 = time.perf_counter()
    metrics = dict(run_fn(scenario, seed, policy))
    return {
        "metrics": metrics,
        "run_wall_s": round(time.perf_counter() - t0, 6),
        "host": socket.gethostname(),
        "pid": os.getpid(),
    }
