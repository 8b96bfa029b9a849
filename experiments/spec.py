"""What a sweep is (policies × seeds on one scenario) and the parsing of its arguments.

Parsing lives here rather than in the CLI so the service's `POST /api/sweeps` validates a
request with the same rules and the same one-line messages.
"""

from __future__ import annotations

import hashlib
import json
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    from engine import Scenario
    from experiments.grid import Grid, GridParam

MAX_RUNS = 1_000_000
"""A sweep larger than this is almost certainly a typo in --seeds."""


class SpecError(ValueError):
    """An argument that cannot describe a sweep; the message is one line, fit for a user."""


@dataclass(frozen=True, order=True)
class PolicyRef:
    """A policy as the engine names it, plus its number in the research (0 if unnumbered)."""

    number: int
    name: str

    @property
    def label(self) -> str:
        return f"Policy {self.number} ({self.name})" if self.number else self.name

    @property
    def short(self) -> str:
        return f"P{self.number}" if self.number else self.name


@dataclass(frozen=True)
class SweepSpec:
    """Every policy × every seed on one (already scaled) scenario, or at every point of a grid
    of overrides to it (`experiments.grid`)."""

    policies: tuple[PolicyRef, ...]
    seeds: tuple[int, ...]
    scenario: Scenario
    scale: int = 1
    grid: Grid | None = None
    planner: str = "ompl"
    """The path planner every run plans with (`engine.PLANNERS`): part of what a run is, so
    the manifest pins it like the scenario."""

    @property
    def total(self) -> int:
        points = len(self.grid.points) if self.grid is not None else 1
        return points * len(self.policies) * len(self.seeds)

    @property
    def scenario_hash(self) -> str:
        return scenario_hash(self.scenario)

    def policy(self, name: str) -> PolicyRef:
        for p in self.policies:
            if p.name == name:
                return p
        raise KeyError(name)


def scenario_dict(scenario: Any) -> dict[str, Any]:
    """The scenario as plain JSON data (what the journal and manifest store)."""
    data: dict[str, Any] = scenario.model_dump(mode="json")
    return data


def scenario_hash(scenario: Any) -> str:
    """A short content hash: two scenarios with equal parameters share it, whatever their source."""
    return scenario_data_hash(scenario_dict(scenario))


def scenario_data_hash(data: dict[str, Any]) -> str:
    """`scenario_hash` of a scenario already as JSON data (a stored mission's scenario)."""
    text = json.dumps(data, sort_keys=True, separators=(",", ":"))
    return hashlib.sha256(text.encode("utf-8")).hexdigest()[:16]


MAX_SEED = 2**31 - 1
"""The largest seed, in a sweep as in a mission (`POST /api/missions` takes 0..2^31-1), so any
run of a sweep can be repeated as a live mission."""


def parse_seeds(text: str) -> tuple[int, ...]:
    """`0-99`, `7`, `1,5,9` or `0-9,20-29` → sorted unique seeds."""
    seeds: set[int] = set()
    parts = [p.strip() for p in text.split(",")]
    if not text.strip() or any(not p for p in parts):
        raise SpecError(f"--seeds {text!r}: expected e.g. 0-99 or 1,5,9")
    for part in parts:
        lo_text, sep, hi_text = part.partition("-")
        try:
            lo = int(lo_text)
            hi = int(hi_text) if sep else lo
        except ValueError:
            raise SpecError(
                f"--seeds {text!r}: {part!r} is not a seed or a range like 0-99"
            ) from None
        if lo < 0 or hi < 0:
            raise SpecError(f"--seeds {text!r}: seeds must be non-negative")
        if hi > MAX_SEED:
            raise SpecError(f"--seeds {text!r}: seeds go up to {MAX_SEED} (2^31 - 1)")
        if hi < lo:
            raise SpecError(f"--seeds {text!r}: range {part} is empty (start > end)")
        if hi - lo >= MAX_RUNS:
            raise SpecError(f"--seeds {text!r}: more than {MAX_RUNS} seeds")
        seeds.update(range(lo, hi + 1))
    return tuple(sorted(seeds))


def parse_policies(
    text: str, resolve: Callable[[str], str], numbers: Mapping[int, str]
) -> tuple[PolicyRef, ...]:
    """`1,2,3` or `fcfs,nearest` → policies in the order given, duplicates dropped.

    `resolve` is the engine's `resolve_policy` (raising on unknown names) and `numbers` its
    `POLICY_NAMES`; they are parameters so the service and tests can pass their own.
    """
    by_name = {name: num for num, name in numbers.items()}
    out: list[PolicyRef] = []
    parts = [p.strip() for p in text.split(",")]
    if not text.strip() or any(not p for p in parts):
        raise SpecError(f"--policies {text!r}: expected e.g. 1,2,3")
    for part in parts:
        try:
            name = resolve(part)
        except (KeyError, ValueError, LookupError) as exc:
            known = ", ".join(f"{n}={v}" for n, v in sorted(numbers.items()))
            raise SpecError(f"--policies: unknown policy {part!r} (known: {known})") from exc
        ref = PolicyRef(by_name.get(name, 0), name)
        if ref not in out:
            out.append(ref)
    return tuple(out)


def make_spec(
    policies: tuple[PolicyRef, ...],
    seeds: tuple[int, ...],
    scenario: Scenario,
    scale: int = 1,
    grid: Sequence[GridParam] | None = None,
    planner: str = "ompl",
) -> SweepSpec:
    """Check the whole spec: a sweep of zero runs or of an absurd size is an argument error.

    `grid` (parsed `--grid` parameters) overrides fields of the scaled scenario at every
    point of their product; every point is validated here.
    """
    if scale < 1:
        raise SpecError(f"--scale {scale}: must be a whole number >= 1")
    from engine import PLANNERS

    if planner not in PLANNERS:
        raise SpecError(f"--planner {planner!r}: expected one of {', '.join(PLANNERS)}")
    if not policies or not seeds:
        raise SpecError("a sweep needs at least one policy and one seed")
    if len(policies) * len(seeds) > MAX_RUNS:
        raise SpecError(f"{len(policies)} policies × {len(seeds)} seeds: more than {MAX_RUNS} runs")
    built = None
    if grid:
        from experiments.grid import make_grid

        built = make_grid(grid, scenario, MAX_RUNS // (len(policies) * len(seeds)))
    return SweepSpec(
        policies=policies, seeds=seeds, scenario=scenario, scale=scale, grid=built, planner=planner
    )
