"""The sweep's journal: one JSON line per finished run, fsynced as soon as the run ends.

The journal is the only state a sweep keeps, so an interrupted sweep (Ctrl-C, a killed
machine) loses at most the runs that were still in flight. A torn last line from a crash is
cut off on the next open. Runs are keyed by policy, seed and scenario hash (a grid point's
scenario, with its overrides applied, has its own hash); a directory is bound to one
scenario, and to a grid's parameters, by its manifest (`sweep.json`).
"""

from __future__ import annotations

import json
import os
from collections.abc import Collection, Iterator
from contextlib import contextmanager
from dataclasses import dataclass
from pathlib import Path
from typing import Any

JOURNAL = "runs.jsonl"
MANIFEST = "sweep.json"
LOCK = ".sweep.lock"


class SweepConflict(RuntimeError):
    """The output directory belongs to another scenario or another running sweep."""


@dataclass(frozen=True, order=True)
class RunKey:
    """What identifies a run: the same key means the same bits out of the engine."""

    policy: str
    seed: int
    scenario: str


def record_key(record: dict[str, Any]) -> RunKey:
    return RunKey(str(record["policy"]), int(record["seed"]), str(record["scenario"]))


class Journal:
    """Append-only JSONL file of finished runs in a sweep directory."""

    def __init__(self, out_dir: Path) -> None:
        self.path = out_dir / JOURNAL

    def load(self) -> dict[RunKey, dict[str, Any]]:
        """Every complete record, first one wins if a key somehow appears twice."""
        records: dict[RunKey, dict[str, Any]] = {}
        if not self.path.exists():
            return records
        with self.path.open("r", encoding="utf-8") as fh:
            for line in fh:
                if not line.endswith("\n"):
                    break  # torn last line: the run did not finish being recorded
                try:
                    rec = json.loads(line)
                    key = record_key(rec)
                except (json.JSONDecodeError, KeyError, TypeError, ValueError):
                    continue
                records.setdefault(key, rec)
        return records

    def _repair(self) -> None:
        """Cut a torn last line so the next append starts on a line of its own."""
        if not self.path.exists():
            return
        data = self.path.read_bytes()
        if data and not data.endswith(b"\n"):
            with self.path.open("r+b") as fh:
                fh.truncate(data.rfind(b"\n") + 1)
                fh.flush()
                os.fsync(fh.fileno())

    @contextmanager
    def writer(self) -> Iterator[_Writer]:
        self._repair()
        with self.path.open("a", encoding="utf-8") as fh:
            yield _Writer(fh)


class _Writer:
    def __init__(self, fh: Any) -> None:
        self._fh = fh

    def append(self, record: dict[str, Any]) -> None:
        """Write one record and force it to disk before the next run is reported done."""
        line = json.dumps(record, sort_keys=False, separators=(",", ":"), allow_nan=False)
        self._fh.write(line + "\n")
        self._fh.flush()
        os.fsync(self._fh.fileno())


def check_manifest(
    out_dir: Path,
    scenario_hash: str,
    scenario: dict[str, Any],
    engine: str | None = None,
    grid: list[str] | None = None,
    run_hashes: Collection[str] = (),
    planner: str = "ompl",
) -> None:
    """Bind the directory to this scenario, engine build and planner, or refuse another one's.

    A grid sweep binds it to its base scenario and its grid parameters (`grid`, the dotted
    paths; their values may change like seeds do); its runs carry their points' scenario
    hashes (`run_hashes`), which a journal without a manifest may hold.
    """
    path = out_dir / MANIFEST
    if path.exists():
        try:
            existing = json.loads(path.read_text(encoding="utf-8"))
            found = str(existing["scenario_hash"])
        except (OSError, json.JSONDecodeError, KeyError, TypeError) as exc:
            raise SweepConflict(f"{path}: unreadable sweep manifest ({exc})") from None
        if found != scenario_hash:
            raise SweepConflict(
                f"{out_dir} holds a sweep of another scenario ({existing.get('scenario_name')!r}, "
                f"hash {found}, this one {scenario_hash}); use a new --out"
            )
        pinned = existing.get("engine")
        if engine is not None and pinned is not None and pinned != engine:
            raise SweepConflict(
                f"{out_dir} was swept with another engine build ({pinned}, this one {engine}); "
                "results of two builds must not be mixed: use a new --out"
            )
        found_grid = existing.get("grid")
        if sorted(found_grid or []) != sorted(grid or []):
            raise SweepConflict(
                f"{out_dir} holds a sweep over {_grid_text(found_grid)}, this one is over "
                f"{_grid_text(grid)}; use a new --out"
            )
        found_planner = existing.get("planner", "ompl")  # manifests before --planner: OMPL
        if found_planner != planner:
            raise SweepConflict(
                f"{out_dir} holds a sweep planned with {found_planner!r}, this one with "
                f"{planner!r}; use a new --out"
            )
        return
    others = {k.scenario for k in Journal(out_dir).load()} - {scenario_hash, *run_hashes}
    if others:
        raise SweepConflict(
            f"{out_dir}/{JOURNAL} holds runs of another scenario (hash {sorted(others)[0]}); "
            "use a new --out"
        )
    manifest = {
        "scenario_hash": scenario_hash,
        "engine": engine,
        "scenario_name": scenario.get("name"),
        "scenario": scenario,
        "planner": planner,
    }
    if grid is not None:
        manifest["grid"] = grid
    write_atomic(path, json.dumps(manifest, indent=2) + "\n")


def _grid_text(grid: Any) -> str:
    if not grid:
        return "no grid"
    return "the grid " + " × ".join(str(p) for p in grid)


@contextmanager
def exclusive(out_dir: Path) -> Iterator[None]:
    """Hold an advisory lock so two sweeps never append to one journal at once.

    The lock file is removed when the sweep ends (nothing is left behind in the results),
    while still locked. A sweep that opened it just before, and locks it just after, would
    then hold a lock on a file no longer there, beside a newer sweep's: so a lock counts only
    if the file it is on is still the one at the path, else it is taken again.
    """
    try:
        import fcntl
    except ImportError:  # pragma: no cover - not on POSIX: no lock, single-writer by convention
        yield
        return
    path = out_dir / LOCK
    while True:
        fh = path.open("a")
        try:
            fcntl.flock(fh.fileno(), fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError:
            fh.close()
            raise SweepConflict(f"another sweep is writing to {out_dir}") from None
        try:
            current = path.stat().st_ino
        except FileNotFoundError:
            current = None
        if current == os.fstat(fh.fileno()).st_ino:
            break
        fh.close()  # the previous holder removed it meanwhile: lock the new one
    try:
        yield
    finally:
        path.unlink(missing_ok=True)
        fh.close()  # drops the lock


def write_atomic(path: Path, text: str) -> None:
    """Replace a file in one step, so readers never see half of it."""
    tmp = path.with_name(path.name + ".tmp")
    tmp.write_text(text, encoding="utf-8")
    os.replace(tmp, path)
