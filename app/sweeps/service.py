"""Sweeps as background jobs: `run_sweep` on a thread of its own, the runs in worker processes.

A sweep is minutes of CPU, so it never runs on the event loop or under the engine gate. Each
sweep gets one thread that drives `run_sweep` over a process pool it owns
(`REGOLITH_SWEEP_WORKERS`, default 1, so live missions keep a core); even the derived files
(statistics, figures) are written in that pool, so matplotlib and scipy never hold the
server's GIL. The journal in `<data_dir>/sweeps/<id>/` is the truth about finished runs; the
`sweeps` row holds status and progress, written through the store like every other write.
Cancel and server stop kill the workers at once: a run in flight was never journaled, so a
resume simply runs it again. The thread side is `job.py`; reading a sweep's folder for
the API is `files.py`.
"""

from __future__ import annotations

import asyncio
import logging
import threading
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import TYPE_CHECKING, Any

from sqlalchemy import and_, func, or_, select
from sqlalchemy.orm import Session
from starlette.concurrency import run_in_threadpool

from app.db.models import Sweep as SweepRow
from app.db.models import utcnow
from app.services.errors import Conflict, Invalid, LimitExceeded, NotFound
from app.services.store import Store
from app.settings import Settings
from app.sweeps.files import (
    SWEEP_FILES,
    check_build,
    figure_links,
    file_links,
    read_results,
    read_served,
    set_aside,
)
from app.sweeps.job import SweepJob, halt, progress_fields, work
from engine import POLICY_NAMES, Scenario, ScenarioError, reference_scenario, resolve_policy
from experiments.spec import PolicyRef, SpecError, SweepSpec, make_spec, parse_policies

if TYPE_CHECKING:
    from experiments.runner import Progress

log = logging.getLogger("regolith.sweeps")

SWEEP_DIR = "sweeps"
FIG_DIR = "figures"
PROGRESS_EVERY_S = 0.5
CANCEL_WAIT_S = 10.0
STOP_WAIT_S = 20.0
RESUMABLE = ("interrupted", "cancelled", "failed")
_COLUMNS = (
    "id", "status", "policies", "seeds", "scale", "scenario_name", "total", "done", "failed",
    "elapsed_s", "eta_s", "created_at", "started_at", "ended_at", "error",
)  # fmt: skip


class SweepManager:
    """Starts, watches, cancels and resumes sweeps; the routes' only handle on them."""

    def __init__(self, settings: Settings, store: Store) -> None:
        self.settings = settings
        self.store = store
        self.jobs: dict[int, SweepJob] = {}
        self.stopping = False
        self._starting = 0

    @property
    def root(self) -> Path:
        return self.settings.data_dir / SWEEP_DIR

    def out_dir(self, sweep_id: int) -> Path:
        return self.root / str(sweep_id)

    async def start(self) -> int:
        """Sweeps left running by the last server had their job die with it."""
        return await self.store.interrupt_stale_sweeps()

    async def aclose(self) -> None:
        """Stop every job (its finished runs are kept) and mark it interrupted."""
        self.stopping = True
        jobs = list(self.jobs.values())
        for job in jobs:
            halt(job)
        tasks = [j.task for j in jobs if j.task is not None]
        if tasks:
            _, late = await asyncio.wait(tasks, timeout=STOP_WAIT_S)
            for task in late:  # the row stays "running"; the next start marks it interrupted
                task.cancel()

    # -- start, cancel, resume ---------------------------------------------------------

    async def create(
        self, policies: list[str], seeds: tuple[int, ...], scale: int, scenario: Scenario | None
    ) -> dict[str, Any]:
        with self._slot():
            base = scenario or reference_scenario()
            refs = parse_policies(",".join(policies), resolve_policy, POLICY_NAMES)
            spec = self._spec(refs, seeds, base, scale)
            row = await self.store.create_sweep(
                {
                    "status": "running",
                    "policies": [p.name for p in refs],
                    "seeds": list(seeds),
                    "scale": scale,
                    "scenario_name": spec.scenario.name[:80],
                    "scenario": base.model_dump(mode="json"),
                    "total": spec.total,
                    "done": 0,
                    "failed": 0,
                    "elapsed_s": 0.0,
                    "started_at": utcnow(),
                }
            )
            await run_in_threadpool(set_aside, self.out_dir(row.id))
            self._launch(row.id, spec)
        return self.fields(row)

    async def cancel(self, sweep_id: int) -> dict[str, Any]:
        """Stop a running sweep; answers once its final status is written (or after 10 s)."""
        await self._settled(sweep_id)
        job = self.jobs.get(sweep_id)
        if job is None:
            row = await self._row(sweep_id)
            raise Conflict(
                f"sweep {sweep_id} is {row.status}; only a running sweep can be cancelled"
            )
        if not job.cancelling:
            job.cancelling = True
            await self.store.update_sweep(sweep_id, {"status": "cancelling"})
            halt(job)
        if job.task is not None:
            await asyncio.wait([job.task], timeout=CANCEL_WAIT_S)
        return await self.get(sweep_id)

    async def resume(self, sweep_id: int) -> dict[str, Any]:
        """Continue an interrupted, cancelled or failed sweep from its journal."""
        await self._settled(sweep_id)
        with self._slot():
            row = await self._row(sweep_id)
            if sweep_id in self.jobs or row.status not in RESUMABLE:
                raise Conflict(
                    f"sweep {sweep_id} is {row.status}; only an interrupted, cancelled or "
                    "failed sweep can be resumed"
                )
            spec = self._stored_spec(row)
            await run_in_threadpool(check_build, self.out_dir(sweep_id), sweep_id)
            changes = {"status": "running", "error": None, "ended_at": None, "eta_s": None}
            await self.store.update_sweep(sweep_id, changes)
            self._launch(sweep_id, spec)
        return await self.get(sweep_id)

    async def _settled(self, sweep_id: int) -> None:
        """A job that has its final status (every read shows it) is writing it: let it."""
        job = self.jobs.get(sweep_id)
        if job is not None and job.final is not None and job.task is not None:
            await asyncio.wait([job.task])

    @contextmanager
    def _slot(self) -> Iterator[None]:
        """Hold one of the REGOLITH_MAX_RUNNING_SWEEPS places while a sweep is being started
        (a job writing its final status holds none: it shows as ended)."""
        limit = self.settings.max_running_sweeps
        running = sum(1 for job in self.jobs.values() if job.final is None)
        if running + self._starting >= limit:
            raise LimitExceeded(
                f"{limit} sweep(s) already running; wait for it to finish, cancel it, or raise "
                "REGOLITH_MAX_RUNNING_SWEEPS"
            )
        self._starting += 1
        try:
            yield
        finally:
            self._starting -= 1

    def _spec(
        self, refs: tuple[PolicyRef, ...], seeds: tuple[int, ...], base: Scenario, scale: int
    ) -> SweepSpec:
        runs, limit = len(refs) * len(seeds), self.settings.max_sweep_runs
        if runs > limit:
            raise Invalid(
                f"seeds: {len(refs)} policies × {len(seeds)} seeds = {runs} runs, over this "
                f"server's limit of {limit} per sweep (REGOLITH_MAX_SWEEP_RUNS)",
                ("body", "seeds"),
            )
        try:
            scaled = base.scaled(scale)
            return make_spec(refs, seeds, scaled, scale)
        except (SpecError, ScenarioError) as exc:
            raise Invalid(str(exc), ("body", "scale")) from None

    def _stored_spec(self, row: SweepRow) -> SweepSpec:
        try:
            refs = parse_policies(",".join(row.policies), resolve_policy, POLICY_NAMES)
            scenario = Scenario.model_validate(row.scenario).scaled(row.scale)
            return make_spec(refs, tuple(int(s) for s in row.seeds), scenario, row.scale)
        except (SpecError, ScenarioError, ValueError) as exc:
            raise Conflict(f"sweep {row.id} cannot be rebuilt on this server: {exc}") from None

    def _launch(self, sweep_id: int, spec: SweepSpec) -> None:
        loop = asyncio.get_running_loop()
        job = SweepJob(sweep_id, spec, self.out_dir(sweep_id), finished=loop.create_future())
        self.jobs[sweep_id] = job
        workers = self.settings.sweep_workers
        threading.Thread(
            target=work, args=(job, workers, loop), name=f"regolith-sweep-{sweep_id}", daemon=True
        ).start()
        job.task = asyncio.create_task(self._supervise(job), name=f"sweep-{sweep_id}")

    async def _supervise(self, job: SweepJob) -> None:
        """Save progress every half second until the thread ends, then the final status."""
        assert job.finished is not None
        saved: Progress | None = None
        while not job.finished.done():
            await asyncio.wait([job.finished], timeout=PROGRESS_EVERY_S)
            current = job.progress
            if current is not None and current is not saved and not job.finished.done():
                saved = current
                await self.store.update_sweep(job.id, progress_fields(current), urgent=False)
        status, error = self._verdict(job, job.finished.result())
        final: dict[str, Any] = {"status": status, "error": error, "ended_at": utcnow()}
        if job.progress is not None:
            final.update(progress_fields(job.progress))
        final["eta_s"] = None
        job.final = final
        try:
            await self.store.update_sweep(job.id, final)
        finally:
            self.jobs.pop(job.id, None)
        log.info("sweep %d %s (%s of %s runs)", job.id, status, final.get("done"), job.spec.total)

    def _verdict(self, job: SweepJob, outcome: BaseException | None) -> tuple[str, str | None]:
        if outcome is None:
            return "completed", None
        if job.stop.is_set():
            return ("interrupted" if self.stopping and not job.cancelling else "cancelled"), None
        from experiments.journal import SweepConflict
        from experiments.runner import SweepError

        if not isinstance(outcome, (SweepError, SweepConflict)):
            log.error("sweep %d failed", job.id, exc_info=outcome)
        return "failed", f"{type(outcome).__name__}: {outcome}"[:2000]

    # -- reads -------------------------------------------------------------------------

    def fields(self, row: SweepRow) -> dict[str, Any]:
        """The row's public fields with a running job's fresher progress laid over."""
        out = {name: getattr(row, name) for name in _COLUMNS}
        job = self.jobs.get(row.id)
        if job is not None:
            out.update(job.live_fields())
        out["n_seeds"] = len(out["seeds"])
        return out

    async def _row(self, sweep_id: int) -> SweepRow:
        row = await self.store.read(_get, sweep_id)
        if row is None:
            raise NotFound(f"sweep {sweep_id} not found")
        return row

    async def get(self, sweep_id: int) -> dict[str, Any]:
        return self.fields(await self._row(sweep_id))

    async def page(
        self, status: str | None, limit: int, offset: int
    ) -> tuple[list[dict[str, Any]], int]:
        # a running job's status may be ahead of its row (its final status being written):
        # the filter reads the status each item shows, so the list and its count agree
        live = {i: str(job.live_fields()["status"]) for i, job in self.jobs.items()}
        rows, total = await self.store.read(_page, status, live, limit, offset)
        return [self.fields(r) for r in rows], total

    async def detail(self, sweep_id: int, results: bool = True) -> dict[str, Any]:
        """Fields, scenario, the runs so far and, once completed, the summary and figures
        (without `results`, only the progress: cheap enough to poll every second)."""
        row = await self._row(sweep_id)
        out = self.fields(row)
        out.update(scenario=row.scenario, runs=[], summary=None)
        if results:
            done = out["status"] == "completed"
            out.update(await run_in_threadpool(read_results, self.out_dir(sweep_id), row, done))
        out["figures"] = figure_links(f"/api/sweeps/{sweep_id}/{FIG_DIR}", out["summary"])
        out["files"] = await run_in_threadpool(file_links, self.out_dir(sweep_id), sweep_id)
        return out

    async def file(self, sweep_id: int, name: str) -> bytes:
        """One of the sweep's result files (`SWEEP_FILES`), once written."""
        await self._row(sweep_id)
        if name not in SWEEP_FILES:
            raise NotFound(f"sweep {sweep_id} has no file {name!r}")
        data = await run_in_threadpool(read_served, self.root, str(sweep_id), name)
        if data is None:
            raise NotFound(f"sweep {sweep_id} has no {name} yet")
        return data

    async def figure(self, sweep_id: int, name: str) -> bytes:
        """A figure file of the sweep; the name must stay inside its figures folder."""
        await self._row(sweep_id)
        data = await run_in_threadpool(read_served, self.root, str(sweep_id), FIG_DIR, name)
        if data is None:
            raise NotFound(f"sweep {sweep_id} has no figure {name!r}")
        return data


# -- reads (thread pool) -------------------------------------------------------------------


def _get(session: Session, sweep_id: int) -> SweepRow | None:
    return session.get(SweepRow, sweep_id)


def _page(
    session: Session, status: str | None, live: dict[int, str], limit: int, offset: int
) -> tuple[list[SweepRow], int]:
    """A page of sweeps, newest first; with `status`, those showing it: a row's own, or for
    a sweep with a job, the job's (`live`: id -> status)."""
    stmt = select(SweepRow).order_by(SweepRow.id.desc())
    count = select(func.count()).select_from(SweepRow)
    if status is not None:
        shows = or_(
            and_(SweepRow.status == status, SweepRow.id.not_in(list(live))),
            SweepRow.id.in_([i for i, s in live.items() if s == status]),
        )
        stmt = stmt.where(shows)
        count = count.where(shows)
    return list(session.scalars(stmt.limit(limit).offset(offset))), int(session.scalar(count) or 0)
