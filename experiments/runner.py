"""Run a sweep: every policy × seed on an executor, journaled, then summarized.

`run_sweep` is a library function so the CLI and the service's background jobs share it;
both observe it through the `progress` callback and may stop it through `stop`. Any
`concurrent.futures.Executor` works: the default local process pool, or a Dask cluster's
`client.get_executor()`.
"""

from __future__ import annotations

import math
import multiprocessing
import os
import time
from collections.abc import Callable
from concurrent.futures import FIRST_COMPLETED, Executor, Future, ProcessPoolExecutor, wait
from dataclasses import dataclass, field
from multiprocessing.context import BaseContext
from pathlib import Path
from typing import Any

from experiments.bound import BoundFn, engine_bound
from experiments.journal import Journal, RunKey, check_manifest, exclusive
from experiments.lifeline import die_with
from experiments.outputs import write_outputs
from experiments.spec import SweepSpec, scenario_dict
from experiments.worker import RunFn, engine_fingerprint, execute_run


@dataclass(frozen=True)
class Progress:
    """Where a sweep stands; `done` counts runs resumed from the journal too."""

    done: int
    total: int
    resumed: int
    failed: int
    elapsed_s: float
    eta_s: float | None
    last: RunKey | None = None


ProgressFn = Callable[[Progress], None]


class SweepError(RuntimeError):
    """Some runs raised; the others are journaled, so a re-run retries only the failures."""

    def __init__(self, failures: list[tuple[RunKey, BaseException]], total: int) -> None:
        key, exc = failures[0]
        super().__init__(
            f"{len(failures)} of {total} runs failed; first: policy {key.policy} seed "
            f"{key.seed}: {type(exc).__name__}: {exc}"
        )
        self.failures = failures


class EngineMismatch(RuntimeError):
    """A worker ran another engine build than the one this sweep is pinned to."""

    def __init__(self, worker: object, pinned: str) -> None:
        super().__init__(f"worker engine build {worker} differs from this sweep's {pinned}")


class SweepCancelled(RuntimeError):
    """`stop()` asked the sweep to end; finished runs are journaled."""


@dataclass
class SweepResult:
    out_dir: Path
    ran: int
    resumed: int
    elapsed_s: float
    records: list[dict[str, Any]]
    files: list[Path] = field(default_factory=list)


def local_pool(workers: int | None = None) -> ProcessPoolExecutor:
    """A process pool on all local cores.

    Workers come from a fork server that has imported the engine once: as quick to start as
    a fork (~1 s saved per worker over spawn) without forking a parent whose threads (the
    progress bar, a web server) may hold locks. Spawn where there is no fork server. Every
    worker dies with this process, even a `kill -9` of it (`lifeline.die_with`).
    """
    n = workers or os.cpu_count() or 1
    if "forkserver" in multiprocessing.get_all_start_methods():
        ctx: BaseContext = multiprocessing.get_context("forkserver")
        ctx.set_forkserver_preload(["experiments.worker"])  # imports the engine
    else:  # pragma: no cover - Windows
        ctx = multiprocessing.get_context("spawn")
    return ProcessPoolExecutor(
        max_workers=n, mp_context=ctx, initializer=die_with, initargs=(os.getpid(),)
    )


def run_sweep(
    spec: SweepSpec,
    out_dir: Path,
    *,
    progress: ProgressFn | None = None,
    executor: Executor | None = None,
    workers: int | None = None,
    run_fn: RunFn | None = None,
    stop: Callable[[], bool] | None = None,
    outputs: bool = True,
    window: int | None = None,
    bound_fn: BoundFn | None = None,
) -> SweepResult:
    """Run what the journal in `out_dir` lacks, then write runs.csv, summary, figures, report.

    `run_fn` defaults to the engine's `run_mission` (imported in the worker); `executor`
    defaults to a local process pool of `workers` processes, shut down at the end. At most
    `window` runs are in flight, so cancelling is quick and memory stays flat. The makespan
    lower bound comes from `bound_fn`, by default the engine's world when `run_fn` is too.
    """
    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    t0 = time.perf_counter()
    shash = spec.scenario_hash
    with exclusive(out_dir):
        engine = engine_fingerprint()
        grid = spec.grid
        hashes = [shash] if grid is None else [pt.hash for pt in grid.points]
        check_manifest(
            out_dir,
            shash,
            scenario_dict(spec.scenario),
            engine,
            grid=None if grid is None else grid.paths,
            run_hashes=hashes,
            planner=spec.planner,
        )
        journal = Journal(out_dir)
        done = journal.load()
        wanted = [RunKey(p.name, s, h) for h in hashes for p in spec.policies for s in spec.seeds]
        pending = [k for k in wanted if k not in done]
        resumed = len(wanted) - len(pending)
        if progress:
            progress(Progress(resumed, len(wanted), resumed, 0, 0.0, None if pending else 0.0))
        ran = 0
        if pending:
            own = executor is None
            ex = executor if executor is not None else local_pool(workers)
            limit = window or (4 * (workers or os.cpu_count() or 1) if own else 512)
            clean = False
            try:
                ran = _drive(
                    engine,
                    spec,
                    pending,
                    done,
                    journal,
                    ex,
                    run_fn,
                    limit,
                    progress,
                    stop,
                    resumed,
                    len(wanted),
                    t0,
                )
                clean = True
            finally:
                if own:
                    ex.shutdown(wait=clean, cancel_futures=True)
        records = [done[k] for k in wanted]
        if bound_fn is None and run_fn is None:
            bound_fn = engine_bound
        if not outputs:
            files = []
        elif grid is None:
            files = write_outputs(spec, records, out_dir, bound_fn)
        else:
            from experiments.grid_outputs import write_grid_outputs

            files = write_grid_outputs(spec, records, out_dir, bound_fn)
    return SweepResult(out_dir, ran, resumed, time.perf_counter() - t0, records, files)


def _drive(
    engine: str,
    spec: SweepSpec,
    pending: list[RunKey],
    done: dict[RunKey, dict[str, Any]],
    journal: Journal,
    ex: Executor,
    run_fn: RunFn | None,
    limit: int,
    progress: ProgressFn | None,
    stop: Callable[[], bool] | None,
    resumed: int,
    total: int,
    t0: float,
) -> int:
    """Keep up to `limit` runs in flight; journal each one the moment it finishes."""
    queue = iter(pending)
    inflight: dict[Future[dict[str, Any]], RunKey] = {}
    failures: list[tuple[RunKey, BaseException]] = []
    ran = 0

    points = {} if spec.grid is None else {pt.hash: pt for pt in spec.grid.points}

    def fill() -> None:
        while len(inflight) < limit:
            key = next(queue, None)
            if key is None:
                return
            pt = points.get(key.scenario)
            scenario = spec.scenario if pt is None else pt.scenario
            fut = ex.submit(execute_run, run_fn, scenario, key.seed, key.policy, spec.planner)
            inflight[fut] = key

    with journal.writer() as writer:
        try:
            fill()
            while inflight:
                finished, _ = wait(list(inflight), return_when=FIRST_COMPLETED)
                for fut in sorted(finished, key=lambda f: inflight[f]):
                    key = inflight.pop(fut)
                    try:
                        out = fut.result()
                    except Exception as exc:  # a run that raised is reported, not journaled
                        failures.append((key, exc))
                        continue
                    if out.get("engine") != engine:
                        failures.append((key, EngineMismatch(out.get("engine"), engine)))
                        continue
                    record = {"policy": key.policy, "seed": key.seed, "scenario": key.scenario}
                    if key.scenario in points:  # a grid run says where it ran
                        record["point"] = _jsonable(points[key.scenario].as_dict())
                    record.update(_jsonable(out))
                    writer.append(record)
                    done[key] = record
                    ran += 1
                    if progress:
                        elapsed = time.perf_counter() - t0
                        left = total - resumed - ran
                        eta = elapsed / ran * left
                        n = resumed + ran
                        progress(Progress(n, total, resumed, len(failures), elapsed, eta, key))
                if stop is not None and stop():
                    raise SweepCancelled(f"stopped after {resumed + ran} of {total} runs")
                fill()
        except BaseException:
            for fut in inflight:
                fut.cancel()
            raise
    if failures:
        raise SweepError(failures, total)
    return ran


def _jsonable(value: Any) -> Any:
    """Plain JSON: non-finite floats become null, tuples lists, numpy scalars Python ones."""
    if isinstance(value, dict):
        return {str(k): _jsonable(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [_jsonable(v) for v in value]
    if isinstance(value, bool) or value is None or isinstance(value, (int, str)):
        return value
    if isinstance(value, float):
        return value if math.isfinite(value) else None
    item = getattr(value, "item", None)  # numpy scalars
    if callable(item):
        return _jsonable(item())
    return str(value)
