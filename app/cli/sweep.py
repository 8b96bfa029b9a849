"""`regolith sweep`: every policy × seed, in parallel, resumable, summarized with figures."""

from __future__ import annotations

import sys
from contextlib import ExitStack
from pathlib import Path
from typing import Annotated, Any, NoReturn

import typer

from app.cli.errors import USAGE_EXIT, fail
from engine import policy_help


def _fail(message: str, code: int = USAGE_EXIT) -> NoReturn:
    fail("sweep", message, code)


def sweep(
    out: Annotated[
        Path, typer.Option("--out", metavar="DIR", help="Directory for the journal and results.")
    ],
    policies: Annotated[
        str,
        typer.Option(
            "--policies",
            metavar="LIST",
            help=f"Policy numbers or names, e.g. 1,2,3; registered: {policy_help()}.",
        ),
    ] = "1,2,3",
    seeds: Annotated[
        str, typer.Option("--seeds", metavar="SEEDS", help="Seeds, e.g. 0-99 or 1,5,9.")
    ] = "0-9",
    scenario: Annotated[
        Path | None,
        typer.Option(
            "--scenario", metavar="FILE", help="Scenario .toml/.json (default: reference)."
        ),
    ] = None,
    scale: Annotated[
        int, typer.Option("--scale", metavar="K", help="K× team, sites and area.")
    ] = 1,
    planner: Annotated[
        str,
        typer.Option(
            "--planner",
            metavar="NAME",
            help="Path planner: ompl (RRT-Connect), exact (shortest paths; for scale) or straight.",
        ),
    ] = "ompl",
    workers: Annotated[
        int | None,
        typer.Option("--workers", metavar="N", help="Local processes (default: all cores)."),
    ] = None,
    scheduler: Annotated[
        str | None,
        typer.Option(
            "--scheduler", metavar="ADDRESS", help="Run on a Dask cluster, e.g. tcp://host:8786."
        ),
    ] = None,
    grid: Annotated[
        list[str] | None,
        typer.Option(
            "--grid",
            metavar="PATH=V1,V2",
            help="Scenario override to sweep, PATH=V1,V2,… e.g. speeds.excavator=0.3,0.5; "
            "repeat for a cartesian product.",
        ),
    ] = None,
    grid_file: Annotated[
        Path | None,
        typer.Option(
            "--grid-file",
            metavar="FILE",
            help="Grid parameters from a .toml/.json: PATH = [values].",
        ),
    ] = None,
    quiet: Annotated[bool, typer.Option("--quiet", "-q", help="No progress bar.")] = False,
) -> None:
    """Compare policies over many seeds: runs.csv, summary.json, figures and report.md.

    Re-running with the same --out continues an interrupted sweep and never repeats a run.
    With --grid, every policy × seed runs at every point of the grid.
    """
    from experiments.grid import parse_grid
    from experiments.journal import SweepConflict
    from experiments.runner import SweepError, run_sweep
    from experiments.spec import SpecError, make_spec, parse_policies, parse_seeds

    try:
        from engine import (
            POLICY_NAMES,
            ScenarioError,
            load_scenario,
            reference_scenario,
            resolve_policy,
        )
    except ImportError as exc:  # pragma: no cover - only while the engine is being built
        _fail(f"the engine is not available: {exc}", 1)

    if workers is not None and workers < 1:
        _fail(f"--workers {workers}: must be at least 1")
    if out.exists() and not out.is_dir():
        _fail(f"--out {out}: exists and is not a directory")
    try:
        pols = parse_policies(policies, resolve_policy, POLICY_NAMES)
        seed_list = parse_seeds(seeds)
        if scale < 1:
            raise SpecError(f"--scale {scale}: must be a whole number >= 1")
        params = parse_grid(grid or [], grid_file)
        scen = load_scenario(scenario) if scenario else reference_scenario()
        spec = make_spec(pols, seed_list, scen.scaled(scale), scale, params, planner)
    except (SpecError, ScenarioError) as exc:
        _fail(str(exc))

    with ExitStack() as stack:
        executor: Any = None
        if scheduler:
            executor = stack.enter_context(_DaskExecutor(scheduler))
        bar = None if quiet else stack.enter_context(_ProgressBar(spec.total))
        try:
            result = run_sweep(spec, out, progress=bar, executor=executor, workers=workers)
        except SweepConflict as exc:
            _fail(str(exc))
        except SweepError as exc:
            _fail(f"{exc}; finished runs are saved, re-run to retry the rest", 1)
        except KeyboardInterrupt:
            if bar is not None:
                bar.stop()
            _fail(f"interrupted; finished runs are saved in {out}, re-run to continue", 130)
    where = f" at {len(spec.grid.points)} grid points" if spec.grid is not None else ""
    typer.echo(
        f"{spec.total} runs{where} ({result.ran} new, {result.resumed} resumed) in "
        f"{result.elapsed_s:.1f} s → {out}/report.md"
    )


class _DaskExecutor:
    """A Dask cluster's concurrent.futures executor; the client closes on exit."""

    def __init__(self, address: str) -> None:
        self.address = address
        self.client: Any = None

    def __enter__(self) -> Any:
        try:
            from distributed import Client
        except ImportError:  # pragma: no cover - dask[distributed] is a dependency
            _fail("--scheduler needs dask[distributed] installed", 1)
        try:
            self.client = Client(self.address, timeout="10s")  # type: ignore[no-untyped-call]
        except (OSError, TimeoutError, ValueError) as exc:
            _fail(f"--scheduler {self.address}: cannot connect ({exc})")
        return self.client.get_executor(pure=False)

    def __exit__(self, *exc: object) -> None:
        self.client.close()


class _ProgressBar:
    """A rich progress bar on stderr fed by run_sweep's progress callback."""

    def __init__(self, total: int) -> None:
        from rich.console import Console
        from rich.progress import (
            BarColumn,
            MofNCompleteColumn,
            Progress,
            TextColumn,
            TimeElapsedColumn,
        )

        self._progress = Progress(
            TextColumn("sweep"),
            BarColumn(),
            MofNCompleteColumn(),
            TextColumn("runs"),
            TimeElapsedColumn(),
            TextColumn("ETA {task.fields[eta]}"),
            TextColumn("{task.fields[last]}"),
            console=Console(file=sys.stderr),
            transient=False,
        )
        self._task = self._progress.add_task("sweep", total=total, last="", eta="-:--:--")

    def __enter__(self) -> _ProgressBar:
        self._progress.start()
        return self

    def __exit__(self, *exc: object) -> None:
        self.stop()

    def stop(self) -> None:
        self._progress.stop()

    def __call__(self, p: Any) -> None:
        last = f"last: {p.last.policy} seed {p.last.seed}" if p.last else ""
        if p.resumed and p.done == p.resumed:
            last = f"{p.resumed} resumed"
        eta = "-:--:--" if p.eta_s is None else _clock(p.eta_s)
        self._progress.update(self._task, completed=p.done, last=last, eta=eta)


def _clock(seconds: float) -> str:
    s = round(seconds)
    return f"{s // 3600}:{s % 3600 // 60:02d}:{s % 60:02d}"


def register(cli: typer.Typer) -> None:
    """Add `sweep` to the `regolith` command line."""
    cli.command(name="sweep")(sweep)
