"""Scenarios: the reference one, as a template for `POST /api/missions` bodies, and the
reader that turns an uploaded scenario file (TOML or JSON) into that JSON."""

from __future__ import annotations

import json
import tomllib
from typing import Any

from fastapi import APIRouter
from fastapi.exceptions import RequestValidationError
from pydantic import ValidationError
from starlette.concurrency import run_in_threadpool

from app.api.deps import Operator, ServicesDep, Viewer
from app.api.schemas import ScenarioFile
from app.services.scenario_limits import check_size
from engine import Scenario, reference_scenario

router = APIRouter(prefix="/scenarios", tags=["scenarios"], dependencies=[Viewer])


@router.get("/reference")
async def reference() -> Scenario:
    """The reference scenario (docs/spec.md §2) with every default spelled out."""
    return reference_scenario()


def _invalid(loc: tuple[str | int, ...], msg: str) -> RequestValidationError:
    return RequestValidationError([{"loc": loc, "msg": msg, "type": "value_error"}])


def _read(body: ScenarioFile) -> Scenario:
    """The file's text parsed (`tomllib` or `json`) and validated as a `Scenario`."""
    kind = body.format.upper()
    try:
        data: Any = tomllib.loads(body.text) if body.format == "toml" else json.loads(body.text)
    except RecursionError:
        raise _invalid(("body", "text"), f"not valid {kind}: nested too deeply") from None
    except ValueError as exc:  # TOMLDecodeError and JSONDecodeError say the line
        raise _invalid(("body", "text"), f"not valid {kind}: {exc}") from None
    if not isinstance(data, dict):
        raise _invalid(("body", "text"), "the file must hold one table/object at the top level")
    try:
        return Scenario.model_validate(data)
    except ValidationError as exc:
        # named like the same scenario's errors in `POST /api/missions` (body.scenario.…)
        raise RequestValidationError(
            [
                {"loc": ("body", "scenario", *e["loc"]), "msg": e["msg"], "type": e["type"]}
                for e in exc.errors()
            ]
        ) from None


@router.post("/parse", dependencies=[Operator])
async def parse(body: ScenarioFile, services: ServicesDep) -> Scenario:
    """An uploaded scenario file's text (TOML by default, or JSON) as the validated
    `Scenario` to send as `POST /api/missions`' `scenario`, every default spelled out; 422
    naming the field (`body.scenario.team.haulers`) or, for a file that does not parse,
    `body.text` with the line. Operators only: it serves the start form and costs CPU."""
    scenario = await run_in_threadpool(_read, body)
    check_size(services.settings, scenario)
    return scenario
