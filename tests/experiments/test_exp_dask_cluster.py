"""`regolith sweep --scheduler` on a real Dask cluster (a scheduler and two workers, each its
own process on 127.0.0.1), one worker killed with SIGKILL mid-sweep: the sweep completes with
every run exactly once and the same runs.csv as a local sweep."""

from __future__ import annotations

import json
import os
import signal
import socket
import subprocess
import sys
import time
from collections import Counter
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path

import pytest

from engine import reference_scenario
from experiments.bound import engine_bound

BIN = Path(sys.executable).parent
POLICIES, SEEDS = "1,4", "0-5"


def free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])


def regolith(*args: str) -> subprocess.Popen[str]:
    return subprocess.Popen(
        [sys.executable, "-c", "from app.cli import main; main()", *args],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )


def wait_until(check, timeout: float, what: str) -> None:  # type: ignore[no-untyped-def]
    deadline = time.monotonic() + timeout
    while not check():
        if time.monotonic() > deadline:
            pytest.fail(f"timed out waiting for {what}")
        time.sleep(0.05)


@contextmanager
def cluster(tmp: Path) -> Iterator[tuple[str, list[subprocess.Popen[bytes]]]]:
    """`dask scheduler` and two `dask worker --no-nanny` processes (a worker's pid is the pid
    its runs record), torn down whatever happens."""
    address = f"tcp://127.0.0.1:{free_port()}"
    port = address.rsplit(":", 1)[1]
    logs = (tmp / "dask.log").open("w")
    dask = str(BIN / "dask")
    procs = [
        subprocess.Popen(
            [dask, "scheduler", "--host", "127.0.0.1", "--port", port, "--no-dashboard"],
            stdout=logs,
            stderr=logs,
        )
    ]
    try:
        for _ in range(2):
            procs.append(
                subprocess.Popen(
                    [dask, "worker", address, "--nthreads", "1", "--no-nanny", "--no-dashboard",
                     "--host", "127.0.0.1"],
                    stdout=logs,
                    stderr=logs,
                )
            )  # fmt: skip
        yield address, procs[1:]
    finally:
        for p in procs[::-1]:
            if p.poll() is None:
                p.kill()
            p.wait(timeout=10)
        logs.close()


def test_a_killed_worker_loses_and_duplicates_no_run(tmp_path: Path) -> None:
    local = regolith("sweep", "--policies", POLICIES, "--seeds", SEEDS, "--out",
                     str(tmp_path / "local"), "--workers", "2")  # fmt: skip
    assert local.wait(timeout=300) == 0, local.stderr.read() if local.stderr else ""
    out = tmp_path / "dask"
    journal = out / "runs.jsonl"
    with cluster(tmp_path) as (address, workers):
        sweep = regolith("sweep", "--policies", POLICIES, "--seeds", SEEDS, "--out", str(out),
                         "--scheduler", address)  # fmt: skip
        pids = {w.pid: w for w in workers}

        def recorded_pids() -> Counter[int]:
            if not journal.exists():
                return Counter()
            lines = journal.read_text().splitlines()
            return Counter(json.loads(x)["pid"] for x in lines if x.endswith("}"))

        # kill a worker once it has finished a run, while the sweep still has runs to do
        wait_until(lambda: any(p in pids for p in recorded_pids()), 120, "a worker's first run")
        victim = next(p for p in recorded_pids() if p in pids)
        os.kill(victim, signal.SIGKILL)
        pids[victim].wait(timeout=10)
        before = recorded_pids()
        code = sweep.wait(timeout=300)
        err = sweep.stderr.read() if sweep.stderr else ""
        assert code == 0, err
    assert sum(before.values()) < 12, "the worker died after the sweep ended: not a mid-sweep kill"
    records = [json.loads(x) for x in journal.read_text().splitlines()]
    keys = Counter((r["policy"], r["seed"]) for r in records)
    assert len(keys) == 12 and set(keys.values()) == {1}  # every run, each exactly once
    survivor = next(p for p in pids if p != victim)
    assert Counter(r["pid"] for r in records)[survivor] >= 12 - before[victim]
    assert recorded_pids()[victim] == before[victim]  # nothing from the dead worker afterwards
    for name in ("runs.csv", "bounds.csv"):  # the same figures as the local sweep, byte for byte
        assert (out / name).read_bytes() == (tmp_path / "local" / name).read_bytes()
    header = (out / "runs.csv").read_text().splitlines()[0]
    assert "makespan_ratio" in header and "makespan_ratio_apriori" in header
    for rec in records:  # both lower bounds hold on the reference scenario
        bound = engine_bound(reference_scenario(), rec["seed"])
        assert bound.value <= rec["metrics"]["makespan_s"]
