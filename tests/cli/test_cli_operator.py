"""What an operator sees: one-line usage errors, readable help, progress on a terminal, and an
exit code that says whether the mission completed."""

from __future__ import annotations

import io
import json
import os
import pty
import re
import subprocess
import sys
from pathlib import Path

import pytest
from typer.testing import CliRunner

from app.cli import cli
from app.cli.progress import ProgressLine, run_with_progress
from engine import reference_scenario, run_mission

SHORT = "max_time_s = 600\n"  # the reference mission needs ~3,000 s: this one times out


def regolith(*args: str, **kw: object) -> subprocess.CompletedProcess[str]:
    cmd = [sys.executable, "-c", "from app.cli import main; main()", *args]
    return subprocess.run(cmd, capture_output=True, text=True, timeout=120, **kw)  # type: ignore[call-overload]


@pytest.mark.parametrize(
    ("args", "says"),
    [
        (["run", "--seed", "1"], "missing option '--policy'"),
        (["run", "--policy", "1", "--seed", "x"], "'--seed'"),
        (["run", "--policy", "1", "--seed", "-1"], "'--seed'"),
        (["run", "--polcy", "1"], "no such option: --polcy"),
        (["sweep", "--seeds", "0-1"], "missing option '--out'"),
        (["sweep", "--out", "x", "--scale", "two"], "'--scale'"),
        (["serve", "--port", "http"], "'--port'"),
        (["db", "upgrade", "--bogus"], "no such option: --bogus"),
        (["nope"], "no such command 'nope'"),
    ],
)
def test_usage_errors_are_one_line_in_one_format(args: list[str], says: str) -> None:
    out = CliRunner().invoke(cli, args)
    assert out.exit_code == 2, out.output
    lines = out.stderr.strip().splitlines()
    command = " ".join(
        ["regolith", *[a for a in args[:2] if a in ("run", "sweep", "serve", "db", "upgrade")]]
    )
    assert len(lines) == 1 and lines[0].startswith(f"{command}: "), out.stderr
    assert says in lines[0] and lines[0].endswith(f"(see {command} --help)"), lines[0]


@pytest.mark.parametrize("command", [["run"], ["sweep"], ["serve"], ["db", "upgrade"]])
def test_help_shows_readable_placeholders(command: list[str]) -> None:
    out = CliRunner().invoke(cli, [*command, "--help"], env={"COLUMNS": "200"})
    assert out.exit_code == 0, out.output
    assert re.search(r"<[a-z][^>]*>", out.output) is None, out.output  # no <list[str]>, <int range>
    if command == ["run"]:
        assert re.search(r"--seed N +Seed .*\[default: 0", out.output), out.output


def test_seed_defaults_to_0() -> None:
    a = json.loads(CliRunner().invoke(cli, ["run", "--policy", "1", "--json"]).stdout)
    assert a["seed"] == 0 and a["completed"] is True


def test_a_mission_that_does_not_complete_exits_1_with_its_figures(tmp_path: Path) -> None:
    (tmp_path / "short.toml").write_text(SHORT)
    for extra in (["--json"], []):
        out = CliRunner().invoke(
            cli, ["run", "--policy", "2", "--scenario", str(tmp_path / "short.toml"), *extra]
        )
        assert out.exit_code == 1, out.output
        if extra:
            m = json.loads(out.stdout)
            assert m["status"] == "timeout" and not m["completed"]
        else:
            assert "timeout" in out.stdout.splitlines()[0]


def test_progress_on_a_terminal_only(tmp_path: Path) -> None:
    (tmp_path / "short.toml").write_text(SHORT)
    args = ["run", "--policy", "1", "--scenario", str(tmp_path / "short.toml")]
    piped = regolith(*args)  # stderr is a pipe: nothing but the summary
    assert piped.returncode == 1 and piped.stderr == "" and "timeout" in piped.stdout

    main, tty = pty.openpty()  # stderr a terminal: the progress line, rewritten in place
    try:
        cmd = [sys.executable, "-c", "from app.cli import main; main()", *args]
        proc = subprocess.run(cmd, stdout=subprocess.PIPE, stderr=tty, text=True, timeout=120)
        os.close(tty)
        shown = b""
        while True:
            try:
                chunk = os.read(main, 65536)
            except OSError:  # the terminal's other side is closed: all read
                break
            if not chunk:
                break
            shown += chunk
    finally:
        os.close(main)
    assert proc.returncode == 1 and "timeout" in proc.stdout
    updates = shown.decode().split("\r")
    assert any(
        re.match(r"t [\d,]+ s simulated \| minerals \d+/64 \| sites \d+/10 \| ", u) for u in updates
    ), shown
    assert b" of 600 s" not in shown  # the timeout cap is no estimate of the end
    assert shown.endswith(b"\r\x1b[K")  # erased at the end: the terminal is left clean

    json_out = regolith(*args, "--json")  # --json: stdout is one object, stderr stays empty
    assert json_out.stderr == "" and json.loads(json_out.stdout)["status"] == "timeout"


def test_the_run_shown_with_progress_is_the_same_run() -> None:
    scen = reference_scenario()
    data = scen.model_dump()
    data["bus"] = {**data["bus"], "loss": 0.2}
    from engine import parse_scenario

    lossy = parse_scenario(data)
    actions = [
        {"t": 400.0, "kind": "disable_robot", "args": {"name": "hauler-2", "mode": "abrupt"}},
        {"t": 900.0, "kind": "enable_robot", "args": {"name": "hauler-2"}},
        {"t": 500.0, "kind": "add_robot", "args": {"type": "excavator"}},
    ]
    screen = io.StringIO()
    shown = run_with_progress(lossy, 3, "coalition", actions, ProgressLine(screen, every_s=0))
    assert shown == run_mission(lossy, 3, "coalition", actions)
    steps = screen.getvalue().split("\r")
    assert len(steps) > 100 and "minerals 64/64" in steps[-2]  # the last update before erasing
