"""A field mission (every robot its own process over Zenoh) on the dashboard, like a simulated
one: twelve robots on the map moving, counters rising, an operator SIGKILL of a hauler that
holds a transport shown as a failed robot, its transport re-auctioned to another, a new
excavator process joining and winning excavations, a pause (its time standing, no delivery)
and a resume, the mission (the compact one, tests/field/compact.py) run to completion at
50×; and all of it in the database's tables: every mineral delivered (docs/field.md).

Its live view tells the truth as a simulated one's does (docs/dashboard.md): the timeline is
on and says a field run plays back from its stored poses (tests/e2e/test_field_playback.py
scrubs one), each robot's distance travelled is measured from what mission control hears
(table, chart and stored metrics), the counters on completion are the final ones, only the
SIGKILLed hauler is shown failed (none whose process ended with the mission), and every
auction the API shows closed is closed in the feed (none left "open" after the end). (These
were a second field mission of their own, test_field_view.py; one mission serves both.)"""

from __future__ import annotations

import os
import time
from pathlib import Path

import httpx
import pytest
from playwright.sync_api import Page, expect

from tests.e2e.conftest import ConsoleLog, Server
from tests.e2e.test_dashboard import WORK, Start, free_point, open_live, wait_for
from tests.field.compact import COMPACT, compact_scenario
from tests.field.pace import paced
from tests.field.serial import one_field_mission_at_a_time
from tests.progress import STALL_S


@pytest.mark.fleet
def test_field_mission_on_the_dashboard(
    operator: Page, console: ConsoleLog, start_mission: Start, api: httpx.Client, server: Server
) -> None:
    with one_field_mission_at_a_time():
        _field_mission_on_the_dashboard(operator, console, start_mission, api, server)


def _field_mission_on_the_dashboard(
    page: Page, console: ConsoleLog, start_mission: Start, api: httpx.Client, server: Server
) -> None:
    mission = start_mission(
        policy="nearest", seed=0, speed=paced(50.0), field=True, scenario=COMPACT
    )
    mid = mission["id"]
    open_live(page, mid)
    expect(page.locator("#map")).to_have_attribute("data-robot-count", "12")
    first = {r["name"]: (r["x"], r["y"]) for r in page.evaluate("window.__regolith.robots")}
    # a field run plays back from its stored poses: the timeline is on and says so
    timeline = page.locator("#timeline")
    expect(timeline).to_have_attribute("data-source", "poses")
    expect(timeline).not_to_have_attribute("data-disabled", "true")
    expect(page.locator("#tl-range")).to_be_enabled()
    expect(page.locator("#tl-play")).to_be_enabled()
    expect(page.locator("#tl-source")).to_have_text("field: stored poses")
    # a new excavator joins (a new agent process) mid-mission and must win work: while the
    # scouts still find sites (the last ones by ~700 s; joining later, it raced the last
    # excavation auctions and could find none left)
    wait_for(page, "window.__regolith.lastCounters.sites_found >= 2", STALL_S, WORK)
    res = api.post(f"/missions/{mid}/robots", json={"type": "excavator"})
    assert res.status_code in (200, 201), res.text
    newcomer = res.json()["name"]
    expect(page.locator("#map")).to_have_attribute("data-robot-count", "13")
    wait_for(page, "window.__regolith.lastCounters.minerals_delivered >= 3", STALL_S, WORK)
    now = {r["name"]: (r["x"], r["y"]) for r in page.evaluate("window.__regolith.robots")}
    assert sum(now[n] != first[n] for n in first) >= 6  # the robots move on the map
    # distances from the heartbeats: every robot that moved has a distance, and the chart
    # shows each type's sum, while the mission runs
    wait_for(
        page,
        """[...document.querySelectorAll('#robot-table tr[data-robot]')]
            .filter(tr => Number(tr.dataset.distance) > 0).length >= 10""",
        STALL_S,
        WORK,
    )
    chart = page.evaluate("window.__regolith.charts.distance")
    assert all(chart.get(t, 0) > 0 for t in ("scout", "excavator", "hauler")), chart
    expect(page.locator("#chart-distance")).not_to_contain_text("no data")
    grown = table_distances(page)
    wait_for(  # and they grow as the robots drive on
        page,
        f"""(() => {{ const was = {grown};
            return [...document.querySelectorAll('#robot-table tr[data-robot]')]
              .filter(tr => Number(tr.dataset.distance) > (was[tr.dataset.robot] || 0) + 1)
              .length >= 6; }})()""",
        STALL_S,
        WORK,
    )
    # pause: every agent stands (field/clock.py), the dashboard shows the mission paused, its
    # time standing and no new delivery; then a speed button resumes it (as on a simulated
    # mission), and its own pace is given back; "max" means nothing on the wall clock
    expect(page.locator("[data-speed='max']")).to_be_disabled()
    expect(page.locator("#policy-select")).to_be_enabled()
    pace = api.get(f"/missions/{mid}").json()["speed"]
    page.locator("[data-speed='0']").click()
    expect(page.locator("#live-status")).to_have_attribute("data-status", "paused")
    paused = api.get(f"/missions/{mid}").json()
    assert paused["status"] == "paused", paused
    t0 = paused["sim_time"]
    # the frame of the pause moment (the world's count at the pause) may come after the
    # answer that said "paused": a delivery carried out just before it is counted there
    wait_for(page, f"window.__regolith.t >= {t0} - 1e-6", timeout=STALL_S)
    delivered = page.evaluate("window.__regolith.lastCounters.minerals_delivered")
    start = time.monotonic()
    while time.monotonic() - start < max(2.0, 150.0 / pace):  # ~4 deliveries' worth
        assert api.get(f"/missions/{mid}").json()["sim_time"] == t0
        assert page.evaluate("window.__regolith.lastCounters.minerals_delivered") == delivered
        page.wait_for_timeout(100)
    assert page.evaluate("window.__regolith.t") <= t0 + 1e-6
    page.locator("[data-speed='10']").click()
    expect(page.locator("#live-status")).to_have_attribute("data-status", "running")
    res = api.put(f"/missions/{mid}/speed", json={"speed": pace})
    assert res.status_code == 200 and res.json()["status"] == "running", res.text
    wait_for(page, f"window.__regolith.t > {t0}", STALL_S, WORK)
    acts = [a["kind"] for a in api.get(f"/missions/{mid}/actions").json()]
    assert acts[-4:] == ["pause", "speed", "resume", "speed"], acts

    # SIGKILL a hauler just after it won a transport: the task it held must be re-auctioned
    won = wait_for(  # won in the last 20 simulated seconds: still driving to its excavator
        page,
        """window.__regolith.auctions.find(a => a.kind === 'excavator_hauler'
            && a.status === 'closed' && a.allocated_to && !a.reauction_of
            && window.__regolith.stream.t - a.closed_at < 20)""",
        STALL_S,
        WORK,
    )
    victim = won["allocated_to"]
    res = api.post(f"/missions/{mid}/robots/{victim}/disable", json={"mode": "abrupt"})
    assert res.status_code == 200, res.text
    wait_for(
        page,
        f"window.__regolith.robots.some(r => r.name === '{victim}' && r.alive === false)",
    )
    # an operator task, as in a simulated mission: checked (422 naming the field), then
    # auctioned by the operator's console (its own agent process), asked over the wire
    res = api.post(f"/missions/{mid}/tasks", json={"type": "transport", "location": [-5, 10]})
    assert res.status_code == 422 and "location" in res.text, res.text
    x, y = free_point(page)
    res = api.post(f"/missions/{mid}/tasks", json={"type": "transport", "location": [x, y]})
    assert res.status_code == 201, res.text
    injected = res.json()["auction_id"]
    assert injected.startswith("operator/")
    wait_for(  # a hauler wins it (and finds nothing there to carry: a void transport)
        page,
        f"""window.__regolith.auctions.some(a => a.id === '{injected}' && a.kind === 'operator'
            && a.status === 'closed' && (a.allocated_to || '').startsWith('hauler-'))""",
        STALL_S,
        WORK,
    )
    # the victim's transport is re-auctioned (its peers notice the silence) and won by another
    wait_for(
        page,
        f"""window.__regolith.auctions.some(a => a.reauction_of === '{won["id"]}'
            && a.status === 'closed' && a.allocated_to && a.allocated_to !== '{victim}')""",
        STALL_S,
        WORK,
    )
    wait_for(
        page,
        f"""window.__regolith.auctions.some(a => a.task_type === 'excavate'
            && a.status === 'closed' && a.allocated_to === '{newcomer}')""",
        STALL_S,
        WORK,
    )
    # to the end: every mineral delivered, the killed hauler's load (if it had one) too
    wait_for(page, "window.__regolith.status !== 'running'", STALL_S, WORK)
    assert console.errors == []
    detail = api.get(f"/missions/{mid}").json()
    assert detail["status"] == "completed", detail
    m = detail["metrics"]
    compact = compact_scenario()
    assert m["minerals_delivered"] == m["minerals_total"] == compact.minerals, m
    assert m["sites_found"] == m["sites_total"] == compact.sites, m
    wait_for(page, "window.__regolith.final")
    # the counters are the final ones (the stored metrics)
    counters = page.evaluate("window.__regolith.lastCounters")
    assert counters["minerals_delivered"] == m["minerals_delivered"], (counters, m)
    everything = f"{compact.minerals}/{compact.minerals}"
    expect(page.locator("[data-counter='minerals']")).to_have_text(everything)
    # only the SIGKILLed hauler is shown failed: none because its process ended with the mission
    failed = page.locator('#robot-table tr[data-robot][data-state="failed"]')
    expect(failed).to_have_count(1)
    expect(failed).to_have_attribute("data-robot", victim)
    # the stored metrics carry the distances, as a simulated run's do
    assert all(m["distance"][t] > 0 for t in ("scout", "excavator", "hauler")), m["distance"]
    assert m["distance_total"] == pytest.approx(sum(m["distance"].values()))
    # every auction as the API has it: closed in the feed too, none left open
    listed = api.get(f"/missions/{mid}/auctions", params={"limit": 500}).json()["items"]
    expect(page.locator("#feed-count")).to_have_text(f"{len(listed)} · 0 open")
    feed = {a["id"]: a["status"] for a in page.evaluate("window.__regolith.auctions")}
    assert set(feed) == {a["id"] for a in listed}
    wrong = {a["id"]: (feed[a["id"]], a["status"]) for a in listed if feed[a["id"]] != a["status"]}
    assert wrong == {}, wrong
    assert console.errors == []

    # what mission control recorded is in the database, in the same tables as a simulated
    # mission's: the victim's transport re-auctioned to another, the newcomer's excavations
    items = api.get(f"/missions/{mid}/auctions", params={"limit": 500}).json()["items"]
    assert all(a["policy"] == "nearest" for a in items)
    again = [a for a in items if a["reauction_of"] == won["id"]]
    assert any(a["status"] == "closed" and a["allocated_to"] != victim for a in again), again
    assert any(
        a["task_type"] == "excavate" and a["allocated_to"] == newcomer and a["status"] == "closed"
        for a in items
    ), (newcomer, [(a["id"], a["allocated_to"]) for a in items if a["task_type"] == "excavate"])

    def events(kind: str) -> list[dict[str, object]]:
        res = api.get(f"/missions/{mid}/events", params={"kind": kind, "limit": 500})
        return list(res.json()["items"])

    assert len(events("delivered")) == compact.minerals  # each delivery recorded once
    (inj,) = events("task_injected")
    assert inj["data"]["auction_id"] == injected and inj["data"]["task_type"] == "transport"
    assert [a["id"] for a in items if a["kind"] == "operator"] == [injected]
    acts = api.get(f"/missions/{mid}/actions").json()
    assert [a["kind"] for a in acts].count("inject_task") == 1, acts
    assert len(events("mineral_dropped")) == len(events("mineral_recovered"))
    # the agents' processes are gone once the mission has ended
    deadline = time.monotonic() + 15
    assert server.proc is not None
    while _agents(server.proc.pid):
        assert time.monotonic() < deadline, f"agents left running: {_agents(server.proc.pid)}"
        time.sleep(0.2)


def _agents(parent: int) -> list[int]:
    """Agent processes the server started that are still running (not zombies)."""
    out = []
    for pid in os.listdir("/proc"):
        if not pid.isdigit():
            continue
        try:
            cmd = Path(f"/proc/{pid}/cmdline").read_bytes()
            stat = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()
        except OSError:
            continue
        if b"app.cli\x00agent" in cmd and int(stat[1]) == parent and stat[0] != "Z":
            out.append(int(pid))
    return out


def table_distances(page: Page) -> dict[str, float]:
    return dict(
        page.evaluate(
            """Object.fromEntries([...document.querySelectorAll('#robot-table tr[data-robot]')]
                .map(tr => [tr.dataset.robot, Number(tr.dataset.distance)]))"""
        )
    )
