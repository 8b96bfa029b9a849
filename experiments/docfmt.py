"""Reading a finished sweep's files and formatting its numbers for the docs' generated blocks."""

from __future__ import annotations

import csv
import json
import statistics
from dataclasses import dataclass
from functools import cached_property
from pathlib import Path
from typing import Any

SUPERSCRIPT = str.maketrans("-0123456789", "⁻⁰¹²³⁴⁵⁶⁷⁸⁹")
SHORT = {"central-greedy": "central", "coalition-relaxed": "relaxed"}


@dataclass
class Sweep:
    """One experiment's output folder: runs.csv, summary.json, sweep.json."""

    path: Path

    @cached_property
    def summary(self) -> dict[str, Any]:
        data: dict[str, Any] = json.loads((self.path / "summary.json").read_text())
        return data

    @cached_property
    def manifest(self) -> dict[str, Any]:
        data: dict[str, Any] = json.loads((self.path / "sweep.json").read_text())
        return data

    @cached_property
    def rows(self) -> list[dict[str, str]]:
        with (self.path / "runs.csv").open(newline="") as fh:
            return list(csv.DictReader(fh))

    @property
    def policies(self) -> list[str]:
        return [p["name"] for p in self.summary["policies"]]

    def label(self, name: str) -> str:
        for p in self.summary["policies"]:
            if p["name"] == name:
                return str(p["label"])
        return name

    def short(self, name: str) -> str:
        for p in self.summary["policies"]:
            if p["name"] == name and p["number"]:
                return f"P{p['number']}"
        return SHORT.get(name, name)

    def stat(self, column: str, policy: str, key: str = "mean") -> float:
        return float(self.summary["metrics"][column]["per_policy"][policy][key])

    def half(self, column: str, policy: str) -> float:
        lo, hi = self.summary["metrics"][column]["per_policy"][policy]["ci95"]
        return (float(hi) - float(lo)) / 2 if lo is not None else 0.0

    def pair(self, column: str, a: str, b: str) -> dict[str, Any]:
        """The comparison a − b (flipped if stored as b − a)."""
        for c in self.summary["metrics"][column]["pairwise"]:
            if (c["a"], c["b"]) == (a, b):
                return dict(c)
            if (c["a"], c["b"]) == (b, a):
                flipped = dict(c)
                for k in ("mean_diff", "paired_mean_diff", "paired_median_diff"):
                    flipped[k] = -c[k] if c[k] is not None else None
                lo, hi = c["paired_ci95"]
                flipped["paired_ci95"] = [-hi, -lo]
                flipped["a_lower"], flipped["b_lower"] = c["b_lower"], c["a_lower"]
                flipped["a"], flipped["b"] = a, b
                return flipped
        raise KeyError((column, a, b))

    def values(self, column: str, policy: str) -> dict[int, float]:
        """Per seed, a completed run's value."""
        return {
            int(r["seed"]): float(r[column])
            for r in self.rows
            if r["policy"] == policy and r["status"] == "completed" and r[column] != ""
        }

    def mean_of(self, policy: str, fn: Any) -> list[float]:
        """fn(row) over a policy's completed runs."""
        return [fn(r) for r in self.rows if r["policy"] == policy and r["status"] == "completed"]

    @property
    def build(self) -> str:
        return str(self.manifest["engine"])

    @property
    def seed_text(self) -> str:
        seeds = self.summary["seeds"]
        return f"{seeds[0]}–{seeds[-1]}" if seeds == list(range(seeds[0], seeds[-1] + 1)) else "…"


def num(x: float, digits: int = 1) -> str:
    return f"{x:,.{digits}f}"


def pm(sweep: Sweep, column: str, policy: str, digits: int = 1) -> str:
    mean, half = sweep.stat(column, policy), sweep.half(column, policy)
    if sweep.stat(column, policy, "std") == 0:
        return num(mean, digits)
    return f"{num(mean, digits)} ± {num(half, digits)}"


def pval(p: float | None) -> str:
    """A p-value: three decimals, or as a power of ten below 0.001."""
    if p is None:
        return "–"
    if p >= 0.001:
        return f"{p:.3f}"
    if p == 0.0:
        return "< 10⁻³⁰⁰"
    mant, exp = f"{p:.1e}".split("e")
    return f"{mant} × 10{str(int(exp)).translate(SUPERSCRIPT)}"


def mean(xs: list[float]) -> float:
    return statistics.fmean(xs) if xs else float("nan")


def table(header: list[str], rows: list[list[str]]) -> str:
    lines = ["| " + " | ".join(header) + " |", "| " + " | ".join("---" for _ in header) + " |"]
    lines += ["| " + " | ".join(r) + " |" for r in rows]
    return "\n".join(lines) + "\n"


def last_found(row: dict[str, str]) -> float:
    found = json.loads(row["sites_found_at"])
    return float(max(found))
