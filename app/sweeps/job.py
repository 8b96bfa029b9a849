"""A sweep job's thread side: drive `run_sweep` over a process pool it owns, stop on demand.

Kept apart from the manager (`app/sweeps/service.py`) because everything here runs on the
job's own thread, never on the event loop: the only things shared with the loop are the
progress attribute (one store per run), the stop flag and the future that carries the outcome.
The derived files (statistics, figures) are written in the pool too, so matplotlib and scipy
never hold the server's GIL.
"""

from __future__ import annotations

import asyncio
import math
import threading
from concurrent.futures import ProcessPoolExecutor
from contextlib import suppress
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

from experiments.spec import SweepSpec

if TYPE_CHECKING:
    from experiments.runner import Progress


@dataclass
class SweepJob:
    """A sweep being run: its stop flag and pool, the latest progress from its thread."""

    id: int
    spec: SweepSpec
    out_dir: Path
    stop: threading.Event = field(default_factory=threading.Event)
    pool: ProcessPoolExecutor | None = None
    progress: Progress | None = None
    cancelling: bool = False
    phase: str = "runs"  # then "figures": the statistics and figures being written
    final: dict[str, Any] | None = None
    finished: asyncio.Future[BaseException | None] | None = None
    task: asyncio.Task[None] | None = None

    def set_progress(self, p: Progress) -> None:
        """run_sweep's callback (job thread): one attribute store, read by the event loop."""
        self.progress = p

    def live_fields(self) -> dict[str, Any]:
        if self.final is not None:
            return self.final
        out: dict[str, Any] = {
            "status": "cancelling" if self.cancelling else "running",
            "phase": self.phase,
        }
        if self.progress is not None:
            out.update(progress_fields(self.progress))
        return out


def progress_fields(p: Progress) -> dict[str, Any]:
    """The columns of the `sweeps` row that a progress report updates."""
    eta = None if p.eta_s is None or not math.isfinite(p.eta_s) else round(p.eta_s, 3)
    return {
        "done": p.done,
        "total": p.total,
        "failed": p.failed,
        "elapsed_s": round(p.elapsed_s, 3),
        "eta_s": eta,
    }


def work(job: SweepJob, workers: int, loop: asyncio.AbstractEventLoop) -> None:
    """Thread body: run the sweep, then hand the outcome to the event loop."""
    outcome: BaseException | None = None
    try:
        _execute(job, workers)
    except BaseException as exc:  # reported by the supervisor
        outcome = exc
    with suppress(RuntimeError):  # a closed loop: the server did not wait for us
        loop.call_soon_threadsafe(_settle, job.finished, outcome)


def _settle(
    future: asyncio.Future[BaseException | None] | None, outcome: BaseException | None
) -> None:
    if future is not None and not future.done():
        future.set_result(outcome)


def _execute(job: SweepJob, workers: int) -> None:
    """Runs, then the derived files, all in a pool of `workers` processes this job owns."""
    from experiments.bound import engine_bound
    from experiments.outputs import write_outputs
    from experiments.runner import SweepCancelled, local_pool, run_sweep

    job.pool = pool = local_pool(workers)
    clean = False
    try:
        if job.stop.is_set():
            raise SweepCancelled("stopped before it started")
        result = run_sweep(
            job.spec,
            job.out_dir,
            progress=job.set_progress,
            executor=pool,
            stop=job.stop.is_set,
            outputs=False,
            window=2 * workers,
        )
        job.phase = "figures"  # every run done: a minute of statistics and plotting may follow
        pool.submit(write_outputs, job.spec, result.records, job.out_dir, engine_bound).result()
        clean = True
    finally:
        pool.shutdown(wait=clean, cancel_futures=True)


def halt(job: SweepJob) -> None:
    """Ask the job to stop, and end its runs in flight now rather than after them."""
    job.stop.set()
    pool = job.pool
    if pool is None:
        return
    terminate = getattr(pool, "terminate_workers", None)  # Python 3.14+
    if callable(terminate):
        terminate()
        return
    for proc in list((getattr(pool, "_processes", None) or {}).values()):
        proc.terminate()
