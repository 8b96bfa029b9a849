"""Every experiment docs/experiments.md and docs/policies.md cite, rerun from scratch.

    python -m experiments.reproduce                 # `make reproduce`: rerun into a temporary
                                                    # folder, check every cited number
    python -m experiments.reproduce --write         # `make results`: rerun (resuming in
                                                    # sweeps/reproduce/), rewrite results/, the
                                                    # docs' generated blocks and their figures

Each experiment is a sweep (`experiments.runner.run_sweep`). Every measured number in the two
docs sits in a generated block (`<!-- generated:NAME -->` … `<!-- /generated:NAME -->`)
rendered from the sweeps' results by `experiments.docblocks`; checking re-renders every
block from the fresh run and compares it with the docs number by number
(`experiments.blocks`), and compares each fresh `runs.csv` with the committed one.

The policy list of the reference sweep lives here, in `REFERENCE_POLICIES`, and nowhere else.
"""

from __future__ import annotations

import argparse
import json
import shutil
import subprocess
import sys
import tempfile
import time
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

ROOT = Path(__file__).resolve().parent.parent
RESULTS = ROOT / "results"
DOCS = ("docs/experiments.md", "docs/policies.md")
FIGURES = ROOT / "docs" / "img" / "experiments"

REFERENCE_POLICIES = "1,2,3,4,5,0,6"
"""The reference sweep's policies, in table order: the one place to add a policy to it."""
STUDY_POLICIES = "1,2,3,5"
"""The study's three policies and the relaxed Policy 2 (for context): the findings' sweeps."""
REALISM_SCENARIOS = (
    ("energy", "scenarios/realism/energy.toml"),
    ("docks", "scenarios/realism/docks.toml"),
    ("uncertainty", "scenarios/realism/uncertainty.toml"),
    ("radio", "scenarios/realism/radio.toml"),
    ("all", "scenarios/lunar-realistic.toml"),
)
"""The cost of realism (docs/experiments.md): each option alone, then all four together."""
GRID_POLICIES = "1,2,3"
GRID_SEEDS = "0-9"


@dataclass(frozen=True)
class Experiment:
    name: str
    policies: str
    seeds: str
    grid: tuple[str, ...] = ()
    variants: bool = False  # the policies are ablation variants (experiments.ablations)
    scenario: str | None = None  # a scenario file under the repository (None: the reference)
    keep: tuple[str, ...] = ("runs.csv", "summary.json", "sweep.json")

    @property
    def command(self) -> str:
        """The plain `regolith sweep` that runs the same sweep (variants: none does)."""
        if self.variants:
            return f"experiments.reproduce: variants {self.policies}, seeds {self.seeds}"
        grid = "".join(f" --grid {g}" for g in self.grid)
        scenario = f" --scenario {self.scenario}" if self.scenario else ""
        return f"regolith sweep --policies {self.policies} --seeds {self.seeds}{scenario}{grid}"


EXPERIMENTS: tuple[Experiment, ...] = (
    Experiment("reference", REFERENCE_POLICIES, "0-99"),
    Experiment("heldout", STUDY_POLICIES, "1000-1099"),
    Experiment(
        "ablations",
        "no-lead,no-time-bids-no-queue,first-auction-only,central-greedy-no-lead",
        "0-29",
        variants=True,
    ),
    Experiment(
        "grid-speeds",
        GRID_POLICIES,
        GRID_SEEDS,
        ("speeds.excavator=0.25,0.5,1.0", "speeds.hauler=0.4,0.8,1.6"),
    ),
    Experiment(
        "grid-dig-scouts",
        GRID_POLICIES,
        GRID_SEEDS,
        ("timing.dig_s=5,20,80", "team.scouts=1,2,4"),
    ),
    Experiment(
        "grid-team", GRID_POLICIES, GRID_SEEDS, ("team.excavators=2,4,8", "team.haulers=3,6,12")
    ),
    Experiment(
        "grid-bid-sites",
        GRID_POLICIES,
        GRID_SEEDS,
        ("protocol.bid_window_s=0.2,1,5", "sites=5,10,20"),
    ),
    *(
        Experiment(f"realism/{option}", REFERENCE_POLICIES, "0-99", scenario=file)
        for option, file in REALISM_SCENARIOS
    ),
)


def experiment_spec(exp: Experiment) -> Any:
    from engine import POLICY_NAMES, load_scenario, reference_scenario, resolve_policy
    from experiments.ablations import VARIANTS
    from experiments.grid import parse_grid
    from experiments.spec import PolicyRef, make_spec, parse_policies, parse_seeds

    if exp.variants:
        names = exp.policies.split(",")
        unknown = [n for n in names if n not in VARIANTS]
        if unknown:
            raise ValueError(f"unknown ablation variants {unknown}")
        pols = tuple(PolicyRef(0, n) for n in names)
    else:
        pols = parse_policies(exp.policies, resolve_policy, POLICY_NAMES)
    grid = parse_grid(list(exp.grid)) if exp.grid else None
    scenario = load_scenario(ROOT / exp.scenario) if exp.scenario else reference_scenario()
    return make_spec(pols, parse_seeds(exp.seeds), scenario, 1, grid)


def run_experiment(exp: Experiment, out: Path, workers: int | None = None) -> float:
    """Run (or resume) one experiment's sweep in out/NAME; return its wall time."""
    from experiments.ablations import run_variant
    from experiments.runner import run_sweep

    t0 = time.perf_counter()
    run_sweep(
        experiment_spec(exp),
        out / exp.name,
        workers=workers,
        run_fn=run_variant if exp.variants else None,
    )
    return time.perf_counter() - t0


def run_all(
    out: Path,
    experiments: tuple[Experiment, ...] = EXPERIMENTS,
    workers: int | None = None,
    say: Callable[[str], None] = print,
) -> dict[str, float]:
    walls: dict[str, float] = {}
    for exp in experiments:
        say(f"reproduce: {exp.name}: {exp.command}")
        walls[exp.name] = wall = run_experiment(exp, out, workers)
        say(f"reproduce: {exp.name}: {wall:.0f} s")
    return walls


def git_commit() -> str | None:
    try:
        out = subprocess.run(
            ["git", "-C", str(ROOT), "describe", "--always", "--dirty", "--abbrev=12"],
            capture_output=True,
            text=True,
            check=True,
        )
    except (OSError, subprocess.CalledProcessError):
        return None
    return out.stdout.strip() or None


def write_results(out: Path, results: Path = RESULTS) -> None:
    """Copy each experiment's kept files to results/NAME and record the build they came from."""
    from experiments.worker import engine_fingerprint

    for exp in EXPERIMENTS:
        dest = results / exp.name
        dest.mkdir(parents=True, exist_ok=True)
        for f in exp.keep:
            shutil.copyfile(out / exp.name / f, dest / f)
        if exp.grid:
            summary = json.loads((dest / "summary.json").read_text())
            (dest / "summary.json").write_text(json.dumps(trim_grid(summary), indent=1) + "\n")
        elif exp.scenario:
            summary = json.loads((dest / "summary.json").read_text())
            (dest / "summary.json").write_text(json.dumps(trim_metrics(summary), indent=1) + "\n")
    builds = sorted(
        {json.loads((out / e.name / "sweep.json").read_text())["engine"] for e in EXPERIMENTS}
    )
    manifest = {
        "engine_build": builds[0] if len(builds) == 1 else builds,
        "renderer_engine_build": engine_fingerprint(),
        "source": git_commit(),
        "note": "engine_build is the hash of engine/*.py the runs were made with (from their "
        "sweep.json); source is `git describe --dirty` of the tree that wrote these files, "
        "renderer_engine_build its engine's hash",
        "experiments": [
            {"name": e.name, "command": e.command, "seeds": e.seeds} for e in EXPERIMENTS
        ],
    }
    (results / "manifest.json").write_text(json.dumps(manifest, indent=2) + "\n")


GRID_METRICS = ("makespan_s", "distance_excavator", "auction_open_s_excavator_hauler_mean")


def trim_grid(summary: dict[str, Any]) -> dict[str, Any]:
    """A grid's summary.json with each point's statistics cut to the metrics the docs cite
    (the full one is ~1 MB per grid; runs.csv beside it has every run)."""
    for pt in summary["points"]:
        metrics = pt["summary"]["metrics"]
        pt["summary"]["metrics"] = {k: v for k, v in metrics.items() if k in GRID_METRICS}
    summary["trimmed"] = f"each point's metrics cut to {', '.join(GRID_METRICS)}"
    return summary


REALISM_METRICS = ("makespan_s", "minerals_delivered")


def trim_metrics(summary: dict[str, Any]) -> dict[str, Any]:
    """A realism sweep's summary.json with its metrics cut to those the docs cite (the full
    one is ~1.5 MB; runs.csv beside it has every run, and the blocks read that)."""
    summary["metrics"] = {k: v for k, v in summary["metrics"].items() if k in REALISM_METRICS}
    summary["trimmed"] = f"metrics cut to {', '.join(REALISM_METRICS)}"
    return summary


def copy_figures(out: Path, dest: Path = FIGURES) -> None:
    """The reference sweep's figures, each grid's winner maps and the cost of realism, as the
    docs show them."""
    from experiments import realism_cost

    dest.mkdir(parents=True, exist_ok=True)
    realism_cost.figure(realism_cost.load(out), dest / "realism-cost.png")
    for png in sorted((out / "reference" / "figures").glob("*.png")):
        shutil.copyfile(png, dest / png.name)
    for exp in EXPERIMENTS:
        if exp.grid:
            for png in sorted((out / exp.name / "figures").glob("grid_winner_*.png")):
                shutil.copyfile(png, dest / f"{exp.name}__{png.name}")


def compare_runs(
    out: Path, results: Path = RESULTS, experiments: tuple[Experiment, ...] = EXPERIMENTS
) -> list[str]:
    """Each fresh runs.csv against the committed one: the first differing cell of each."""
    import csv

    problems = []
    for exp in experiments:
        old_path, new_path = results / exp.name / "runs.csv", out / exp.name / "runs.csv"
        if not old_path.exists():
            problems.append(f"results/{exp.name}/runs.csv: missing (run `make results`)")
            continue
        with old_path.open() as a, new_path.open() as b:
            old, new = list(csv.reader(a)), list(csv.reader(b))
        if old == new:
            continue
        if old[0] != new[0]:
            problems.append(f"results/{exp.name}/runs.csv: columns differ from the fresh run's")
            continue
        if len(old) != len(new):
            problems.append(
                f"results/{exp.name}/runs.csv: {len(old) - 1} rows, fresh {len(new) - 1}"
            )
            continue
        for i, (ro, rn) in enumerate(zip(old, new, strict=True)):
            for col, vo, vn in zip(old[0], ro, rn, strict=True):
                if vo != vn:
                    problems.append(
                        f"results/{exp.name}/runs.csv row {i} ({_who(old[0], ro)}), "
                        f"column {col}: committed {vo}, fresh {vn}"
                    )
                    break
            else:
                continue
            break
    return problems


def build_note(out: Path, experiments: tuple[Experiment, ...]) -> str:
    """Which engine builds made the committed results and the fresh run (a different build
    that reproduces every number is fine: the check is on the numbers)."""
    committed = json.loads((RESULTS / "manifest.json").read_text()).get("engine_build")
    fresh = sorted(
        {json.loads((out / e.name / "sweep.json").read_text())["engine"] for e in experiments}
    )
    same = fresh == [committed]
    return f"reproduce: engine build {', '.join(fresh)} (fresh) vs {committed} (results/): " + (
        "the same" if same else "different builds"
    )


def _who(header: list[str], row: list[str]) -> str:
    r = dict(zip(header, row, strict=True))
    point = "".join(f", {h} {r[h]}" for h in header[3 : header.index("scenario")] if "." in h)
    return f"{r.get('policy')} seed {r.get('seed')}{point}"


def main(argv: list[str] | None = None) -> int:
    from experiments.blocks import check_docs, write_docs
    from experiments.docblocks import render_blocks

    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--write", action="store_true", help="regenerate results/, blocks, figures")
    ap.add_argument("--out", type=Path, help="where the sweeps run (default: a temporary folder)")
    ap.add_argument("--workers", type=int, default=None)
    ap.add_argument(
        "--only",
        help="comma-separated experiment names: rerun only these; the docs are checked with "
        "the committed results of the others (not with --write)",
    )
    ap.add_argument(
        "--no-run",
        action="store_true",
        help="run nothing: render (and check or write) from the finished sweeps in --out",
    )
    args = ap.parse_args(argv)
    if args.no_run and args.out is None:
        ap.error("--no-run needs --out, the folder of finished sweeps")
    chosen = EXPERIMENTS
    if args.only:
        names = [n.strip() for n in args.only.split(",")]
        known = {e.name for e in EXPERIMENTS}
        if args.write or not set(names) <= known:
            ap.error(f"--only: names from {', '.join(sorted(known))}, and not with --write")
        chosen = tuple(e for e in EXPERIMENTS if e.name in names)
    t0 = time.perf_counter()
    with tempfile.TemporaryDirectory(prefix="regolith-reproduce-") as tmp:
        out = args.out or (ROOT / "sweeps" / "reproduce" if args.write else Path(tmp))
        if not args.no_run:
            run_all(out, chosen, workers=args.workers)
        for exp in EXPERIMENTS:
            if exp not in chosen:
                (out / exp.name).mkdir(parents=True, exist_ok=True)
                for f in exp.keep:
                    shutil.copyfile(RESULTS / exp.name / f, out / exp.name / f)
        blocks = render_blocks(out)
        if args.write:
            write_results(out)
            copy_figures(out)
            changed = write_docs(ROOT, DOCS, blocks)
            print(f"reproduce: wrote results/, figures and {changed} changed blocks")
            problems: list[str] = []
        else:
            problems = check_docs(ROOT, DOCS, blocks) + compare_runs(out, experiments=chosen)
            print(build_note(out, chosen))
    total = time.perf_counter() - t0
    if problems:
        for p in problems:
            print(f"reproduce: MISMATCH {p}", file=sys.stderr)
        print(f"reproduce: FAILED, {len(problems)} mismatches ({total:.0f} s)", file=sys.stderr)
        return 1
    if not args.write:
        print(f"reproduce: OK, every generated number matches the fresh run ({total:.0f} s)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
