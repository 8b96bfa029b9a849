"""`regolith fleet run` as a person sees it: a summary in `regolith run`'s layout on stdout
(not a JSON blob), and on a terminal the progress on stderr while it runs, erased at the end.
A tiny scenario (three agents, two minerals) at 100×."""

from __future__ import annotations

import os
import pty
import re
import subprocess
import sys
from pathlib import Path

import pytest

from tests.field.pace import paced
from tests.field.serial import one_field_mission_at_a_time

ROOT = Path(__file__).resolve().parents[2]
TINY = """name = "tiny"
width = 30.0
height = 30.0
sites = 1
minerals = 2
random_craters = 0
[team]
scouts = 1
excavators = 1
haulers = 1
"""


@pytest.mark.slow
@pytest.mark.fleet
def test_fleet_run_prints_a_summary_and_shows_progress_on_a_terminal(tmp_path: Path) -> None:
    (tmp_path / "tiny.toml").write_text(TINY)
    cmd = [sys.executable, "-c", "from app.cli import main; main()", "fleet", "run"]
    speed = f"{paced(100.0):g}"
    cmd += ["--policy", "nearest", "--speed", speed, "--scenario", str(tmp_path / "tiny.toml")]
    main, tty = pty.openpty()
    try:
        with one_field_mission_at_a_time():
            proc = subprocess.Popen(cmd, cwd=ROOT, stdout=subprocess.PIPE, stderr=tty, text=True)
            os.close(tty)
            shown = b""
            while True:  # read the terminal as it goes: its buffer must never fill
                try:
                    chunk = os.read(main, 65536)
                except OSError:  # the other side closed: all read
                    break
                if not chunk:
                    break
                shown += chunk
            out = proc.stdout.read() if proc.stdout else ""
            assert proc.wait() == 0, (out, shown)
    finally:
        os.close(main)
    lines = out.splitlines()
    assert lines[0] == f"policy nearest, seed 0, scenario tiny, field mode at {speed}x: completed"
    assert "  minerals        2/2 delivered" in lines and "  sites found     1/1" in lines
    assert any(ln.startswith("  processes       3 agents started") for ln in lines), out
    assert not out.lstrip().startswith("{")  # a summary, not JSON
    updates = shown.decode().split("\r")
    assert any(
        re.match(r"t [\d,]+ s simulated \| minerals \d/2 \| sites \d/1 \| ", u) for u in updates
    ), shown
    assert shown.endswith(b"\r\x1b[K")
