"""Compare never pools what differs: runs of other scenarios are apart, a run whose
policy was switched live counts under no single policy, and both show in the lists."""

from __future__ import annotations

import time
from typing import Any

from playwright.sync_api import Page, expect

from tests.e2e.conftest import ARTIFACTS, ConsoleLog, painted
from tests.e2e.test_dashboard import wait_for
from tests.e2e.test_layout import CHART_BOXES, check_charts

# A name of its own: other tests of the same session server run small worlds too.
FOUR = {"name": "compare-groups", "width": 40.0, "height": 40.0, "sites": 4}
THREE = {**FOUR, "sites": 3}  # same name, other content


def finish(api: Any, mission: dict[str, Any]) -> dict[str, Any]:
    assert api.put(f"/missions/{mission['id']}/speed", json={"speed": "max"}).status_code == 200
    for _ in range(600):
        m: dict[str, Any] = api.get(f"/missions/{mission['id']}").json()
        if m["status"] not in ("running", "paused"):
            assert m["status"] == "completed", m
            return m
        time.sleep(0.1)
    raise AssertionError(f"mission {mission['id']} did not finish")


def test_compare_keeps_scenarios_and_mixed_runs_apart(
    page: Page, start_mission: Any, api: Any, console: ConsoleLog
) -> None:
    def run(policy: str, seed: int, scenario: dict[str, Any], switch: str | None = None) -> Any:
        m = start_mission(policy=policy, seed=seed, scenario=scenario, planner="straight")
        if switch:
            assert (
                api.put(f"/missions/{m['id']}/policy", json={"policy": switch}).status_code == 200
            )
        return finish(api, m)

    fcfs = [run("fcfs", s, FOUR) for s in (1, 2)]
    coal = run("coalition", 1, FOUR)
    mixed = run("fcfs", 3, FOUR, switch="coalition")
    other = run("fcfs", 1, THREE)
    assert mixed["mixed_policy"] and mixed["policies"] == ["fcfs", "coalition"]
    four, three = (f"{FOUR['name']}#{m['scenario_hash']}" for m in (coal, other))
    assert four != three

    page.goto("/#/compare")
    scenario = page.locator("#compare-scenario")
    expect(scenario.locator(f'option[value="{four}"]')).to_have_count(1)
    scenario.select_option(four)
    rows = page.locator("#compare-table tbody tr[data-mission]")
    expect(rows).to_have_count(4)  # only this scenario's runs are listed
    assert set(rows.evaluate_all("rs => rs.map(r => r.dataset.scenario)")) == {
        coal["scenario_hash"]
    }
    row = page.locator(f'#compare-table tr[data-mission="{mixed["id"]}"]')
    expect(row).to_have_attribute("data-mixed", "true")
    expect(row.locator("td.policy-cell")).to_contain_text("1 · FCFS → 2 · Coalitions")
    expect(row.locator(".badge.mixed")).to_have_text("mixed")
    expect(row.locator("input[type=checkbox]")).to_be_disabled()
    expect(row.locator("input[type=checkbox]")).not_to_be_checked()
    expect(row.locator("td.scenario-cell")).to_have_text("compare-groups")

    head = page.locator("#compare-summary thead th")
    runs = page.locator("#compare-summary tbody tr").first.locator("td")
    expect(head).to_have_text(["mean ± 95% CI", "1 · FCFS", "2 · Coalitions"])
    expect(runs).to_have_text(["2", "1"])  # the mixed run is counted under neither
    mean = sum(m["metrics"]["makespan_s"] for m in fcfs) / 2
    expect(page.locator("#compare-summary tbody tr").nth(1).locator("td").first).to_contain_text(
        f"{mean:.0f} ± "
    )

    # the bar values stand clear of the CI whiskers (FCFS has two runs: a whisker)
    charts = page.evaluate(CHART_BOXES, ".compare-figs svg")
    assert any(c["values"] for c in charts) and any(c["whiskers"] for c in charts)
    check_charts(page, ".compare-figs svg")

    page.get_by_label("Include mixed-policy runs").check()
    expect(row.locator("input[type=checkbox]")).to_be_enabled()
    expect(row.locator("input[type=checkbox]")).to_be_checked()
    expect(head).to_have_text(
        ["mean ± 95% CI", "1 · FCFS", "2 · Coalitions", "FCFS→Coalitions (mixed)"]
    )
    expect(runs).to_have_text(["2", "1", "1"])

    # at a laptop's and a phone's width: labels still clear, the page within the screen
    for w, h in ((1024, 768), (390, 844)):
        page.set_viewport_size({"width": w, "height": h})
        painted(page)  # the charts redraw on resize
        check_charts(page, ".compare-figs svg")
        assert page.evaluate("document.documentElement.scrollWidth") <= w
        page.screenshot(path=str(ARTIFACTS / f"compare-{w}.png"), full_page=True)
    page.set_viewport_size({"width": 1280, "height": 800})

    scenario.select_option(three)  # the 3-site runs alone
    expect(rows).to_have_count(1)
    expect(head).to_have_text(["mean ± 95% CI", "1 · FCFS"])
    expect(runs).to_have_text(["1"])
    expect(page.locator("#compare-n")).to_have_text("· compare-groups · 1 runs")

    # the run history shows both policies of the mixed run
    page.goto("/#/missions")
    hist = page.locator(f'#history tr[data-mission="{mixed["id"]}"]')
    expect(hist).to_have_attribute("data-mixed", "true")
    expect(hist).to_contain_text("1 · FCFS → 2 · Coalitions")
    wait_for(page, "document.querySelectorAll('#history tr[data-mission]').length >= 5")
    assert console.errors == []
