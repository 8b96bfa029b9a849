"""Fixtures for the experiment tests."""

from __future__ import annotations

import pytest

from experiments.spec import SweepSpec
from tests.experiments.exp_fakes import fake_spec


@pytest.fixture
def spec() -> SweepSpec:
    return fake_spec()
