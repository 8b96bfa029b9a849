"""Grid sweeps: parsing and validation of --grid, the product of points × policies × seeds,
resume, the runs.csv columns, summary.json per point and the winner map / line plot."""

from __future__ import annotations

import csv
import json
import threading
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path
from typing import Any

import pytest
from typer.testing import CliRunner

from app.cli import cli
from experiments.grid import load_grid_file, make_grid, parse_grid, parse_grid_arg
from experiments.grid_outputs import write_grid_outputs
from experiments.journal import JOURNAL, SweepConflict
from experiments.runner import Progress, run_sweep
from experiments.spec import MAX_RUNS, SpecError, SweepSpec, make_spec
from tests.experiments.exp_fakes import fake_run, fake_spec


def grid_spec(*args: str, policies: str = "1,2,3", seeds: str = "0-4") -> SweepSpec:
    base = fake_spec(policies, seeds)
    return make_spec(base.policies, base.seeds, base.scenario, 1, parse_grid(args))


def crossing_run(scenario: Any, seed: int, policy: str) -> dict[str, Any]:
    """A constructed case: nearest wins by far with slow excavators, fcfs by far with fast
    ones and many haulers, and with fast excavators and few haulers fcfs is ahead by a hair
    (not significant). Excavator distance: coalition always lowest."""
    out = fake_run(scenario, seed, policy)
    fast = scenario.speeds.excavator > 0.5
    many = scenario.team.haulers > 5
    noise = ((seed * 7919 + len(policy) * 104729) % 97) / 97.0 - 0.5  # shared-ish, per seed
    if not fast:
        base = {"fcfs": 1000.0, "coalition": 990.0, "nearest": 800.0}[policy]
        out["makespan_s"] = base + 5 * noise
    elif many:
        base = {"fcfs": 700.0, "coalition": 900.0, "nearest": 950.0}[policy]
        out["makespan_s"] = base + 5 * noise
    else:
        # per seed the order alternates: fcfs lower on average by 1 s, spread 100 s
        sign = 1 if seed % 2 else -1
        base = {"fcfs": 900.0, "coalition": 1200.0, "nearest": 901.0}[policy]
        out["makespan_s"] = base + (100.0 * sign if policy == "nearest" else 0.0)
    out["distance"]["excavator"] = {"fcfs": 800.0, "coalition": 500.0, "nearest": 700.0}[
        policy
    ] + float(seed)
    return out


class Counting:
    def __init__(self, fn: Any = fake_run) -> None:
        self.calls: list[tuple[str, int, float, int]] = []
        self.fn = fn
        self.lock = threading.Lock()

    def __call__(self, scenario: Any, seed: int, policy: str) -> dict[str, Any]:
        with self.lock:
            self.calls.append((policy, seed, scenario.speeds.excavator, scenario.team.haulers))
        result: dict[str, Any] = self.fn(scenario, seed, policy)
        return result


def sweep(spec: SweepSpec, out: Path, fn: Any, **kw: Any) -> Any:
    with ThreadPoolExecutor(2) as ex:
        return run_sweep(spec, out, executor=ex, run_fn=fn, **kw)


# -- parsing and validation ------------------------------------------------------------------


def test_parse_grid_values_are_typed_and_validated() -> None:
    assert parse_grid_arg("speeds.excavator=0.3,0.5,0.8").values == (0.3, 0.5, 0.8)
    assert parse_grid_arg("protocol.busy_bid=once,every_round").values == ("once", "every_round")
    assert parse_grid_arg("crater_radius=[1,3],[2,5]").values == ([1, 3], [2, 5])
    spec = grid_spec("speeds.excavator=1,0.5", "team.haulers=4,6,8")
    assert spec.grid is not None
    # the values as the scenario holds them: 1 → 1.0
    assert spec.grid.params[0].values == (1.0, 0.5)
    assert [pt.as_dict() for pt in spec.grid.points[:2]] == [
        {"speeds.excavator": 1.0, "team.haulers": 4},
        {"speeds.excavator": 1.0, "team.haulers": 6},
    ]
    assert len({pt.hash for pt in spec.grid.points}) == 6
    assert spec.total == 6 * 3 * 5
    pt = spec.grid.points[-1]
    assert pt.scenario.speeds.excavator == 0.5 and pt.scenario.team.haulers == 8
    assert pt.scenario.team.scouts == spec.scenario.team.scouts  # the rest is the base


@pytest.mark.parametrize(
    ("args", "needle"),
    [
        (["speeds.excavatr=0.3"], "--grid speeds.excavatr: unknown scenario field 'excavatr'"),
        (["nope=1"], "--grid nope: unknown scenario field 'nope'"),
        (["team.haulers.x=1"], "--grid team.haulers.x: unknown scenario field"),
        (["speeds.excavator=-1"], "--grid speeds.excavator=-1: speeds.excavator:"),
        (["team.haulers=4,x"], "--grid team.haulers=x: team.haulers:"),
        (["team.haulers=4,4.0"], "--grid team.haulers: value 4 given twice"),
        (["team.haulers=4", "team.haulers=6"], "--grid team.haulers: given twice"),
        (["team.haulers"], "expected PATH=V1,V2"),
        (["team.haulers=4,,6"], "--grid team.haulers: empty value"),
        (["sites=5000"], "--grid sites=5000:"),
    ],
)
def test_bad_grid_raises_a_one_line_error_naming_the_path(args: list[str], needle: str) -> None:
    with pytest.raises(SpecError) as info:
        grid_spec(*args)
    assert needle in str(info.value) and "\n" not in str(info.value)


def test_a_grid_too_large_is_refused() -> None:
    base = fake_spec("1", "0")
    params = [parse_grid_arg(f"speeds.excavator={','.join(str(i) for i in range(1, 101))}")] * 1
    params += [parse_grid_arg(f"team.haulers={','.join(str(i) for i in range(1, 1001))}")]
    params += [parse_grid_arg(f"team.scouts={','.join(str(i) for i in range(1, 101))}")]
    with pytest.raises(SpecError, match="points, more than"):
        make_grid(params, base.scenario, MAX_RUNS)


def test_grid_file_toml_and_json(tmp_path: Path) -> None:
    toml = tmp_path / "grid.toml"
    toml.write_text('speeds.excavator = [0.3, 0.5]\n"team.haulers" = [4, 6]\n')
    assert [(p.path, p.values) for p in load_grid_file(toml)] == [
        ("speeds.excavator", (0.3, 0.5)),
        ("team.haulers", (4, 6)),
    ]
    js = tmp_path / "grid.json"
    js.write_text(json.dumps({"team": {"haulers": [4]}}))
    assert [(p.path, p.values) for p in load_grid_file(js)] == [("team.haulers", (4,))]
    bad = tmp_path / "bad.toml"
    bad.write_text("team.haulers = 4\n")
    with pytest.raises(SpecError, match=r"team\.haulers: expected a non-empty list"):
        load_grid_file(bad)


def invoke(*args: str) -> tuple[int, str]:
    result = CliRunner().invoke(cli, ["sweep", *args])
    return result.exit_code, result.stderr


@pytest.mark.parametrize(
    ("args", "needle"),
    [
        (["--grid", "speeds.excavatr=0.3"], "--grid speeds.excavatr: unknown scenario field"),
        (["--grid", "speeds.excavator=0"], "--grid speeds.excavator=0: speeds.excavator:"),
        (["--grid-file", "/nonexistent/g.toml"], "--grid-file /nonexistent/g.toml"),
    ],
)
def test_cli_bad_grid_exits_2_before_anything_runs(
    args: list[str], needle: str, tmp_path: Path
) -> None:
    code, err = invoke(*args, "--seeds", "0", "--out", str(tmp_path / "out"), "-q")
    assert code == 2
    assert needle in err
    assert err.count("\n") == 1 and err.startswith("regolith sweep: ")
    assert not (tmp_path / "out").exists()


# -- running -----------------------------------------------------------------------------------


def test_every_point_runs_every_policy_and_seed(tmp_path: Path) -> None:
    spec = grid_spec("speeds.excavator=0.3,0.8", "team.haulers=4,6,8", seeds="0-2")
    run = Counting()
    result = sweep(spec, tmp_path, run, outputs=False)
    assert result.ran == 2 * 3 * 3 * 3 == len(run.calls)
    assert sorted(run.calls) == sorted(
        (p, s, v, h)
        for v in (0.3, 0.8)
        for h in (4, 6, 8)
        for p in ("fcfs", "coalition", "nearest")
        for s in range(3)
    )
    lines = [json.loads(x) for x in (tmp_path / JOURNAL).read_text().splitlines()]
    assert {(r["point"]["speeds.excavator"], r["point"]["team.haulers"]) for r in lines} == {
        (v, h) for v in (0.3, 0.8) for h in (4, 6, 8)
    }
    assert json.loads((tmp_path / "sweep.json").read_text())["grid"] == [
        "speeds.excavator",
        "team.haulers",
    ]


def test_interrupted_grid_sweep_resumes_with_only_the_rest(tmp_path: Path) -> None:
    spec = grid_spec("speeds.excavator=0.3,0.8", "team.haulers=4,6")

    def interrupt_after_23(p: Progress) -> None:
        if p.done == 23:
            raise KeyboardInterrupt

    first = Counting()
    with pytest.raises(KeyboardInterrupt):
        sweep(spec, tmp_path, first, progress=interrupt_after_23, outputs=False)
    done = [json.loads(x) for x in (tmp_path / JOURNAL).read_text().splitlines()]
    assert len(done) == 23
    finished = {
        (r["policy"], r["seed"], r["point"]["speeds.excavator"], r["point"]["team.haulers"])
        for r in done
    }
    rest = Counting()
    result = sweep(spec, tmp_path, rest)
    assert result.resumed == 23 and result.ran == 60 - 23 == len(rest.calls)
    assert not finished & set(rest.calls)
    again = Counting()
    assert sweep(spec, tmp_path, again).ran == 0 and again.calls == []


def test_grid_values_extend_but_other_parameters_are_refused(tmp_path: Path) -> None:
    sweep(grid_spec("team.haulers=4,6", seeds="0-1"), tmp_path, Counting(), outputs=False)
    more = Counting()
    result = sweep(grid_spec("team.haulers=4,6,8", seeds="0-1"), tmp_path, more, outputs=False)
    assert result.resumed == 12 and {c[3] for c in more.calls} == {8}
    with pytest.raises(SweepConflict, match=r"over the grid team\.haulers, this one is over"):
        sweep(grid_spec("team.scouts=1,2", seeds="0-1"), tmp_path, Counting(), outputs=False)
    with pytest.raises(SweepConflict, match="this one is over no grid"):
        sweep(fake_spec("1", "0-1"), tmp_path, Counting(), outputs=False)


def test_a_plain_sweep_directory_refuses_a_grid(tmp_path: Path) -> None:
    sweep(fake_spec("1", "0-1"), tmp_path, Counting(), outputs=False)
    with pytest.raises(SweepConflict, match="holds a sweep over no grid"):
        sweep(grid_spec("team.haulers=4,6", seeds="0-1"), tmp_path, Counting(), outputs=False)


# -- outputs -----------------------------------------------------------------------------------


def test_runs_csv_has_one_column_per_grid_parameter(tmp_path: Path) -> None:
    spec = grid_spec("speeds.excavator=0.3,0.8", "team.haulers=4,6", seeds="0-2")
    sweep(spec, tmp_path, crossing_run)
    rows = list(csv.DictReader((tmp_path / "runs.csv").open()))
    assert len(rows) == 4 * 3 * 3
    assert list(rows[0])[:6] == [
        "policy",
        "policy_number",
        "seed",
        "scenario_hash",
        "speeds.excavator",
        "team.haulers",
    ]
    assert [(r["speeds.excavator"], r["team.haulers"]) for r in rows[::9]] == [
        ("0.3", "4"),
        ("0.3", "6"),
        ("0.8", "4"),
        ("0.8", "6"),
    ]
    assert [(r["policy"], r["seed"]) for r in rows[:9]] == [
        (p, str(s)) for p in ("fcfs", "coalition", "nearest") for s in range(3)
    ]
    # makespan_s etc. as in a plain sweep
    assert {"makespan_s", "distance_excavator"} <= set(rows[0])


def test_summary_per_point_and_the_winner_map(tmp_path: Path) -> None:
    spec = grid_spec("speeds.excavator=0.3,0.8", "team.haulers=4,6", seeds="0-7")
    result = sweep(spec, tmp_path, crossing_run)
    summary = json.loads((tmp_path / "summary.json").read_text())
    assert summary["kind"] == "grid" and summary["grid"]["parameters"] == [
        "speeds.excavator",
        "team.haulers",
    ]
    assert [p["values"] for p in summary["points"]] == [
        {"speeds.excavator": v, "team.haulers": h} for v in (0.3, 0.8) for h in (4, 6)
    ]
    mk = [p["winners"]["makespan"] for p in summary["points"]]
    assert [(w["policy"], w["runner_up"], w["significant"]) for w in mk] == [
        ("nearest", "coalition", True),
        ("nearest", "coalition", True),
        ("fcfs", "nearest", False),  # fast excavators, few haulers: a hair, not significant
        ("fcfs", "coalition", True),
    ]
    assert all(
        p["winners"]["excavator_distance"]["policy"] == "coalition" for p in summary["points"]
    )
    # each point's summary is a plain sweep's
    point = summary["points"][0]["summary"]
    assert point["metrics"]["makespan_s"]["per_policy"]["nearest"]["n"] == 8
    for stem in (
        "grid_winner_makespan__speeds-excavator__team-haulers",
        "grid_winner_excavator_distance__speeds-excavator__team-haulers",
    ):
        for ext in ("png", "svg"):
            assert (tmp_path / "figures" / f"{stem}.{ext}").stat().st_size > 1000
            assert tmp_path / "figures" / f"{stem}.{ext}" in result.files
    report = (tmp_path / "report.md").read_text()
    assert "figures/grid_winner_makespan__speeds-excavator__team-haulers.png" in report
    assert "| speeds.excavator=0.8, team.haulers=4 | Policy 1 (fcfs) |" in report


def test_the_winner_map_colours_cells_by_winner() -> None:
    from matplotlib.colors import to_rgb

    from experiments.figures import COLORS
    from experiments.grid_figures import Cell, MapPanel, build_winner_map

    cells = {(0, 0): Cell(2, "P3", "P2", 0.001, True), (0, 1): Cell(0, "P1", "P3", 0.4, False)}
    fig = build_winner_map(
        "t", "x", ["a", "b"], "y", ["c"], [MapPanel("", cells)], ["1", "2", "3"], "p"
    )
    img = fig.axes[0].images[0].get_array()
    assert tuple(img[0, 0]) == pytest.approx(to_rgb(COLORS[2]))
    pale = tuple(img[0, 1])
    assert pale != pytest.approx(to_rgb(COLORS[0])) and min(pale) > 0.6  # pale: not significant
    texts = [t.get_text() for t in fig.axes[0].texts]
    assert "P3\nvs P2\np=0.001" in texts and "P1\nvs P3\np=0.40 n.s." in texts


def test_one_parameter_gives_a_line_plot(tmp_path: Path) -> None:
    spec = grid_spec("team.haulers=4,6,8", seeds="0-3")
    sweep(spec, tmp_path, crossing_run)
    assert (tmp_path / "figures" / "grid_makespan.png").stat().st_size > 1000
    assert (tmp_path / "figures" / "grid_makespan.svg").is_file()
    names = [f["name"] for f in json.loads((tmp_path / "summary.json").read_text())["figures"]]
    assert names == ["grid_makespan", "grid_excavator_distance"]


def test_three_parameters_give_a_map_per_pair_with_panels(tmp_path: Path) -> None:
    spec = grid_spec("speeds.excavator=0.3,0.8", "team.haulers=4,6", "team.scouts=1,2", seeds="0-1")
    records = sweep(spec, tmp_path, crossing_run, outputs=False).records
    files = write_grid_outputs(spec, records, tmp_path)
    pngs = sorted(f.name for f in files if f.suffix == ".png")
    assert len(pngs) == 3 * 2  # 3 pairs × (makespan, excavator distance)
    assert "grid_winner_makespan__team-haulers__team-scouts.png" in pngs


def test_no_grid_sweep_is_unchanged(tmp_path: Path) -> None:
    spec = fake_spec("1,3", "0-2")
    assert spec.grid is None and spec.total == 6
    sweep(spec, tmp_path, fake_run)
    rows = list(csv.DictReader((tmp_path / "runs.csv").open()))
    assert list(rows[0])[:5] == ["policy", "policy_number", "seed", "scenario_hash", "status"]
    manifest = json.loads((tmp_path / "sweep.json").read_text())
    assert "grid" not in manifest
    summary = json.loads((tmp_path / "summary.json").read_text())
    assert "kind" not in summary and "points" not in summary
    assert all("point" not in json.loads(x) for x in (tmp_path / JOURNAL).read_text().splitlines())
