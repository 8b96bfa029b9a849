"""A grid of scenario overrides: every policy × seed at every point of a cartesian product.

`--grid speeds.excavator=0.3,0.5,0.8 --grid team.haulers=4,6,8` (or a `--grid-file`) names
scenario fields by dotted path and the values to try; the points are the product of the
value lists, the first parameter varying slowest. Each point is the base scenario with those
fields replaced, validated like any scenario, so its content hash (what the journal keys a
run by) identifies the point. Parsing and validation raise `SpecError` with one line that
names the path, before anything runs.
"""

from __future__ import annotations

import itertools
import json
import tomllib
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from pydantic import BaseModel, ValidationError

from experiments.spec import SpecError, scenario_dict, scenario_hash


@dataclass(frozen=True)
class GridParam:
    """One grid parameter: a dotted scenario path and the raw values to try, in order."""

    path: str
    values: tuple[Any, ...]


@dataclass(frozen=True)
class GridPoint:
    """One point: the parameter values (as the validated scenario holds them) and its scenario."""

    index: int
    values: tuple[tuple[str, Any], ...]
    scenario: Any
    hash: str

    def as_dict(self) -> dict[str, Any]:
        return dict(self.values)

    @property
    def label(self) -> str:
        return ", ".join(f"{p}={fmt_value(v)}" for p, v in self.values)


@dataclass(frozen=True)
class Grid:
    """The parameters (their validated values) and every point, in product order."""

    params: tuple[GridParam, ...]
    points: tuple[GridPoint, ...]

    @property
    def paths(self) -> list[str]:
        return [p.path for p in self.params]

    def point(self, scenario_hash: str) -> GridPoint:
        for pt in self.points:
            if pt.hash == scenario_hash:
                return pt
        raise KeyError(scenario_hash)


def fmt_value(v: Any) -> str:
    """A value as a user would type it: 0.5, 4, true, once, [2.0,5.0]."""
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, float):
        return f"{v:g}"
    if isinstance(v, str):
        return v
    return json.dumps(v, separators=(",", ":"))


def _split(text: str) -> list[str]:
    """Split on commas outside brackets, so `crater_radius=[1,3],[2,5]` gives two values."""
    parts, depth, cur = [], 0, ""
    for ch in text:
        if ch in "[{":
            depth += 1
        elif ch in "]}":
            depth -= 1
        if ch == "," and depth == 0:
            parts.append(cur.strip())
            cur = ""
        else:
            cur += ch
    parts.append(cur.strip())
    return parts


def _literal(text: str) -> Any:
    """`0.3` → 0.3, `4` → 4, `true` → True, `[2,5]` → [2, 5]; anything else stays text."""
    try:
        return json.loads(text)
    except json.JSONDecodeError:
        return text


def parse_grid_arg(text: str) -> GridParam:
    """`speeds.excavator=0.3,0.5,0.8` → GridParam (syntax only; paths are checked later)."""
    path, sep, values = text.partition("=")
    path = path.strip()
    if not sep or not path or not values.strip():
        raise SpecError(f"--grid {text!r}: expected PATH=V1,V2,… e.g. speeds.excavator=0.3,0.5")
    parts = _split(values)
    if any(not p for p in parts):
        raise SpecError(f"--grid {path}: empty value in {values!r}")
    return GridParam(path, tuple(_literal(p) for p in parts))


def load_grid_file(path: str | Path) -> list[GridParam]:
    """A .toml or .json file whose leaves are value lists, addressed by their dotted path.

    `[speeds]` + `excavator = [0.3, 0.5]`, `speeds.excavator = [0.3, 0.5]` and
    `"speeds.excavator" = [0.3, 0.5]` all name the same parameter.
    """
    p = Path(path)
    try:
        raw = p.read_text(encoding="utf-8")
        if p.suffix.lower() == ".toml":
            data = tomllib.loads(raw)
        elif p.suffix.lower() == ".json":
            data = json.loads(raw)
        else:
            raise SpecError(f"--grid-file {p}: must end in .toml or .json")
    except OSError as exc:
        raise SpecError(f"--grid-file {p}: {exc.strerror or exc}") from None
    except (tomllib.TOMLDecodeError, json.JSONDecodeError, UnicodeDecodeError) as exc:
        msg = str(exc).splitlines()[0] if str(exc) else type(exc).__name__
        raise SpecError(f"--grid-file {p}: not valid {p.suffix[1:].upper()}: {msg}") from None
    if not isinstance(data, dict) or not data:
        raise SpecError(f"--grid-file {p}: must hold a table of PATH = [values]")
    out: list[GridParam] = []

    def walk(prefix: str, node: Mapping[str, Any]) -> None:
        for key, value in node.items():
            name = f"{prefix}.{key}" if prefix else str(key)
            if isinstance(value, dict):
                walk(name, value)
            elif isinstance(value, list) and value:
                out.append(GridParam(name, tuple(value)))
            else:
                raise SpecError(f"--grid-file {p}: {name}: expected a non-empty list of values")

    walk("", data)
    return out


def check_path(path: str, model: type[BaseModel]) -> None:
    """Every segment must be a field of the model it lands in; else name the path."""
    node: Any = model
    for i, part in enumerate(path.split(".")):
        fields = getattr(node, "model_fields", None) if isinstance(node, type) else None
        if fields is None:
            parent = ".".join(path.split(".")[:i])
            raise SpecError(f"--grid {path}: unknown scenario field ({parent} has no fields)")
        if part not in fields:
            where = ".".join(path.split(".")[:i]) or "the scenario"
            known = ", ".join(fields)
            raise SpecError(
                f"--grid {path}: unknown scenario field {part!r} (known in {where}: {known})"
            )
        node = fields[part].annotation


def _set(data: dict[str, Any], path: str, value: Any) -> None:
    parts = path.split(".")
    node = data
    for part in parts[:-1]:
        node = node[part]
    node[parts[-1]] = value


def _get(data: Mapping[str, Any], path: str) -> Any:
    node: Any = data
    for part in path.split("."):
        node = node[part]
    return node


def _errors(exc: ValidationError) -> str:
    parts = []
    for err in exc.errors():
        loc = ".".join(str(p) for p in err["loc"]) or "scenario"
        parts.append(f"{loc}: {err['msg']}")
    return "; ".join(parts)


def make_grid(params: Sequence[GridParam], base: BaseModel, max_points: int) -> Grid:
    """Validate every path and every point's scenario; the values as the scenario holds them.

    A value the scenario rejects on its own names the path and the value; a combination it
    rejects (e.g. too many sites for a small area) names the point.
    """
    if not params:
        raise SpecError("--grid: no parameters")
    model = type(base)
    seen: set[str] = set()
    for prm in params:
        check_path(prm.path, model)
        if prm.path in seen:
            raise SpecError(f"--grid {prm.path}: given twice")
        if any(prm.path.startswith(o + ".") or o.startswith(prm.path + ".") for o in seen):
            raise SpecError(f"--grid {prm.path}: overlaps another grid parameter")
        seen.add(prm.path)
    n = 1
    for prm in params:
        n *= len(prm.values)
    if n > max_points:
        raise SpecError(f"--grid: {n} points, more than {max_points}")
    base_data = scenario_dict(base)
    # each value alone first, so an error names one path and one value
    canon: list[tuple[Any, ...]] = []
    for prm in params:
        vals: list[Any] = []
        for v in prm.values:
            data = json.loads(json.dumps(base_data))
            _set(data, prm.path, v)
            try:
                scen = model.model_validate(data)
            except ValidationError as exc:
                raise SpecError(f"--grid {prm.path}={fmt_value(v)}: {_errors(exc)}") from None
            cv = _get(scenario_dict(scen), prm.path)
            if cv in vals:
                raise SpecError(f"--grid {prm.path}: value {fmt_value(v)} given twice")
            vals.append(cv)
        canon.append(tuple(vals))
    checked = tuple(GridParam(p.path, vals) for p, vals in zip(params, canon, strict=True))
    points = []
    for i, combo in enumerate(itertools.product(*canon)):
        data = json.loads(json.dumps(base_data))
        for prm, v in zip(checked, combo, strict=True):
            _set(data, prm.path, v)
        values = tuple((p.path, v) for p, v in zip(checked, combo, strict=True))
        try:
            scen = model.model_validate(data)
        except ValidationError as exc:
            label = ", ".join(f"{p}={fmt_value(v)}" for p, v in values)
            raise SpecError(f"--grid point {label}: {_errors(exc)}") from None
        points.append(GridPoint(i, values, scen, scenario_hash(scen)))
    return Grid(checked, tuple(points))


def parse_grid(args: Iterable[str], file: str | Path | None = None) -> list[GridParam]:
    """Every `--grid` argument and the `--grid-file`'s parameters, in that order."""
    params = [parse_grid_arg(a) for a in args]
    if file is not None:
        params += load_grid_file(file)
    return params
