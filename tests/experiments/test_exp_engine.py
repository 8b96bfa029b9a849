"""Sweeps on the real engine: the makespan lower bound never exceeds a real run's makespan
(the Dask cluster is tested in test_exp_dask_cluster.py)."""

from __future__ import annotations

import json
from dataclasses import replace
from pathlib import Path
from typing import Any

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from engine import POLICY_NAMES, parse_scenario, reference_scenario, resolve_policy, run_mission
from experiments.bound import engine_bound
from experiments.runner import run_sweep
from experiments.spec import make_spec, parse_policies

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


def test_a_sweep_plans_with_its_planner(tmp_path: Path) -> None:
    """`--planner exact`: every run is the engine's own mission on that planner, and the
    summary and report say so."""
    scenario = reference_scenario()
    spec = make_spec(parse_policies("1,3", resolve_policy, POLICY_NAMES), (0, 1), scenario)
    exact = replace(spec, planner="exact")
    result = run_sweep(exact, tmp_path, workers=1)
    for record in result.records:
        alone = run_mission(scenario, record["seed"], record["policy"], planner="exact")
        assert record["metrics"] == alone
    ompl = run_mission(scenario, 0, "fcfs")
    assert ompl["makespan_s"] != result.records[0]["metrics"]["makespan_s"]  # not OMPL's run
    summary = json.loads((tmp_path / "summary.json").read_text())
    assert summary["scenario"]["planner"] == "exact"
    assert "--planner exact" in (tmp_path / "report.md").read_text()
