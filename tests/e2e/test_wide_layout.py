"""The dashboard at 1440 px and on a phone, as a new user saw it: every column of the compare
table whole, a finished mission's map whole on load, a scrubber that keeps its width under
the pointer, the sweep form inside its panel with a "building figures" phase, charts that
show what the table and counters show, the robot list whole with energy on, the legend
showing only what applies, and no empty row for a hidden button (docs/dashboard.md)."""

from __future__ import annotations

import re
from pathlib import Path
from typing import Any

import httpx
import pytest
from playwright.sync_api import Page, expect
from playwright.sync_api import TimeoutError as PlaywrightTimeout

from engine import load_scenario
from tests.e2e.conftest import ConsoleLog
from tests.e2e.test_compare_groups import FOUR, finish
from tests.e2e.test_dashboard import Start, next_robot_poll, wait_for
from tests.progress import STALL_S, START_S, Progress

WIDE = {"width": 1440, "height": 900}
LONG = {**FOUR, "name": "south-pole-survey-x10"}  # a long scenario name, as scaled ones have
ENERGY = Path(__file__).resolve().parents[2] / "scenarios" / "realism" / "energy.toml"

# the robot table's cells whose text is cut (an ellipsis instead of the text)
CUT_CELLS = """[...document.querySelectorAll('#robot-table tbody td')]
  .filter(td => td.offsetParent !== null && td.scrollWidth > td.clientWidth + 0.5)
  .map(td => [td.className, td.textContent])"""


def _inside(inner: dict[str, float] | None, outer: dict[str, float] | None) -> bool:
    assert inner is not None and outer is not None
    return (
        inner["x"] >= outer["x"] - 0.5
        and inner["y"] >= outer["y"] - 0.5
        and inner["x"] + inner["width"] <= outer["x"] + outer["width"] + 0.5
        and inner["y"] + inner["height"] <= outer["y"] + outer["height"] + 0.5
    )


def test_compare_columns_fit_at_1440(
    operator: Page, start_mission: Start, api: httpx.Client, console: ConsoleLog
) -> None:
    page = operator
    page.set_viewport_size(WIDE)
    runs = [
        finish(api, start_mission(policy=p, seed=7, planner="straight", scenario=LONG))
        for p in ("coalition-relaxed", "coalition")
    ]
    page.goto("/#/compare")
    menu = page.locator("#compare-scenario")
    expect(menu.locator("option", has_text=LONG["name"])).to_have_count(1)
    if menu.is_enabled():  # (one scenario only: the menu has no other choice)
        menu.select_option(menu.locator("option", has_text=LONG["name"]).get_attribute("value"))
    for m in runs:
        row = page.locator(f'#compare-table tr[data-mission="{m["id"]}"]')
        expect(row).to_be_visible()
        makespan = row.locator("td").last
        expect(makespan).to_have_text(str(round(m["metrics"]["makespan_s"])))
        # measured in one go in the page (the table may be redrawn between two look-ups)
        geometry = page.wait_for_function(
            """(id) => {
                const td = document.querySelector(
                    `#compare-table tr[data-mission="${id}"] td:last-child`);
                const box = document.querySelector('.compare-pick');
                if (!td || !box || td.offsetParent === null) return null;
                const r = e => { const b = e.getBoundingClientRect();
                    return {x: b.x, y: b.y, width: b.width, height: b.height}; };
                return [r(td), r(box)];
            }""",
            arg=m["id"],
        ).json_value()
        assert _inside(*geometry), geometry
    wrap = page.locator(".compare-pick")
    assert wrap.evaluate("w => w.scrollWidth <= w.clientWidth"), "the table overflows its panel"
    clipped = page.evaluate(
        """[...document.querySelectorAll('#compare-table th, #compare-table td.num')]
            .filter(c => c.scrollWidth > c.clientWidth + 0.5).map(c => c.textContent)"""
    )
    assert clipped == []
    assert console.errors == []


@pytest.fixture
def finished(start_mission: Start, api: httpx.Client) -> dict[str, Any]:
    return finish(api, start_mission(seed=8, planner="straight", scenario=FOUR))


def test_a_finished_mission_shows_its_whole_map_on_load(
    operator: Page, finished: dict[str, Any]
) -> None:
    page = operator
    page.set_viewport_size(WIDE)
    page.goto(f"/#/live/{finished['id']}")
    wait_for(page, "window.__regolith.final")
    # the layout settles after load (a notice, the timeline) and the map must follow it: wait
    # until every corner, site and label lies inside the canvas, measured in one go
    misplaced = """(() => {
        const r = window.__regolith, world = r.map, c = document.querySelector('#map');
        const box = c.getBoundingClientRect(), out = [];
        const pts = [[0, 0], [world.width, 0], [0, world.height], [world.width, world.height],
                     ...world.sites.map(s => [s.x, s.y])];
        for (const [x, y] of pts) {
            const [px, py] = r.pagePoint(x, y);
            if (px < box.left || px > box.right || py < box.top || py > box.bottom)
                out.push({x, y, px, py});
        }
        for (const l of r.drawn.labels) {  // (canvas pixels)
            const [left, top, right, bottom] = l.box;
            if (left < 0 || top < 0 || right > box.width || bottom > box.height) out.push(l);
        }
        return out; })()"""
    try:  # (a function, not an expression: the page's CSP forbids eval)
        page.wait_for_function(f"() => {misplaced}.length === 0")
    except PlaywrightTimeout:
        pytest.fail(f"parts of the map lie outside its canvas: {page.evaluate(misplaced)}")


def test_the_scrubber_keeps_its_width_under_the_pointer(
    operator: Page, finished: dict[str, Any]
) -> None:
    """A press starts looking back (a wider label, a "Final state" button): the slider must
    not shrink under the pointer, or the thumb jumps away from it."""
    page = operator
    page.set_viewport_size(WIDE)
    page.goto(f"/#/live/{finished['id']}")
    wait_for(page, "window.__regolith.final")
    rng = page.locator("#tl-range")
    before = rng.bounding_box()
    assert before is not None
    x, y = before["x"] + before["width"] * 0.3, before["y"] + before["height"] / 2
    page.mouse.move(x, y)
    page.mouse.down()
    expect(page.locator("#timeline")).to_have_attribute("data-mode", "back")
    during = rng.bounding_box()
    page.mouse.up()
    assert during is not None and during["width"] == pytest.approx(before["width"], abs=0.5)
    assert during["x"] == pytest.approx(before["x"], abs=0.5)
    t = float(page.locator("#timeline").get_attribute("data-t") or "nan")
    end = float(page.locator("#timeline").get_attribute("data-end") or "nan")
    assert t == pytest.approx(0.3 * end, abs=0.03 * end)  # where the pointer pressed


def test_on_a_phone_looking_back_leaves_no_empty_tool_row(
    operator: Page, finished: dict[str, Any]
) -> None:
    page = operator
    page.set_viewport_size({"width": 390, "height": 844})
    page.goto(f"/#/live/{finished['id']}")
    wait_for(page, "window.__regolith.final")
    page.locator("#tl-range").focus()
    page.keyboard.press("Home")
    expect(page.locator("#timeline")).to_have_attribute("data-mode", "back")
    rows = page.evaluate(
        """(() => {
          const shown = [...document.querySelector('.map-tools').children]
            .filter(e => getComputedStyle(e).display !== 'none');
          const top = e => Math.round(e.getBoundingClientRect().top / 8);
          const all = new Set(shown.map(top));
          const seen = new Set(
            shown.filter(e => getComputedStyle(e).visibility !== 'hidden').map(top));
          return [all.size, seen.size];
        })()"""
    )
    assert rows[0] == rows[1], f"{rows[0] - rows[1]} row(s) of the map tools hold nothing visible"


def test_the_sweep_panel_holds_its_form_and_says_when_it_builds_figures(
    operator: Page, console: ConsoleLog
) -> None:
    page = operator
    page.set_viewport_size({"width": 1440, "height": 760})
    page.goto("/#/compare")
    form = page.locator("#sweep-form")
    form.get_by_label("2 · Coalitions").uncheck()
    form.get_by_label("3 · Nearest").uncheck()
    form.get_by_label("Seeds").fill("0")
    page.evaluate(  # every phase the progress box shows, as it shows it
        """window.__phases = [];
        const box = document.querySelector('#sweep-progress');
        const text = document.querySelector('#sweep-progress-text');
        new MutationObserver(() => window.__phases.push([box.dataset.phase, text.textContent]))
          .observe(box, {attributes: true, subtree: true, childList: true});"""
    )
    form.get_by_role("button", name="Start sweep").click()
    progress = page.locator("#sweep-progress")
    expect(progress).to_be_visible()
    # measured in one go in the page: the list of sweeps above the form may grow between
    # two look-ups and move the progress bar down after the panel was measured
    form_box, progress_box, panel = page.evaluate(
        """['#sweep-form', '#sweep-progress', '#sweep-panel'].map(s => {
            const b = document.querySelector(s).getBoundingClientRect();
            return {x: b.x, y: b.y, width: b.width, height: b.height}; })"""
    )
    assert _inside(form_box, panel), "the sweep form spills out of its panel"
    assert _inside(progress_box, panel), "the progress bar spills out of its panel"
    expect(progress).to_have_attribute("data-status", "completed", timeout=120_000)
    phases = page.evaluate("window.__phases")
    building = [text for phase, text in phases if phase == "figures"]
    assert building and all("building figures…" in text for text in building), phases
    assert not any("ETA" in text for phase, text in phases if phase == "figures")
    assert console.errors == []


#: minerals enough that the mission cannot end at Max before the test pauses it, however
#: slowly a loaded machine lets the test sample (the reference scenario's 64 could)
MANY = {"name": "many-minerals", "minerals": 1500, "max_time_s": 10_000_000}
#: the chart's figures as last drawn against the table's sums and the counters, read at one
#: moment in the page (a robot poll may land between two separate reads)
AGREE = """(() => { const c = window.__regolith.charts; const s = c.shown; const want = {};
    for (const tr of document.querySelectorAll('#robot-table tr[data-robot]'))
      want[tr.dataset.type] = (want[tr.dataset.type] || 0) + Number(tr.dataset.distance);
    const delivered = window.__regolith.lastCounters.minerals_delivered;
    const ok = s && Object.keys(want).length
      && Object.keys(want).every(k => Math.abs((s.distance[k] || 0) - want[k]) < 0.5)
      && s.delivered === delivered;
    return {ok, shown: s, table: want, delivered, curve: c.delivered.slice(-3)}; })()"""


def test_at_max_the_charts_and_counters_agree_with_the_table_and_feed(
    operator: Page, start_mission: Start, api: httpx.Client
) -> None:
    page = operator
    page.set_viewport_size(WIDE)
    mission = start_mission(seed=9, speed="max", planner="straight", paused=True, scenario=MANY)
    mid = mission["id"]
    page.goto(f"/#/live/{mid}")
    # the page's first load: no progress to watch, so the generous start limit (progress.py)
    expect(page.locator("#live-status")).to_have_text("paused", timeout=START_S * 1000)
    count = page.locator("#feed-count")
    assert api.put(f"/missions/{mid}/speed", json={"speed": "max"}).status_code == 200
    assert api.post(f"/missions/{mid}/resume").status_code == 200
    samples = 0
    watch = Progress("five deliveries and three counter samples at Max")
    while True:  # while it runs at Max: the box counts auctions as the feed does
        box, feed, delivered, t = page.evaluate(
            """[document.querySelector('[data-counter=auctions]')?.textContent + ' · '
                + document.querySelector('[data-counter=open]')?.textContent + ' open',
               document.querySelector('#feed-count').textContent,
               window.__regolith.lastCounters.minerals_delivered, window.__regolith.t]"""
        )
        if "undefined" not in box and feed:
            assert box == feed
            samples += 1
        if delivered is not None and delivered >= 5 and samples >= 3:
            break
        watch.check((t, samples))
        page.wait_for_timeout(50)
    assert api.post(f"/missions/{mid}/pause").status_code == 200
    expect(page.locator("#live-status")).to_have_text("paused", timeout=STALL_S * 1000)
    next_robot_poll(page, mid)
    next_robot_poll(page, mid)
    # paused, nothing moves: within the chart's redraw second after the last robot poll the
    # chart shows the table's sums and the counters' deliveries, and stays so; polls go on
    # once a second, so a chart that never settles fails after a few of them
    polls = 0
    while not (seen := page.evaluate(AGREE))["ok"]:
        assert polls < 10, f"the charts never settled on the table and counters: {seen}"
        next_robot_poll(page, mid)
        polls += 1
    shown = seen["shown"]
    assert shown["delivered"] >= 5
    expect(count).to_have_text(re.compile(r"^\d+ · \d+ open$"))
    # no energy and no Policy 2 pair in this mission: the legend does not show them
    expect(page.locator('#legend [data-legend="charge"]')).to_be_hidden()
    expect(page.locator('#legend [data-legend="pair"]')).to_be_hidden()


def test_with_energy_on_the_robot_list_stays_whole_at_1440(
    operator: Page, start_mission: Start, api: httpx.Client
) -> None:
    page = operator
    page.set_viewport_size(WIDE)
    scenario = load_scenario(ENERGY).model_dump(mode="json")
    mission = start_mission(
        policy="coalition", seed=3, speed=200, planner="straight", scenario=scenario
    )
    mid = mission["id"]
    page.goto(f"/#/live/{mid}")
    wait_for(  # tasks held and a battery spent: the widest texts the columns take
        page,
        """[...document.querySelectorAll('#robot-table tr[data-robot]')]
            .filter(tr => tr.dataset.task).length >= 3
          && window.__regolith.stream.robots.some(r => r.charge != null && r.charge < 0.9)""",
    )
    assert api.post(f"/missions/{mid}/pause").status_code == 200
    next_robot_poll(page, mid)
    assert page.evaluate("document.querySelectorAll('#robot-table td.charge').length") >= 12
    assert page.evaluate(CUT_CELLS) == []
    expect(page.locator('#legend [data-legend="charge"]')).to_be_visible()
    expect(page.locator('#legend [data-legend="pair"]')).to_be_visible()  # Policy 2's pairs
