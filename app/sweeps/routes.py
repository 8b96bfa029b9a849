"""Sweeps: start a policy × seed comparison as a background job, watch it, read its results."""

from __future__ import annotations

from typing import Annotated, Any, Literal

from fastapi import APIRouter, Depends, Path, Query, status
from fastapi.responses import Response
from starlette.concurrency import run_in_threadpool

from app.api.deps import Operator, ServicesDep, Viewer
from app.api.schemas import ErrorRead
from app.services.errors import Invalid
from app.services.scenario_limits import check_size, check_world
from app.settings import Settings
from app.sweeps.files import SWEEP_FILES
from app.sweeps.schemas import SweepCreate, SweepDetail, SweepPage, SweepRead, SweepStatus
from app.sweeps.service import SweepManager
from engine import Scenario, ScenarioError, reference_scenario

_ERRORS: dict[int | str, dict[str, Any]] = {
    code: {"model": ErrorRead, "description": text}
    for code, text in [
        (401, "operator token missing (mutating calls)"),
        (403, "operator token wrong"),
        (404, "unknown sweep or figure"),
        (409, "the sweep's state forbids it (not running, not resumable, another engine build)"),
        (413, "request body too large"),
        (429, "REGOLITH_MAX_RUNNING_SWEEPS sweeps already running, or the rate limit"),
    ]
}
router = APIRouter(prefix="/sweeps", tags=["sweeps"], responses=_ERRORS)

SweepId = Annotated[int, Path(ge=1, le=2**31 - 1, description="sweep id")]
FigureName = Annotated[
    str,
    Path(
        pattern=r"^[A-Za-z0-9_-]{1,64}\.(png|svg)$",
        description="a figure file, e.g. makespan.png",
    ),
]
_MEDIA = {"png": "image/png", "svg": "image/svg+xml"}
FileName = Annotated[
    Literal[tuple(SWEEP_FILES)],  # type: ignore[valid-type]
    Path(description="a result file: " + ", ".join(SWEEP_FILES)),
]


async def get_sweeps(services: ServicesDep) -> SweepManager:
    return services.sweeps


SweepsDep = Annotated[SweepManager, Depends(get_sweeps)]


@router.post("", status_code=status.HTTP_202_ACCEPTED, dependencies=[Operator])
async def start_sweep(body: SweepCreate, sweeps: SweepsDep, services: ServicesDep) -> SweepRead:
    """Start every policy × seed in the background; poll `GET /api/sweeps/{id}` for progress."""
    seeds = body.seed_tuple()
    await run_in_threadpool(_check_runs, services.settings, body.scenario, body.scale, seeds[0])
    fields = await sweeps.create([str(p) for p in body.policies], seeds, body.scale, body.scenario)
    return SweepRead.model_validate(fields)


def _check_runs(settings: Settings, scenario: Scenario | None, scale: int, seed: int) -> None:
    """The runs a sweep would make, refused up front like a mission: over this server's
    robot or grid limits (before or after scaling), or no world for its first seed."""
    base = scenario or reference_scenario()
    check_size(settings, base)
    try:
        scaled = base.scaled(scale)
    except ScenarioError as exc:
        raise Invalid(str(exc), ("body", "scale")) from None
    check_size(settings, scaled, ("body", "scale"), f" (at scale {scale})")
    check_world(scaled, seed, ("body", "scenario") if scale == 1 else ("body", "scale"))


@router.get("", dependencies=[Viewer])
async def list_sweeps(
    sweeps: SweepsDep,
    status: SweepStatus | None = None,
    limit: Annotated[int, Query(ge=1, le=500)] = 50,
    offset: Annotated[int, Query(ge=0, le=10_000_000)] = 0,
) -> SweepPage:
    """Newest first."""
    items, total = await sweeps.page(status, limit, offset)
    return SweepPage(
        items=[SweepRead.model_validate(i) for i in items], total=total, limit=limit, offset=offset
    )


@router.get("/{sweep_id}", dependencies=[Viewer])
async def get_sweep(
    sweep_id: SweepId,
    sweeps: SweepsDep,
    runs: Annotated[bool, Query(description="false: leave out runs and summary (polling)")] = True,
) -> SweepDetail:
    """Progress, the runs so far and, once completed, the summary and the figures' URLs."""
    return SweepDetail.model_validate(await sweeps.detail(sweep_id, results=runs))


@router.get(
    "/{sweep_id}/figures/{name}",
    dependencies=[Viewer],
    response_class=Response,
    responses={200: {"content": {m: {} for m in _MEDIA.values()}, "description": "the figure"}},
)
async def get_figure(sweep_id: SweepId, name: FigureName, sweeps: SweepsDep) -> Response:
    """A figure of a completed sweep, as PNG or SVG."""
    data = await sweeps.figure(sweep_id, name)
    return Response(data, media_type=_MEDIA[name.rsplit(".", 1)[-1]])


@router.get(
    "/{sweep_id}/files/{name}",
    dependencies=[Viewer],
    response_class=Response,
    responses={200: {"content": {m: {} for m in SWEEP_FILES.values()}, "description": "the file"}},
)
async def get_file(sweep_id: SweepId, name: FileName, sweeps: SweepsDep) -> Response:
    """A result file of the sweep, as an attachment named `sweep-{id}-{name}`."""
    data = await sweeps.file(sweep_id, name)
    disposition = f'attachment; filename="sweep-{sweep_id}-{name}"'  # names are [a-z.]+
    return Response(
        data, media_type=SWEEP_FILES[name], headers={"content-disposition": disposition}
    )


@router.post("/{sweep_id}/cancel", dependencies=[Operator])
async def cancel_sweep(sweep_id: SweepId, sweeps: SweepsDep) -> SweepRead:
    """Stop a running sweep; its finished runs are kept, so it can be resumed later."""
    return SweepRead.model_validate(await sweeps.cancel(sweep_id))


@router.post("/{sweep_id}/resume", status_code=status.HTTP_202_ACCEPTED, dependencies=[Operator])
async def resume_sweep(sweep_id: SweepId, sweeps: SweepsDep) -> SweepRead:
    """Continue an interrupted, cancelled or failed sweep; finished runs are never repeated."""
    return SweepRead.model_validate(await sweeps.resume(sweep_id))
