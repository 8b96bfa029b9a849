"""`regolith run`: one JSON object with the documented keys, repeatable, clear errors."""

import json
import subprocess
import sys
from pathlib import Path

import pytest
from typer.testing import CliRunner

from app.cli import cli
from engine.policies import unused_number

REQUIRED = {
    "policy", "seed", "completed", "makespan_s", "sites_found", "sites_total",
    "minerals_delivered", "minerals_total", "distance", "auction_open_s", "auctions", "bids",
    "declines", "messages", "wall_s", "failures", "reauctions", "minerals_dropped",
    "minerals_recovered", "messages_lost", "sites_found_at", "lower_bound_s",
    "lower_bound_apriori_s", "lower_bound_term", "makespan_ratio", "makespan_ratio_apriori",
}  # fmt: skip


def regolith(*args: str) -> subprocess.CompletedProcess[str]:
    return subprocess.run(
        [sys.executable, "-c", "from app.cli import main; main()", *args],
        capture_output=True,
        text=True,
        timeout=120,
    )


def test_json_is_one_object_with_every_key_and_repeats_but_for_wall_time():
    first, second = (regolith("run", "--policy", "2", "--seed", "3", "--json") for _ in range(2))
    assert first.returncode == 0, first.stderr
    a, b = json.loads(first.stdout), json.loads(second.stdout)
    assert a.keys() >= REQUIRED
    assert a["policy"] == "coalition" and a["completed"] is True
    assert set(a["distance"]) == {"scout", "excavator", "hauler"}
    assert set(a["auction_open_s"]["scout_excavator"]) == {"count", "mean", "p50", "max"}
    assert a.pop("wall_s") > 0 and b.pop("wall_s") > 0  # the machine's time, beside the figures
    # both makespan lower bounds: the run's own discovery times, and the world's a priori
    assert len(a["sites_found_at"]) == a["sites_total"] and None not in a["sites_found_at"]
    assert a["lower_bound_apriori_s"] < a["lower_bound_s"] <= a["makespan_s"]
    assert a["makespan_ratio"] == a["makespan_s"] / a["lower_bound_s"]
    assert a["makespan_ratio_apriori"] == a["makespan_s"] / a["lower_bound_apriori_s"]
    assert a == b


def test_faults_on_the_command_line_reach_the_json():
    out = regolith(
        "run", "--policy", "fcfs", "--seed", "1", "--json", "--loss", "0.2",
        "--fail", "hauler-2@400", "--fail", "excavator-1@700:graceful",
        "--enable", "hauler-2@900", "--add", "excavator@500",
    )  # fmt: skip
    assert out.returncode == 0, out.stderr
    m = json.loads(out.stdout)
    assert m["completed"] and m["minerals_delivered"] == 64
    assert m["failures"] == 1 and m["messages_lost"] > 0
    assert m["lower_bound_s"] is None and m["lower_bound_apriori_s"] is None  # faults: none


def test_the_human_summary_names_the_figures():
    out = CliRunner().invoke(cli, ["run", "--policy", "3", "--seed", "0"])
    assert out.exit_code == 0
    assert "makespan" in out.output and "64/64 delivered" in out.output
    bound = next(ln for ln in out.output.splitlines() if "lower bound" in ln)
    assert "per run" in bound and "a priori" in bound


@pytest.mark.parametrize(
    ("args", "says"),
    [
        (["--policy", str(unused_number()), "--seed", "1"], "policy"),
        (["--policy", "1", "--seed", "1", "--scale", "0"], "--scale"),
        (["--policy", "1", "--seed", "1", "--loss", "2"], "loss"),
        (["--policy", "1", "--seed", "1", "--fail", "hauler-2"], "--fail"),
        (["--policy", "1", "--seed", "1", "--fail", "hauler-2@5:sideways"], "mode"),
        (["--policy", "1", "--seed", "1", "--add", "rover@5"], "--add"),
        (["--policy", "1", "--seed", "1", "--fail", "hauler-99@5"], "hauler-99"),
        (["--policy", "1", "--seed", "1", "--scenario", "missing.toml"], "missing.toml"),
    ],
)
def test_bad_arguments_give_one_line_and_exit_2(args, says):
    out = CliRunner().invoke(cli, ["run", *args])
    assert out.exit_code == 2, out.output
    lines = [ln for ln in out.output.splitlines() if ln.strip()]
    assert any(says in ln for ln in lines), out.output
    assert "Traceback" not in out.output


def test_a_bad_scenario_file_names_the_field(tmp_path: Path):
    bad = tmp_path / "bad.toml"
    bad.write_text("minerals = 3\nsites = 5\n[team]\nhaulers = 0\n")
    out = CliRunner().invoke(cli, ["run", "--policy", "1", "--seed", "0", "--scenario", str(bad)])
    assert out.exit_code == 2
    assert "team.haulers" in out.output


@pytest.mark.parametrize(
    ("name", "text"), [("bad.json", '{"width": -1}'), ("bad.toml", "width = -1\n")]
)
def test_a_bad_value_in_a_scenario_file_names_the_file(tmp_path: Path, name: str, text: str):
    bad = tmp_path / name
    bad.write_text(text)
    out = CliRunner().invoke(cli, ["run", "--policy", "1", "--scenario", str(bad)])
    assert out.exit_code == 2
    assert out.output.strip() == (
        f"regolith run: scenario file {bad}: width: Input should be greater than 0"
    ), out.output


@pytest.mark.parametrize(
    ("text", "says"),
    [
        ("crater_radius = [0.0001, 0.0004]\n", "crater_radius"),  # once a 500 and a traceback
        ("crater_radius = [1.0, 5000.0]\n", "crater_radius"),
        ("[protocol]\nheartbeat_s = 1e-300\nfailure_timeout_s = 1e-299\n", "heartbeat_s"),
        ("[speeds]\nhauler = 1e-310\n", "speeds.hauler"),
        ("start_spread = 100\n", "sites"),  # valid alone, but no world fits: still exit 2
    ],
)
def test_a_scenario_that_cannot_run_is_one_line_and_exit_2(tmp_path: Path, text: str, says: str):
    path = tmp_path / "s.toml"
    path.write_text(text)
    out = CliRunner().invoke(cli, ["run", "--policy", "1", "--seed", "0", "--scenario", str(path)])
    assert out.exit_code == 2, out.output
    lines = [ln for ln in out.output.splitlines() if ln.strip()]
    assert len(lines) == 1 and lines[0].startswith("regolith run: ") and says in lines[0], (
        out.output
    )


def test_the_exact_planner_is_never_longer_and_a_bad_planner_is_one_line():
    runs = {
        p: regolith("run", "--policy", "4", "--seed", "0", "--planner", p, "--json")
        for p in ("ompl", "exact")
    }
    figures = {p: json.loads(r.stdout) for p, r in runs.items()}
    assert figures["exact"]["planner"] == "exact" and figures["exact"]["completed"] is True
    # same world and spiral; shortest paths make the scouts' sweep no longer than RRT-Connect's
    assert figures["exact"]["distance"]["scout"] <= figures["ompl"]["distance"]["scout"]
    bad = regolith("run", "--policy", "4", "--seed", "0", "--planner", "astar")
    assert bad.returncode == 2 and "--planner" in bad.stderr


def test_the_offline_reference_runs_from_the_command_line():
    out = regolith("run", "--policy", "offline", "--seed", "0", "--json")
    assert out.returncode == 0, out.stderr
    m = json.loads(out.stdout)
    assert m["policy"] == "offline" and m["completed"] and m["minerals_delivered"] == 64
    assert m["lower_bound_s"] <= m["makespan_s"]


def test_the_realism_options_reach_the_summary_and_their_errors_name_the_field(tmp_path: Path):
    """docs/model.md: a scenario with the options on prints their figures; a bad option value
    is one line naming the field, exit 2."""
    scen = tmp_path / "small-real.toml"
    scen.write_text(
        "width = 40.0\nheight = 40.0\nsites = 2\nminerals = 4\nrandom_craters = 0\n"
        "[team]\nscouts = 1\nexcavators = 1\nhaulers = 2\n"
        "[docks]\nenabled = true\n[energy]\nenabled = true\n"
        "[radio]\nenabled = true\nrange_m = 15.0\nbase_range_m = 20.0\n"
    )
    out = CliRunner().invoke(cli, ["run", "--policy", "1", "--seed", "0", "--scenario", str(scen)])
    assert out.exit_code == 0, out.output
    for line in ("energy (kJ)", "charging (s)", "dock queue", "radio           reach"):
        assert line in out.output
    scen.write_text("[radio]\nenabled = true\nhops = 0\n")
    out = CliRunner().invoke(cli, ["run", "--policy", "1", "--seed", "0", "--scenario", str(scen)])
    assert out.exit_code == 2
    assert "radio.hops" in out.output and len(out.output.strip().splitlines()) == 1
