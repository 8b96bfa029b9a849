"""What a sweep's folder holds, read for the API: runs so far, summary, figures, manifest.

The journal and the derived files are written by `experiments` (in the job's worker
processes); these functions only read them, on the thread pool, never on the event loop.
"""

from __future__ import annotations

import csv
import json
import logging
import math
import os
import stat
import time
from pathlib import Path
from typing import Any

from app.db.models import Sweep as SweepRow
from app.services.errors import Conflict
from experiments.journal import MANIFEST, Journal

log = logging.getLogger("regolith.sweeps")

_FROM_CSV = (
    "lower_bound_s",
    "lower_bound_term",
    "makespan_ratio",
    "lower_bound_apriori_s",
    "makespan_ratio_apriori",
)


def set_aside(out_dir: Path) -> None:
    """A new sweep starts from an empty folder; one left by a lost database is kept aside."""
    if out_dir.exists():
        stale = out_dir.with_name(f"{out_dir.name}.orphan-{int(time.time())}")
        log.warning("sweep folder %s already exists; moved to %s", out_dir, stale)
        out_dir.rename(stale)


def check_build(out_dir: Path, sweep_id: int) -> None:
    """Refuse a resume that would mix two engine builds, before starting a job for it."""
    from experiments.worker import engine_fingerprint

    try:
        pinned = json.loads((out_dir / MANIFEST).read_text(encoding="utf-8")).get("engine")
    except (OSError, ValueError, AttributeError):
        return  # no runs yet: nothing to mix
    if pinned is not None and pinned != engine_fingerprint():
        raise Conflict(
            f"sweep {sweep_id} ran on engine build {pinned}, this server runs "
            f"{engine_fingerprint()}; results of two builds are never mixed: start a new sweep"
        )


def read_results(out_dir: Path, row: SweepRow, completed: bool) -> dict[str, Any]:
    """The runs journaled so far (the `regolith run --json` metrics plus policy and seed) and,
    for a completed sweep, summary.json and each run's lower bound from runs.csv."""
    order = {name: i for i, name in enumerate(row.policies)}
    seeds = set(row.seeds)
    records = [
        r for r in Journal(out_dir).load().values() if r["policy"] in order and r["seed"] in seeds
    ]
    records.sort(key=lambda r: (order[r["policy"]], r["seed"]))
    runs = [{**r.get("metrics", {}), "policy": r["policy"], "seed": r["seed"]} for r in records]
    summary = None
    if completed:
        try:
            summary = json.loads((out_dir / "summary.json").read_text(encoding="utf-8"))
        except (OSError, ValueError):
            summary = None
        _add_bounds(runs, out_dir / "runs.csv")
    return {"runs": runs, "summary": summary}


def _add_bounds(runs: list[dict[str, Any]], path: Path) -> None:
    try:
        with path.open(encoding="utf-8", newline="") as fh:
            rows = {(r["policy"], int(r["seed"])): r for r in csv.DictReader(fh)}
    except (OSError, KeyError, ValueError):
        return
    for run in runs:
        found = rows.get((run["policy"], run["seed"]), {})
        for col in _FROM_CSV:
            if col in found:
                run[col] = _number(found[col]) if found[col] else None


def _number(text: str) -> float | str:
    try:
        value = float(text)
    except ValueError:
        return text
    return value if math.isfinite(value) else text


SWEEP_FILES = {
    "runs.csv": "text/csv",
    "bounds.csv": "text/csv",
    "summary.json": "application/json",
    "report.md": "text/markdown",
}
"""The result files a sweep's folder may hold, each served by `GET /api/sweeps/{id}/files/{name}`
(only these names: nothing else in the folder is reachable)."""


def read_served(root: Path, *parts: str) -> bytes | None:
    """The bytes of `served_file(root, *parts)`, read without following any symlink even
    if one is swapped in after the check: each folder is opened relative to the one before
    with O_NOFOLLOW, then the file, whose own descriptor must be a regular file."""
    if served_file(root, *parts) is None:
        return None
    fds: list[int] = []
    try:
        fds.append(os.open(root.resolve(), os.O_RDONLY | os.O_DIRECTORY))
        for part in parts[:-1]:
            flags = os.O_RDONLY | os.O_DIRECTORY | os.O_NOFOLLOW
            fds.append(os.open(part, flags, dir_fd=fds[-1]))
        flags = os.O_RDONLY | os.O_NOFOLLOW | os.O_NONBLOCK  # a FIFO must not block the open
        fds.append(os.open(parts[-1], flags, dir_fd=fds[-1]))
        if not stat.S_ISREG(os.fstat(fds[-1]).st_mode):
            return None
        with os.fdopen(fds.pop(), "rb") as fh:
            return fh.read()
    except OSError:  # a symlink (ELOOP, ENOTDIR), gone meanwhile, unreadable
        return None
    finally:
        for fd in fds:
            os.close(fd)


def served_file(root: Path, *parts: str) -> Path | None:
    """`root/parts…` if it is a regular file reached without a symlink, else None.

    A sweep's folder is written by worker processes and may be touched by anyone with a shell
    on the host: a symlink placed in it must never let an unauthenticated reader fetch a file
    from elsewhere (the operator token, the database). So every component below `root` is
    checked with lstat (a symlink, a device or a folder is refused) and the resolved path must
    still lie inside `root`; `read_served` then reads it without following a link."""
    base = root.resolve()
    path = base
    for part in parts:
        if not part or part in (".", "..") or os.sep in part or (os.altsep or os.sep) in part:
            return None
        path = path / part
        try:
            mode = path.lstat().st_mode
        except (OSError, ValueError):
            return None
        if stat.S_ISLNK(mode):
            return None
    if not stat.S_ISREG(mode) or not path.resolve().is_relative_to(base):
        return None
    return path


def file_links(out_dir: Path, sweep_id: int) -> list[dict[str, str]]:
    """The result files written so far, with the URLs that serve them."""
    return [
        {"name": name, "url": f"/api/sweeps/{sweep_id}/files/{name}", "media_type": media}
        for name, media in SWEEP_FILES.items()
        if served_file(out_dir, name) is not None
    ]


def figure_links(base: str, summary: dict[str, Any] | None) -> list[dict[str, Any]]:
    """summary.json's figures with the URLs that serve them (`base` + name + .png/.svg)."""
    return [
        {
            "name": f["name"],
            "title": f.get("title", f["name"]),
            "png": f"{base}/{f['name']}.png",
            "svg": f"{base}/{f['name']}.svg",
            "verdict": [str(v) for v in _as_list(f.get("verdict"))],
        }
        for f in (summary or {}).get("figures", [])
    ]


def _as_list(value: Any) -> list[Any]:
    if value is None:
        return []
    return list(value) if isinstance(value, (list, tuple)) else [value]
