"""The attrition bench refuses what it cannot run, with exit code 2 and a message that names the
option, before it starts any mission."""

import subprocess
import sys
from pathlib import Path

import pytest

from tests.progress import START_S

BENCH = Path(__file__).parents[2] / "bench" / "attrition_bench.py"


@pytest.mark.parametrize(
    ("args", "named"),
    [
        (["--each", "1"], "--each"),
        (["--seeds", "0"], "--seeds"),
        (["--policies", "fcfs,nosuch"], "nosuch"),
    ],
)
def test_bad_input_exits_2_naming_it(args: list[str], named: str) -> None:
    out = subprocess.run(
        [sys.executable, str(BENCH), *args], capture_output=True, text=True, timeout=START_S
    )
    assert out.returncode == 2, out
    assert named in out.stderr and "Traceback" not in out.stderr
