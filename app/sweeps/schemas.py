"""Sweep API schemas (`POST /api/sweeps` and its reads), named by role like `app/api/schemas.py`."""

from __future__ import annotations

from datetime import datetime
from typing import Annotated, Any, Literal

from pydantic import BaseModel, ConfigDict, Discriminator, Field, Tag, model_validator

from app.api.schemas import PolicyName, Seed
from app.services.errors import Invalid
from engine import Scenario
from experiments.spec import SpecError, parse_seeds

MAX_SEEDS = 100_000
"""Seeds a request may name at all (the server's run limit is usually far lower); checked
before a seed list is built, so `"0-999999999"` costs nothing."""

SweepStatus = Literal["running", "cancelling", "completed", "cancelled", "failed", "interrupted"]


class _In(BaseModel):
    model_config = ConfigDict(extra="forbid")


class SeedRange(_In):
    """Seeds `from` … `to`, both included."""

    model_config = ConfigDict(extra="forbid", populate_by_name=True)

    start: Seed = Field(alias="from")
    to: Seed

    @model_validator(mode="after")
    def _ordered(self) -> SeedRange:
        if self.to < self.start:
            raise ValueError(f"range {self.start}-{self.to} is empty (from > to)")
        if self.to - self.start >= MAX_SEEDS:
            raise ValueError(f"more than {MAX_SEEDS} seeds")
        return self


SeedText = Annotated[
    str, Field(min_length=1, max_length=1000, description="`0-99`, `7`, `1,5,9` or `0-9,20-29`")
]
SeedList = Annotated[list[Seed], Field(min_length=1, max_length=MAX_SEEDS)]


def _seed_kind(value: Any) -> str | None:
    """Pick the union member by JSON type, so an error names one form, not all three."""
    if isinstance(value, str):
        return "text"
    if isinstance(value, (dict, SeedRange)):
        return "range"
    return "list" if isinstance(value, list) else None


Seeds = Annotated[
    Annotated[SeedText, Tag("text")]
    | Annotated[SeedRange, Tag("range")]
    | Annotated[SeedList, Tag("list")],
    Discriminator(
        _seed_kind,
        custom_error_type="seeds",
        custom_error_message='expected "0-99", "1,5,9", {"from": 0, "to": 99} or a list of seeds',
    ),
]


DEFAULT_POLICIES = (1, 2, 3)
"""The research's three policies: what a sweep compares unless told otherwise."""


class SweepCreate(_In):
    """Every policy on every seed of one scenario (the reference by default), K× scaled."""

    model_config = ConfigDict(
        extra="forbid",
        json_schema_extra={
            "examples": [{"policies": [1, "coalition"], "seeds": "0-1", "scale": 1}]
        },
    )

    policies: Annotated[list[PolicyName], Field(min_length=1, max_length=16)] = Field(
        default_factory=lambda: list(DEFAULT_POLICIES),
        description="numbers or names, e.g. [1, 2, 3]",
        json_schema_extra={"default": list(DEFAULT_POLICIES)},  # the dashboard pre-checks these
    )
    seeds: Seeds = "0-9"
    scale: Annotated[int, Field(strict=True, ge=1, le=16)] = 1
    scenario: Scenario | None = None

    def seed_tuple(self) -> tuple[int, ...]:
        """Sorted unique seeds; a bad text names the field like a validation error."""
        if isinstance(self.seeds, SeedRange):
            return tuple(range(self.seeds.start, self.seeds.to + 1))
        if isinstance(self.seeds, list):
            return tuple(sorted(set(self.seeds)))
        text = self.seeds
        if _count(text) > MAX_SEEDS:
            raise Invalid(f"seeds: more than {MAX_SEEDS} seeds", ("body", "seeds"))
        try:
            return parse_seeds(text)
        except SpecError as exc:
            message = str(exc).removeprefix(f"--seeds {text!r}: ")
            raise Invalid(f"seeds: {message}", ("body", "seeds")) from None


def _count(text: str) -> int:
    """An upper bound on the seeds a text names (0 for parts parse_seeds will reject)."""
    total = 0
    for part in text.split(","):
        lo, sep, hi = part.strip().partition("-")
        try:
            total += int(hi) - int(lo) + 1 if sep else 1
        except ValueError:
            continue
    return total


class SweepRead(BaseModel):
    """A sweep's identity and progress; `done` counts runs resumed from its journal too."""

    id: int
    status: SweepStatus
    policies: list[str]
    seeds: list[int]
    n_seeds: int
    scale: int
    scenario_name: str
    done: int
    total: int
    failed: int
    elapsed_s: float = Field(description="wall time of the current (or last) session")
    eta_s: float | None
    phase: Literal["runs", "figures"] | None = Field(
        None,
        description="while running: `runs`, then `figures` (every run done, the statistics "
        "and figures being written); null once it has ended",
    )
    created_at: datetime
    started_at: datetime | None
    ended_at: datetime | None
    error: str | None = None


class SweepFigure(BaseModel):
    name: str
    title: str
    png: str
    svg: str
    verdict: list[str]


class SweepFile(BaseModel):
    """A result file of the sweep (runs.csv, bounds.csv, summary.json, report.md)."""

    name: str
    url: str
    media_type: str


class SweepDetail(SweepRead):
    """A sweep with its scenario (before scaling), the runs journaled so far (each the
    `regolith run --json` metrics with `policy` and `seed`) and, once completed,
    `summary.json` and the figures' URLs."""

    scenario: dict[str, Any]
    runs: list[dict[str, Any]]
    summary: dict[str, Any] | None
    figures: list[SweepFigure]
    files: list[SweepFile] = Field(description="result files written so far, to download")


class SweepPage(BaseModel):
    items: list[SweepRead]
    total: int
    limit: int
    offset: int
