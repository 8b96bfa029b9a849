"""The policy registry: one entry per policy, with the metadata every client shows."""

import pytest

from engine.policies import (
    POLICIES,
    POLICY_NAMES,
    FirstComeFirstServed,
    policy_table,
    register_policy,
)


def test_the_table_is_the_registry_in_registration_order_as_plain_data():
    table = policy_table()
    assert [p["name"] for p in table] == list(POLICIES)
    assert {p["number"]: p["name"] for p in table} == POLICY_NAMES
    assert [p["name"] for p in table if not p["decentralized"]] == ["central-greedy", "offline"]
    assert len({p["colour"] for p in table}) == len(table)  # one colour each, for the charts
    assert all(p["label"] and p["description"] for p in table)


def test_registration_refuses_a_taken_number_and_unshowable_metadata():
    taken = type("Twin", (FirstComeFirstServed,), {"name": "twin"})  # number 1 is fcfs's
    no_colour = type(
        "Drab", (FirstComeFirstServed,), {"name": "drab", "number": 9, "colour": "red"}
    )
    for cls in (taken, no_colour):
        with pytest.raises(ValueError, match=cls.__name__):
            register_policy(cls)
    assert "twin" not in POLICIES and "drab" not in POLICIES
