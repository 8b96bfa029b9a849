"""The compare page starts a sweep, shows its progress and then its results per policy."""

from __future__ import annotations

from playwright.sync_api import Page, expect

from tests.e2e.conftest import ConsoleLog


def test_viewer_sees_the_sweep_form_disabled(page: Page) -> None:
    page.goto("/#/compare")
    expect(page.locator("#sweep-panel")).to_be_visible()
    expect(page.get_by_role("button", name="Start sweep")).to_be_disabled()


def test_start_a_sweep_and_compare_its_results(operator: Page, console: ConsoleLog) -> None:
    page = operator
    page.goto("/#/compare")
    form = page.locator("#sweep-form")
    expect(form.get_by_label("2 · Coalitions")).to_be_checked()
    form.get_by_label("3 · Nearest").uncheck()
    form.get_by_label("Seeds").fill("0")
    form.get_by_role("button", name="Start sweep").click()

    progress = page.locator("#sweep-progress")
    expect(progress).to_be_visible()
    expect(progress).to_have_attribute("data-total", "2")
    expect(progress).to_have_attribute("data-status", "completed", timeout=60_000)
    sid = progress.get_attribute("data-sweep")
    expect(page.locator("#compare-n")).to_have_text(f"· sweep {sid} · 2 runs", timeout=10_000)
    head = page.locator("#compare-summary thead th")
    expect(head).to_have_text(["mean ± 95% CI", "1 · FCFS", "2 · Coalitions"])
    expect(page.locator("#cmp-makespan svg")).to_be_visible()

    makespan = page.locator('#sweep-figures figure[data-figure="makespan"]')
    expect(makespan).to_be_visible()
    expect(makespan.locator("img")).to_have_attribute("data-loaded", "true", timeout=10_000)
    assert makespan.locator("img").evaluate("img => img.naturalWidth") > 100
    expect(makespan.locator("p.hint").first).to_contain_text("makespan")
    expect(page.locator("#sweep-select")).to_have_value(str(sid))

    page.locator("#compare-none").click()  # back to missions: the sweep's figures go away
    expect(page.locator("#sweep-figures")).to_be_hidden()
    assert console.errors == []
