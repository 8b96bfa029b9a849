"""Every registered policy (the research's three, Policy 4 and the
centralized baseline) completes the reference scenario on seeds 0–9."""

import pytest

from engine import POLICIES, reference_scenario, run_mission


@pytest.mark.parametrize("policy", list(POLICIES))
def test_reference_missions_find_every_site_and_deliver_every_mineral(policy):
    for seed in range(10):
        m = run_mission(reference_scenario(), seed, policy)
        assert m["completed"], (policy, seed, m["status"])
        assert (m["sites_found"], m["sites_total"]) == (10, 10)
        assert (m["minerals_delivered"], m["minerals_total"]) == (64, 64)
        assert m["makespan_s"] > 0
        assert m["auction_open_s"]["scout_excavator"]["count"] >= 10
