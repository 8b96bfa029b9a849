"""The policy registry: one entry per policy, with the metadata every client shows."""

import pytest

from engine import Mission, reference_scenario
from engine.policies import (
    POLICIES,
    POLICY_NAMES,
    FirstComeFirstServed,
    Lookahead,
    make_policy,
    policy_rng,
    policy_table,
    register_policy,
    register_variant,
    unused_number,
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


def test_the_registry_is_read_only_outside_registration():
    with pytest.raises(TypeError):
        POLICIES["rogue"] = FirstComeFirstServed  # type: ignore[index]
    with pytest.raises(TypeError):
        POLICY_NAMES[99] = "rogue"  # type: ignore[index]


def test_a_variant_is_resolvable_by_name_but_in_no_menu():
    register_variant("lookahead-no-lead-test", "lookahead", {"lead": False})
    register_variant("lookahead-no-lead-test", "lookahead", {"lead": False})  # again: a no-op
    p = make_policy("lookahead-no-lead-test")
    assert isinstance(p, Lookahead) and p.name == "lookahead-no-lead-test"
    assert p.transport_lead_s(10.0, 5.0) == 0.0 and make_policy(4).transport_lead_s(10, 5) == 15
    assert "lookahead-no-lead-test" not in POLICIES
    assert "lookahead-no-lead-test" not in [p["name"] for p in policy_table()]
    with pytest.raises(ValueError, match="taken"):
        register_variant("lookahead-no-lead-test", "lookahead", {"bid_all": False})
    with pytest.raises(ValueError, match="no parameters"):
        register_variant("nearest-odd", "nearest", {"lead": False})


def test_a_policy_gets_its_own_seeded_stream_and_a_baseline_alone_the_global_view():
    a, b = Mission(reference_scenario(), 3, "nearest"), Mission(reference_scenario(), 3, "nearest")
    fresh = policy_rng(3)
    first = a.ctx.policy.rng.integers(1 << 30)
    assert first == b.ctx.policy.rng.integers(1 << 30) == fresh.integers(1 << 30)
    assert first != policy_rng(4).integers(1 << 30)
    with pytest.raises(RuntimeError, match="global view"):
        _ = a.ctx.policy.global_view
    central = Mission(reference_scenario(), 3, "central-greedy")
    assert central.ctx.policy.global_view is central.ctx


def test_an_unused_number_is_unused():
    assert unused_number() not in POLICY_NAMES
