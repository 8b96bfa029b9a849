"""Shared pieces for the experiment tests: a spec over the fake engine."""

from __future__ import annotations

import pytest
from exp_fakes import POLICIES, resolve

from app.experiments.spec import SweepSpec, make_spec, parse_policies, parse_seeds
from engine.scenario import reference_scenario


def fake_spec(policies: str = "1,2,3", seeds: str = "0-5") -> SweepSpec:
    return make_spec(
        parse_policies(policies, resolve, POLICIES), parse_seeds(seeds), reference_scenario()
    )


@pytest.fixture
def spec() -> SweepSpec:
    return fake_spec()
