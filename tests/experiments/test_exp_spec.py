"""Parsing sweep arguments: what is accepted, and one-line messages for what is not."""

from __future__ import annotations

import pytest

from engine import reference_scenario
from experiments.report import seed_ranges
from experiments.spec import (
    PolicyRef,
    SpecError,
    make_spec,
    parse_policies,
    parse_seeds,
    scenario_hash,
)
from tests.experiments.exp_fakes import POLICIES, resolve


@pytest.mark.parametrize(
    ("text", "seeds"),
    [("0-3", (0, 1, 2, 3)), ("7", (7,)), ("5,1,5", (1, 5)), ("0-1, 10-11", (0, 1, 10, 11))],
)
def test_seeds(text: str, seeds: tuple[int, ...]) -> None:
    assert parse_seeds(text) == seeds


@pytest.mark.parametrize(
    "text",
    ["5-2", "", "a", "1,,2", "-3", "1-x", "0-99999999", "2147483648", "2147483647-2147483650"],
)
def test_bad_seeds(text: str) -> None:
    with pytest.raises(SpecError) as err:
        parse_seeds(text)
    assert "\n" not in str(err.value) and "--seeds" in str(err.value)


def test_seed_ranges_round_trip() -> None:
    seeds = (0, 1, 2, 5, 7, 8)
    assert seed_ranges(seeds) == "0-2,5,7-8"
    assert parse_seeds(seed_ranges(seeds)) == seeds


def test_policies_by_number_or_name_in_given_order() -> None:
    got = parse_policies("3, fcfs,1", resolve, POLICIES)
    assert got == (PolicyRef(3, "nearest"), PolicyRef(1, "fcfs"))
    assert got[0].label == "Policy 3 (nearest)"


@pytest.mark.parametrize("text", ["9", "", "1,bogus"])
def test_bad_policies(text: str) -> None:
    with pytest.raises(SpecError, match="--policies"):
        parse_policies(text, resolve, POLICIES)


def test_spec_limits_and_hash() -> None:
    scen = reference_scenario()
    with pytest.raises(SpecError, match="scale"):
        make_spec((PolicyRef(1, "fcfs"),), (0,), scen, scale=0)
    assert scenario_hash(scen) == scenario_hash(reference_scenario())
    assert scenario_hash(scen) != scenario_hash(scen.model_copy(update={"minerals": 63}))
