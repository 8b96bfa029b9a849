"""The dashboard's policy menus come from GET /api/policies: exactly the registered policies,
each one usable in the live view's policy switch."""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import httpx
from playwright.sync_api import Page, expect

from tests.e2e.conftest import ConsoleLog
from tests.e2e.test_dashboard import open_live


def test_every_policy_menu_offers_exactly_the_registered_policies_and_each_switches(
    operator: Page,
    console: ConsoleLog,
    api: httpx.Client,
    start_mission: Callable[..., dict[str, Any]],
) -> None:
    page = operator
    registered = api.get("/policies").json()
    names = [p["name"] for p in registered]
    labels = [f"{p['number']} · {p['label']}" for p in registered]
    assert names and len(set(names)) == len(names)

    page.goto("/#/missions")
    start = page.locator("#start-form select[name=policy] option")
    expect(start).to_have_count(len(names))
    assert start.evaluate_all("os => os.map(o => o.value)") == names
    expect(start).to_have_text(labels)
    history = page.locator("#history-filter select[name=policy] option")
    assert history.evaluate_all("os => os.map(o => o.value)") == ["", *names]

    page.goto("/#/compare")
    boxes = page.locator("#sweep-policies input[name=policy]")
    expect(boxes).to_have_count(len(names))
    assert boxes.evaluate_all("bs => bs.map(b => b.value)") == names

    mission = start_mission(seed=5, speed=1)
    open_live(page, mission["id"])
    live = page.locator("#policy-select")
    assert live.locator("option").evaluate_all("os => os.map(o => o.value)") == names
    expect(page.locator("#live-policy")).to_have_attribute("data-policy", "fcfs")
    for name in [n for n in names if n != "fcfs"] + ["fcfs"]:  # the current one last
        live.select_option(name)
        expect(page.locator("#live-policy")).to_have_attribute("data-policy", name)
        expect(live).to_have_value(name)
        assert api.get(f"/missions/{mission['id']}").json()["policy"] == name
    assert console.errors == []
