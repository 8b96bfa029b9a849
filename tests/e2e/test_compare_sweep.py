"""The compare page starts a sweep, shows its progress and then its results per policy."""

from __future__ import annotations

from typing import Any

from playwright.sync_api import Page, expect

from tests.e2e.conftest import ARTIFACTS, ConsoleLog
from tests.e2e.test_compare_groups import FOUR, finish
from tests.e2e.test_dashboard import wait_for


def test_viewer_sees_the_sweep_form_disabled(page: Page) -> None:
    page.goto("/#/compare")
    expect(page.locator("#sweep-panel")).to_be_visible()
    expect(page.get_by_role("button", name="Start sweep")).to_be_disabled()


def test_start_a_sweep_and_compare_its_results(
    operator: Page, console: ConsoleLog, start_mission: Any, api: Any
) -> None:
    page = operator
    # a finished mission, ticked until a sweep is shown
    finish(api, start_mission(seed=4, planner="straight", scenario=FOUR))
    page.goto("/#/compare")
    form = page.locator("#sweep-form")
    expect(form.get_by_label("2 · Coalitions")).to_be_checked()
    form.get_by_label("3 · Nearest").uncheck()
    form.get_by_label("Seeds").fill("0")
    form.get_by_role("button", name="Start sweep").click()

    progress = page.locator("#sweep-progress")
    expect(progress).to_be_visible()
    expect(progress).to_have_attribute("data-total", "2")
    wait_for(  # as long as the sweep's progress line changes (runs done, its ETA)
        page,
        "document.querySelector('#sweep-progress').dataset.status === 'completed'",
        60,
        "document.querySelector('#sweep-progress-text').textContent",
    )
    expect(progress).to_have_attribute("data-status", "completed")
    sid = progress.get_attribute("data-sweep")
    expect(page.locator("#compare-n")).to_have_text(f"· sweep {sid} · reference · 2 runs")
    head = page.locator("#compare-summary thead th")
    expect(head).to_have_text(["mean ± 95% CI", "1 · FCFS", "2 · Coalitions"])
    expect(page.locator("#cmp-makespan svg")).to_be_visible()

    makespan = page.locator('#sweep-figures figure[data-figure="makespan"]')
    expect(makespan).to_be_visible()
    expect(makespan.locator("img")).to_have_attribute("data-loaded", "true")
    assert makespan.locator("img").evaluate("img => img.naturalWidth") > 100
    expect(makespan.locator("p.hint").first).to_contain_text("makespan")
    expect(page.locator("#sweep-select")).to_have_value(str(sid))

    # the missions' boxes are not ticked while a sweep is shown, and the sweep is named in full
    boxes = page.locator("#compare-table tbody input[type=checkbox]")
    assert boxes.count() >= 1
    assert boxes.evaluate_all("bs => bs.filter(b => b.checked).length") == 0
    desc = page.locator("#sweep-desc")
    expect(desc).to_have_text(
        f"Sweep #{sid}: reference, 1 · FCFS, 2 · Coalitions × 1 seeds, completed"
    )
    assert desc.evaluate(
        "e => e.scrollWidth <= e.clientWidth && e.getBoundingClientRect().right <= innerWidth"
    )

    # every result file and figure downloads, byte for byte what the API serves
    names = ["runs.csv", "summary.json", "report.md", "makespan.svg", "makespan.png"]
    for name in names:
        with page.expect_download() as info:
            page.locator(f'[data-download="sweep-{sid}-{name}"]').click()
        download = info.value
        assert download.suggested_filename == f"sweep-{sid}-{name}"
        folder = "figures" if name.startswith("makespan") else "files"
        served = api.get(f"/sweeps/{sid}/{folder}/{name}").content
        assert download.path().read_bytes() == served, name

    ARTIFACTS.mkdir(parents=True, exist_ok=True)
    page.screenshot(path=str(ARTIFACTS / "compare-sweep.png"), full_page=True)
    page.locator("#compare-none").click()  # back to missions: the sweep's figures go away
    expect(page.locator("#sweep-figures")).to_be_hidden()
    assert console.errors == []
