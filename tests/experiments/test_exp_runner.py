"""The sweep runner over a fake engine: outputs, resume, interruption, failures, conflicts."""

from __future__ import annotations

import csv
import json
import threading
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path
from typing import Any

import pytest

from engine import reference_scenario
from experiments.journal import JOURNAL, SweepConflict
from experiments.runner import Progress, SweepCancelled, SweepError, run_sweep
from experiments.spec import SweepSpec, make_spec
from tests.experiments.exp_fakes import failing_run, fake_run, fake_spec


class Counting:
    """A run function that counts its calls (threads share it, so no pickling)."""

    def __init__(self, fn: Any = fake_run) -> None:
        self.calls: list[tuple[str, int]] = []
        self.fn = fn
        self.lock = threading.Lock()

    def __call__(self, scenario: Any, seed: int, policy: str) -> dict[str, Any]:
        with self.lock:
            self.calls.append((policy, seed))
        result: dict[str, Any] = self.fn(scenario, seed, policy)
        return result


def sweep(spec: SweepSpec, out: Path, fn: Any, **kw: Any) -> Any:
    with ThreadPoolExecutor(2) as ex:
        return run_sweep(spec, out, executor=ex, run_fn=fn, **kw)


def journal_lines(out: Path) -> list[dict[str, Any]]:
    return [json.loads(line) for line in (out / JOURNAL).read_text().splitlines()]


def test_complete_sweep_writes_every_output(spec: SweepSpec, tmp_path: Path) -> None:
    seen: list[Progress] = []
    result = sweep(spec, tmp_path, Counting(), progress=seen.append)
    assert result.ran == 18 and result.resumed == 0
    assert [p.done for p in seen] == list(range(19)) and seen[-1].eta_s == 0.0
    for name in ("runs.csv", "summary.json", "report.md", "sweep.json"):
        assert (tmp_path / name).is_file()
    for fig in ("makespan", "distance", "auction_open"):
        for ext in ("png", "svg"):
            assert (tmp_path / "figures" / f"{fig}.{ext}").stat().st_size > 1000
    rows = list(csv.DictReader((tmp_path / "runs.csv").open()))
    assert [(r["policy"], int(r["seed"])) for r in rows] == [
        (p, s) for p in ("fcfs", "coalition", "nearest") for s in range(6)
    ]
    assert {"distance_scout", "auction_open_s_scout_excavator_mean", "counts_bids"} <= set(rows[0])
    assert "wall_s" not in rows[0]  # machine time is not a mission metric
    assert rows[0]["sites_found_s"] == "[]" and rows[1]["sites_found_s"] == "[1.0,2.0]"
    summary = json.loads((tmp_path / "summary.json").read_text())
    mk = summary["metrics"]["makespan_s"]
    assert mk["per_policy"]["nearest"]["n"] == 6
    assert len(mk["pairwise"]) == 3
    assert "undefined" not in summary["metrics"]  # NaN in every run: nothing to summarize
    report = (tmp_path / "report.md").read_text()
    assert "![Mission makespan](figures/makespan.png)" in report
    assert "Policy 3 (nearest) has the shortest mean makespan" in report


def test_rerun_of_a_complete_dir_runs_nothing(spec: SweepSpec, tmp_path: Path) -> None:
    sweep(spec, tmp_path, Counting())
    before = (tmp_path / "runs.csv").read_bytes()
    again = Counting()
    result = sweep(spec, tmp_path, again)
    assert again.calls == [] and result.ran == 0 and result.resumed == 18
    assert (tmp_path / "runs.csv").read_bytes() == before
    assert len(journal_lines(tmp_path)) == 18


def test_interrupted_sweep_resumes_with_only_the_rest(spec: SweepSpec, tmp_path: Path) -> None:
    def interrupt_after_7(p: Progress) -> None:
        if p.done == 7:
            raise KeyboardInterrupt

    with pytest.raises(KeyboardInterrupt):
        sweep(spec, tmp_path, Counting(), progress=interrupt_after_7, outputs=False)
    done = {(r["policy"], r["seed"]) for r in journal_lines(tmp_path)}
    assert len(done) == 7 and not (tmp_path / "runs.csv").exists()
    rest = Counting()
    result = sweep(spec, tmp_path, rest, outputs=False)
    assert result.resumed == 7 and result.ran == 11
    assert len(rest.calls) == 11 and not done & set(rest.calls)
    assert len(journal_lines(tmp_path)) == 18


def test_torn_last_line_is_discarded(spec: SweepSpec, tmp_path: Path) -> None:
    sweep(make_spec(spec.policies, (0, 1), spec.scenario), tmp_path, Counting(), outputs=False)
    with (tmp_path / JOURNAL).open("a") as fh:
        fh.write('{"policy": "fcfs", "seed": 2, "scen')  # the machine died mid-write
    rest = Counting()
    result = sweep(
        make_spec(spec.policies, (0, 1, 2), spec.scenario), tmp_path, rest, outputs=False
    )
    assert sorted(rest.calls) == [("coalition", 2), ("fcfs", 2), ("nearest", 2)]
    assert result.resumed == 6 and len(journal_lines(tmp_path)) == 9


def test_stop_cancels_and_keeps_finished_runs(spec: SweepSpec, tmp_path: Path) -> None:
    with pytest.raises(SweepCancelled):
        sweep(spec, tmp_path, Counting(), stop=lambda: True, window=2)
    assert 1 <= len(journal_lines(tmp_path)) <= 2


def test_failed_runs_are_reported_and_retried(tmp_path: Path) -> None:
    spec = fake_spec("1,3", "0-4")
    with pytest.raises(SweepError, match="2 of 10 runs failed; first: policy fcfs seed 3"):
        sweep(spec, tmp_path, Counting(failing_run))
    assert len(journal_lines(tmp_path)) == 8
    retry = Counting()
    sweep(spec, tmp_path, retry, outputs=False)
    assert sorted(retry.calls) == [("fcfs", 3), ("nearest", 3)]


def test_another_scenario_in_the_same_dir_is_refused(spec: SweepSpec, tmp_path: Path) -> None:
    sweep(spec, tmp_path, Counting(), outputs=False)
    other = reference_scenario().model_copy(update={"minerals": 40})
    with pytest.raises(SweepConflict, match="another scenario"):
        sweep(make_spec(spec.policies, spec.seeds, other), tmp_path, Counting())


def test_default_process_pool_with_injected_run(tmp_path: Path) -> None:
    spec = fake_spec("1,3", "0-3")
    result = run_sweep(spec, tmp_path, run_fn=fake_run, workers=2, outputs=False)
    assert result.ran == 8
    pids = {r["pid"] for r in journal_lines(tmp_path)}
    assert len(pids) >= 1 and all(p != 0 for p in pids)


def test_another_engine_build_in_the_same_dir_is_refused(spec: SweepSpec, tmp_path: Path) -> None:
    sweep(spec, tmp_path, Counting(), outputs=False)
    manifest = json.loads((tmp_path / "sweep.json").read_text())
    manifest["engine"] = "0123456789ab"
    (tmp_path / "sweep.json").write_text(json.dumps(manifest))
    with pytest.raises(SweepConflict, match="another engine build"):
        sweep(spec, tmp_path, Counting(), outputs=False)


def test_another_planner_in_the_same_dir_is_refused(spec: SweepSpec, tmp_path: Path) -> None:
    sweep(spec, tmp_path, Counting(), outputs=False)
    assert json.loads((tmp_path / "sweep.json").read_text())["planner"] == "ompl"
    exact = make_spec(spec.policies, spec.seeds, spec.scenario, planner="exact")
    with pytest.raises(SweepConflict, match="planned with 'ompl', this one with 'exact'"):
        sweep(exact, tmp_path, Counting(), outputs=False)


def test_a_manifest_from_before_planners_is_an_ompl_sweep(spec: SweepSpec, tmp_path: Path) -> None:
    sweep(spec, tmp_path, Counting(), outputs=False)
    manifest = json.loads((tmp_path / "sweep.json").read_text())
    del manifest["planner"]
    (tmp_path / "sweep.json").write_text(json.dumps(manifest))
    assert sweep(spec, tmp_path, Counting(), outputs=False).resumed == spec.total


def test_a_worker_with_another_engine_build_is_not_journaled(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    import experiments.runner as runner

    monkeypatch.setattr(runner, "engine_fingerprint", lambda: "pinned-build")
    with pytest.raises(SweepError, match="differs from this sweep's pinned-build"):
        sweep(fake_spec("1", "0-1"), tmp_path, Counting(), outputs=False)
    assert (tmp_path / JOURNAL).read_text() == ""


def test_the_lock_holds_while_a_sweep_writes_and_is_gone_after(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    import fcntl

    from experiments.journal import LOCK, exclusive

    with exclusive(tmp_path):
        assert (tmp_path / LOCK).exists()
        with pytest.raises(SweepConflict, match="another sweep is writing"), exclusive(tmp_path):
            pass
    assert not (tmp_path / LOCK).exists()
    result = sweep(fake_spec(seeds="0-1"), tmp_path / "out", Counting())
    assert result.ran == 6 and not (tmp_path / "out" / LOCK).exists()

    # A sweep opens the file, the holder finishes (removes it) and a third sweep locks a new
    # one, then the first gets its lock, on the removed file: it must not count.
    real_flock, newer = fcntl.flock, []

    def flock_after_a_handover(fd: int, op: int) -> None:
        if not newer:
            (tmp_path / LOCK).unlink()
            newer.append((tmp_path / LOCK).open("a"))
            real_flock(newer[0].fileno(), fcntl.LOCK_EX | fcntl.LOCK_NB)
        real_flock(fd, op)

    monkeypatch.setattr(fcntl, "flock", flock_after_a_handover)
    with pytest.raises(SweepConflict, match="another sweep is writing"), exclusive(tmp_path):
        pass
    newer[0].close()
