"""`regolith sweep` argument errors: one line on stderr, exit status 2, nothing run."""

from __future__ import annotations

from pathlib import Path

import pytest
from typer.testing import CliRunner

from app.cli import cli
from engine.policies import unused_number

UNKNOWN = unused_number()  # a number no policy holds


def invoke(*args: str) -> tuple[int, str]:
    result = CliRunner().invoke(cli, ["sweep", *args])
    return result.exit_code, result.stderr


@pytest.mark.parametrize(
    ("args", "needle"),
    [
        (["--seeds", "5-2"], "--seeds '5-2': range 5-2 is empty"),
        (["--seeds", "x"], "--seeds 'x'"),
        (["--policies", str(UNKNOWN)], f"--policies: unknown policy '{UNKNOWN}'"),
        (["--policies", "1,nope"], "unknown policy 'nope'"),
        (["--scale", "0"], "--scale 0"),
        (["--workers", "0"], "--workers 0"),
        (["--planner", "astar"], "--planner 'astar': expected one of ompl, exact, straight"),
        (["--scenario", "/nonexistent/s.toml"], "scenario file"),
    ],
)
def test_bad_arguments_exit_2_with_one_line(args: list[str], needle: str, tmp_path: Path) -> None:
    code, err = invoke(*args, "--out", str(tmp_path / "out"))
    assert code == 2
    assert needle in err
    assert err.count("\n") == 1 and err.startswith("regolith sweep: ")
    assert not (tmp_path / "out").exists()


def test_out_dir_of_another_scenario_exits_2(tmp_path: Path) -> None:
    out = tmp_path / "out"
    out.mkdir()
    (out / "sweep.json").write_text('{"scenario_hash": "0000", "scenario_name": "other"}')
    code, err = invoke("--seeds", "0", "--policies", "1", "--out", str(out), "-q")
    assert code == 2 and "another scenario" in err and err.count("\n") == 1
    assert not (out / "runs.jsonl").exists()
