"""Sweeps on the real engine: a Dask cluster gives the same runs.csv as the local pool, and
the makespan lower bound never exceeds a real run's makespan."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from engine import POLICY_NAMES, parse_scenario, reference_scenario, resolve_policy, run_mission
from experiments.bound import engine_bound, run_bound
from experiments.runner import run_sweep
from experiments.spec import make_spec, parse_policies, parse_seeds


def test_dask_cluster_and_local_pool_write_the_same_runs_csv(tmp_path: Path) -> None:
    from distributed import Client, LocalCluster

    spec = make_spec(
        parse_policies("1,3", resolve_policy, POLICY_NAMES),
        parse_seeds("0-1"),
        reference_scenario(),
    )
    local = run_sweep(spec, tmp_path / "local", workers=2)
    with (
        LocalCluster(
            n_workers=2, threads_per_worker=1, processes=True, dashboard_address=None
        ) as cluster,
        Client(cluster) as client,
    ):
        dask = run_sweep(spec, tmp_path / "dask", executor=client.get_executor(pure=False))
    assert local.ran == dask.ran == 4
    for name in ("runs.csv", "bounds.csv"):
        assert (tmp_path / "local" / name).read_bytes() == (tmp_path / "dask" / name).read_bytes()
    hosts = {r["pid"] for r in dask.records} | {r["pid"] for r in local.records}
    assert len(hosts) >= 2  # the runs really happened in worker processes
    rows = (tmp_path / "local" / "runs.csv").read_text().splitlines()
    assert len(rows) == 5 and "makespan_ratio" in rows[0] and "makespan_ratio_apriori" in rows[0]
    for rec in local.records:  # both bounds hold on the reference scenario too
        b = engine_bound(spec.scenario, rec["seed"])
        assert b.value <= rec["metrics"]["makespan_s"]
        assert b.world is not None
        per_run = run_bound(b.world, rec["metrics"]["sites_found_at"])
        assert per_run is not None and per_run.value <= rec["metrics"]["makespan_s"]


SMALL: dict[str, Any] = {"name": "small", "width": 40.0, "height": 40.0, "sites": 4}


@settings(
    max_examples=12, deadline=None, suppress_health_check=[HealthCheck.too_slow], derandomize=True
)
@given(
    seed=st.integers(0, 10_000),
    minerals=st.integers(4, 12),
    team=st.tuples(st.integers(1, 3), st.integers(1, 3), st.integers(1, 4)),
    craters=st.integers(0, 5),
    speeds=st.tuples(st.sampled_from([0.5, 1.0, 2.0]), st.sampled_from([0.3, 0.5, 1.0])),
    timing=st.tuples(st.sampled_from([5.0, 20.0]), st.sampled_from([0.0, 5.0])),
)
def test_lower_bound_never_exceeds_a_makespan(
    seed: int,
    minerals: int,
    team: tuple[int, int, int],
    craters: int,
    speeds: tuple[float, float],
    timing: tuple[float, float],
) -> None:
    scenario = parse_scenario(
        {
            **SMALL,
            "minerals": minerals,
            "team": {"scouts": team[0], "excavators": team[1], "haulers": team[2]},
            "random_craters": craters,
            "speeds": {"scout": speeds[0], "hauler": speeds[1]},
            "timing": {"dig_s": timing[0], "transfer_s": timing[1], "unload_s": timing[1]},
        }
    )
    bound = engine_bound(scenario, seed)
    assert bound.value > 0
    for policy in ("fcfs", "coalition", "nearest", "lookahead", "central-greedy"):
        m = run_mission(scenario, seed, policy)
        assert m["status"] == "completed"
        assert bound.value <= m["makespan_s"], (policy, bound.terms, m["makespan_s"])


@pytest.mark.parametrize("seed", [4, 5])
def test_lower_bound_on_the_reference_scenario(seed: int) -> None:
    bound = engine_bound(reference_scenario(), seed)
    makespans = [run_mission(reference_scenario(), seed, p)["makespan_s"] for p in (1, 2, 3, 4, 0)]
    assert bound.value <= min(makespans)
    assert bound.value >= 0.4 * min(makespans)  # and it is not vacuous
