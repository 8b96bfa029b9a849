"""The dashboard in a real browser against a real server (its acceptance list)."""

from __future__ import annotations

import math
import re
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

import httpx
from playwright.sync_api import Page, expect

from tests.e2e.conftest import TOKEN, ConsoleLog
from tests.progress import UI_S, Progress, wait_progress

Start = Callable[..., dict[str, Any]]

#: A mission's work so far as the page shows it (sites found, minerals delivered, auctions,
#: bids, its status): the progress measure of a wait for a mission's work (`wait_for`).
WORK = """(() => { const r = window.__regolith || {}; const c = r.lastCounters || {};
    return [c.sites_found, c.minerals_delivered, c.auctions, c.bids, r.status]; })()"""


def wait_for(page: Page, js: str, timeout: float = UI_S, progress: str | None = None) -> Any:
    """Poll a JS expression until it is truthy (page.wait_for_function would need unsafe-eval,
    which the app's Content-Security-Policy rightly forbids). With `progress` (a JS
    expression, e.g. `WORK`), wait as long as its value keeps changing and fail only after
    `timeout` seconds without a change (tests/progress.py): a loaded machine is slower."""
    if progress is not None:
        return wait_progress(
            lambda: page.evaluate(js),
            lambda: page.evaluate(progress),
            js,
            stall_s=timeout,
            every=0.1,
            sleep=lambda s: page.wait_for_timeout(s * 1000),
        )
    deadline = time.monotonic() + timeout
    while True:
        value = page.evaluate(js)
        if value:
            return value
        if time.monotonic() > deadline:
            raise AssertionError(f"timed out after {timeout} s waiting for: {js}")
        page.wait_for_timeout(100)


def open_live(page: Page, mission_id: int) -> None:
    """Open the live view and wait for the stream's snapshot and a few frames."""
    page.goto(f"/#/live/{mission_id}")
    expect(page.locator("#map")).to_have_attribute("data-robot-count", "12")
    wait_for(page, "window.__regolith && window.__regolith.frames >= 3")


def next_robot_poll(page: Page, mission_id: int) -> None:
    """Wait for the live view's next robot-list poll (once a second) to be answered."""
    path = f"/api/missions/{mission_id}/robots"
    page.wait_for_event("response", lambda r: r.url.endswith(path))


def free_point(page: Page) -> tuple[float, float]:
    """A point on the map well clear of craters and the plant, away from the overlays."""
    world = page.evaluate("window.__regolith.map")
    px, py = world["plant"]["x"], world["plant"]["y"]
    for dx, dy in [(15, 12), (-15, 12), (15, -12), (-15, -12), (20, 0), (0, 20), (-20, 0)]:
        x, y = px + dx, py + dy
        if all(math.hypot(x - o["x"], y - o["y"]) > o["r"] + 3 for o in world["obstacles"]):
            return x, y
    raise AssertionError("no free point near the plant")


def test_page_loads_without_console_errors(
    page: Page, console: ConsoleLog, start_mission: Start
) -> None:
    mission = start_mission(seed=11)
    page.goto("/")
    expect(page.locator("#view-missions")).to_be_visible()
    expect(page.locator(f'#history tr[data-mission="{mission["id"]}"]')).to_be_visible()
    page.get_by_role("link", name="Compare").click()
    expect(page.locator("#view-compare")).to_be_visible()
    open_live(page, mission["id"])
    # let the page's periodic work run: a robot-list poll answered, the charts drawn, and a
    # second of frames (10 Hz) after it
    next_robot_poll(page, mission["id"])
    frames = page.evaluate("window.__regolith.frames")
    wait_for(
        page,
        f"window.__regolith.frames >= {frames + 10}"
        " && !!document.querySelector('#chart-minerals svg')"
        " && !!document.querySelector('#chart-distance svg')",
    )
    assert console.errors == []


def test_start_mission_shows_twelve_moving_robots(operator: Page) -> None:
    page = operator
    page.goto("/#/missions")
    form = page.locator("#start-form")
    form.get_by_label("Policy").select_option("fcfs")
    form.get_by_label("Seed").fill("3")
    form.get_by_label("Speed").select_option("10")
    form.get_by_role("button", name="Start mission").click()
    expect(page).to_have_url(re.compile(r"#/live/\d+$"))
    expect(page.locator("#map")).to_have_attribute("data-robot-count", "12")
    expect(page.locator("#robot-table tbody tr[data-robot]")).to_have_count(12)
    wait_for(page, "window.__regolith.frames >= 3")
    before = {r["name"]: (r["x"], r["y"]) for r in page.evaluate("window.__regolith.robots")}
    frames = page.evaluate("window.__regolith.frames")
    wait_for(page, f"window.__regolith.frames >= {frames + 5}")
    after = {r["name"]: (r["x"], r["y"]) for r in page.evaluate("window.__regolith.robots")}
    assert len(before) == len(after) == 12
    moved = [n for n in after if math.dist(before[n], after[n]) > 0.01]
    assert moved, "no robot moved between frames"
    page.locator('[data-speed="0"]').click()  # leave the mission paused for the screenshot


def test_fail_robot_shows_failed_and_reauctions_its_task(
    operator: Page, start_mission: Start, api: httpx.Client
) -> None:
    page = operator
    mission = start_mission(seed=5, speed=40)
    open_live(page, mission["id"])
    # wait until an excavator holds an excavation task (it won a scout's auction), then pause
    busy = page.locator('#robot-table tr[data-type="excavator"]').filter(
        has=page.locator("td.task", has_text=re.compile(r"\S"))
    )
    wait_for(
        page,
        "document.querySelector('#robot-table tr[data-type=excavator] td.task')"
        " && [...document.querySelectorAll('#robot-table tr[data-type=excavator] td.task')]"
        ".some((td) => td.textContent.trim() !== '')",
        60,
        WORK,
    )
    expect(busy.first).to_be_visible()
    page.locator('[data-speed="0"]').click()
    expect(page.locator("#live-status")).to_have_attribute("data-status", "paused")
    robots = api.get(f"/missions/{mission['id']}/robots").json()
    holder = next(r for r in robots if r["type"] == "excavator" and r["task"] and r["alive"])
    name, task = holder["name"], holder["task"]  # e.g. "excavate@(59.9,35.8)"
    found = re.search(r"\(([-\d.]+),([-\d.]+)\)", task)
    assert found, f"{name} has no task with a location: {task!r}"
    site = (float(found[1]), float(found[2]))
    cards = page.locator("#auction-feed li")
    before = set(cards.evaluate_all("els => els.map(e => e.dataset.auctionId)"))
    row = page.locator(f'#robot-table tr[data-robot="{name}"]')
    row.get_by_role("button", name=re.compile("^Fail")).click()
    expect(row).to_have_attribute("data-state", "failed")
    page.locator('[data-speed="100"]').click()  # resume, fast: detection takes 30 s of sim time
    # the failure is noticed (missed heartbeats) and its task is auctioned again
    watch = Progress(f"a new auction for {task} after {name} failed", 60)
    while True:
        watch.check(page.evaluate(WORK))
        seen = cards.evaluate_all(
            "els => els.map(e => [e.dataset.auctionId, e.dataset.taskType, e.dataset.location])"
        )
        fresh = [
            aid
            for aid, kind, loc in seen
            if aid not in before
            and kind == "excavate"
            and math.dist([float(v) for v in loc.split(",")], site) < 0.1
        ]
        if fresh:
            break
        page.wait_for_timeout(250)
    page.locator('[data-speed="0"]').click()


def test_click_on_map_injects_a_task_whose_auction_appears(
    operator: Page, start_mission: Start
) -> None:
    page = operator
    mission = start_mission(seed=7, speed=1)
    open_live(page, mission["id"])
    x, y = free_point(page)
    px, py = page.evaluate(f"window.__regolith.pagePoint({x}, {y})")
    page.mouse.click(px, py)
    form = page.locator("#inject-form")
    expect(form).to_be_visible()
    form.get_by_role("button", name="Inject task").click()
    card = page.locator('#auction-feed li[data-kind="operator"]')
    expect(card.first).to_be_visible()
    loc = [float(v) for v in card.first.get_attribute("data-location").split(",")]
    # the form rounds to 0.1 m; the engine snaps a task within the scan radius of a known site
    assert math.dist(loc, (x, y)) < 2.6, (loc, (x, y))
    expect(form).to_be_hidden()


def test_switching_policy_shows_the_new_policy(
    operator: Page, start_mission: Start, api: httpx.Client
) -> None:
    page = operator
    mission = start_mission(seed=2, speed=1)
    open_live(page, mission["id"])
    expect(page.locator("#live-policy")).to_have_attribute("data-policy", "fcfs")
    page.locator("#policy-select").select_option("nearest")
    expect(page.locator("#live-policy")).to_have_attribute("data-policy", "nearest")
    expect(page.locator("#policy-select")).to_have_value("nearest")
    assert api.get(f"/missions/{mission['id']}").json()["policy"] == "nearest"


def test_without_a_token_the_controls_are_disabled(page: Page, start_mission: Start) -> None:
    mission = start_mission(seed=4, speed=1)
    page.goto("/#/missions")
    expect(page.locator("#readonly-banner")).to_be_visible()
    expect(page.locator("#operator-status")).to_have_text("Read-only")
    expect(page.locator("#start-form button[type=submit]")).to_be_disabled()
    open_live(page, mission["id"])
    controls = page.locator("#live [data-control]")
    assert controls.count() > 10
    for i in range(controls.count()):
        expect(controls.nth(i)).to_be_disabled()
    # a click on the map opens no task form for a viewer
    x, y = free_point(page)
    px, py = page.evaluate(f"window.__regolith.pagePoint({x}, {y})")
    page.mouse.click(px, py)
    expect(page.locator("#inject-form")).to_be_hidden()
    # the token is asked once, in a small form, and then the controls work
    page.get_by_role("button", name="Operator token…").click()
    page.locator("#token-dialog").get_by_label("Token").fill(TOKEN)
    page.locator("#token-dialog").get_by_role("button", name="Save").click()
    expect(page.locator("#operator-status")).to_have_text("Operator")
    expect(page.locator("#readonly-banner")).to_be_hidden()
    expect(page.locator("#policy-select")).to_be_enabled()
    fail = page.locator('#robot-table tr[data-robot="hauler-1"] [data-action="fail"]')
    expect(fail).to_be_enabled()
    assert page.evaluate("window.localStorage.getItem('regolith.token')") == TOKEN


def test_add_fail_and_enable_robots(operator: Page, start_mission: Start) -> None:
    page = operator
    mission = start_mission(seed=6, speed=1)
    open_live(page, mission["id"])
    page.locator("#add-robot-type").select_option("hauler")
    page.get_by_role("button", name="Add robot").click()
    expect(page.locator("#map")).to_have_attribute("data-robot-count", "13")
    row = page.locator('#robot-table tr[data-robot="hauler-7"]')
    expect(row).to_be_visible()
    row.get_by_role("button", name=re.compile("^Fail")).click()
    expect(row).to_have_attribute("data-state", "failed")
    row.get_by_role("button", name=re.compile("^Enable")).click()
    expect(row).not_to_have_attribute("data-state", re.compile("disabled|failed"))
    expect(row.get_by_role("button", name=re.compile("^Disable"))).to_be_enabled()


def test_graceful_disable_shows_disabled(operator: Page, start_mission: Start) -> None:
    page = operator
    mission = start_mission(seed=6, speed=1)
    open_live(page, mission["id"])
    row = page.locator('#robot-table tr[data-robot="hauler-6"]')
    row.get_by_role("button", name=re.compile("^Disable")).click()
    expect(row).to_have_attribute("data-state", "disabled")


SCENARIO_TOML = """\
# a small team on a small area, read by the server (POST /api/scenarios/parse)
name = "e2e-small"
width = 60.0
height = 60.0
sites = 4
minerals = 8
random_craters = 1

[team]
scouts = 1
excavators = 2
haulers = 3

[timing]
dig_s = 10.0
"""


def test_start_mission_from_an_uploaded_toml_scenario(
    operator: Page, api: httpx.Client, tmp_path: Path
) -> None:
    page = operator
    path = tmp_path / "small.toml"
    path.write_text(SCENARIO_TOML)
    page.goto("/#/missions")
    form = page.locator("#start-form")
    assert _choose(page, path).startswith("e2e-small: 60×60 m, 4 sites, team 1/2/3")
    form.get_by_label("Seed").fill("9")
    form.get_by_role("button", name="Start mission").click()
    expect(page).to_have_url(re.compile(r"#/live/\d+$"))
    mission_id = int(page.url.rsplit("/", 1)[1])
    try:
        expect(page.locator("#map")).to_have_attribute("data-robot-count", "6")
        mission = api.get(f"/missions/{mission_id}").json()
        assert mission["scenario_name"] == "e2e-small"
        assert mission["scenario"]["team"] == {"scouts": 1, "excavators": 2, "haulers": 3}
        assert mission["scenario"]["timing"]["dig_s"] == 10.0
        world = page.evaluate("window.__regolith.map")
        assert (world["width"], world["height"]) == (60.0, 60.0)
    finally:
        api.post(f"/missions/{mission_id}/stop")


def _choose(page: Page, path: Path) -> str:
    """Choose a scenario file in the start form; the server's reading of it, as shown."""
    form = page.locator("#start-form")
    with page.expect_response(lambda r: r.url.endswith("/api/scenarios/parse")) as parsed:
        form.get_by_label("Scenario file").set_input_files(str(path))
    assert parsed.value.request.post_data_json["text"] == path.read_text()
    summary = page.locator("#scenario-summary")
    expect(summary).not_to_be_empty()
    return summary.inner_text()


def test_scenario_files_are_read_by_the_server(operator: Page, tmp_path: Path) -> None:
    """The form sends the file's text to POST /api/scenarios/parse (tomllib or json there)
    and shows its errors naming the line or the field; nothing starts."""
    page = operator
    page.goto("/#/missions")
    page.get_by_label("Upload a file (.json or .toml)").check()
    bad_syntax = tmp_path / "broken.toml"
    bad_syntax.write_text('name = "x"\nwidth = \n')
    text = _choose(page, bad_syntax)
    assert text.startswith("Cannot read broken.toml: ") and "line 2" in text, text
    bad_field = tmp_path / "negative.toml"
    bad_field.write_text("[team]\nhaulers = -1\n")
    assert "scenario.team.haulers" in _choose(page, bad_field)
    page.locator("#start-form").get_by_role("button", name="Start mission").click()
    expect(page.locator("#start-error")).to_contain_text("negative.toml is not a scenario")
    assert page.url.endswith("#/missions")
    as_json = tmp_path / "small.json"
    as_json.write_text('{"name": "as-json", "sites": 3, "minerals": 6}')
    assert _choose(page, as_json).startswith("as-json: 100×100 m, 3 sites, team 2/4/6")
