"""A field run played back in the browser: a real field mission (twelve agent processes over
Zenoh) run a few hundred seconds and stopped, then scrubbed; at every moment shown the robots
drawn are where the poses the database holds put them (docs/field.md, *Playback of a field
run*), and no request is refused with 409."""

from __future__ import annotations

import math
import random
from typing import Any

import httpx
import pytest
from playwright.sync_api import Page, Response, expect
from sqlalchemy import text

from app.db.session import make_engine
from app.settings import Settings
from tests.e2e.conftest import ARTIFACTS, ConsoleLog, Server
from tests.e2e.test_dashboard import Start, wait_for
from tests.field.pace import paced
from tests.field.serial import one_field_mission_at_a_time
from tests.progress import wait_progress

Pose = tuple[str, float, float, float, str]  # robot, t, x, y, state


def _poses(server: Server, mid: int) -> list[Pose]:
    engine = make_engine(Settings(data_dir=server.data_dir).database_url)
    try:
        with engine.connect() as db:
            rows = db.execute(
                text("select robot, t, x, y, state from poses where mission_id = :m order by t"),
                {"m": mid},
            )
            return [tuple(r) for r in rows]  # type: ignore[misc]
    finally:
        engine.dispose()


def _expected(poses: list[Pose], t: float) -> dict[str, tuple[float, float, str]]:
    """Each robot at `t` from the rows alone: between its poses around `t`, on the line."""
    out = {}
    for name in {p[0] for p in poses}:
        track = [p for p in poses if p[0] == name]
        before = [p for p in track if p[1] <= t]
        if not before:
            continue  # not started yet: not drawn
        a = before[-1]
        after = next((p for p in track if p[1] > t), None)
        if after is None:
            out[name] = (a[2], a[3], a[4])
            continue
        f = (t - a[1]) / (after[1] - a[1])
        out[name] = (a[2] + f * (after[2] - a[2]), a[3] + f * (after[3] - a[3]), a[4])
    return out


@pytest.mark.fleet
def test_scrub_a_stopped_field_run(
    operator: Page, console: ConsoleLog, start_mission: Start, api: httpx.Client, server: Server
) -> None:
    page = operator
    refused: list[str] = []

    def note(r: Response) -> None:
        if r.status == 409:
            refused.append(r.url)

    page.on("response", note)
    with one_field_mission_at_a_time():
        mission = start_mission(policy="nearest", seed=0, speed=paced(100.0), field=True)
        mid = mission["id"]

        def reported() -> bool:
            poses = _poses(server, mid)
            return len({p[0] for p in poses}) == 12 and poses[-1][1] > poses[0][1] + 150

        wait_progress(reported, lambda: api.get(f"/missions/{mid}").json()["sim_time"], "poses")
        api.post(f"/missions/{mid}/stop").raise_for_status()
    end = api.get(f"/missions/{mid}").json()["sim_time"]
    poses = _poses(server, mid)

    page.goto(f"/#/live/{mid}")
    wait_for(page, "window.__regolith && window.__regolith.final")
    timeline = page.locator("#timeline")
    expect(timeline).to_have_attribute("data-end", str(end))
    expect(timeline).to_have_attribute("data-source", "poses")
    expect(timeline).not_to_have_attribute("data-disabled", "true")
    expect(page.locator("#tl-source")).to_be_visible()
    expect(page.locator("#tl-source")).to_have_text("field: stored poses")
    expect(page.locator("#tl-range")).to_be_enabled()

    # moments: before anyone reported, at a stored pose, between two, after the last
    rng = random.Random()
    some = rng.choice(poses[len(poses) // 3 : -12])
    nxt = next(q for q in poses if q[0] == some[0] and q[1] > some[1])
    # (to the millisecond, rounded down: the slider clamps a time past the end to the end)
    times = [
        math.floor(1000 * t) / 1000
        for t in (poses[0][1] / 2, some[1], (some[1] + nxt[1]) / 2, min(end, poses[-1][1] + 1))
    ]
    for t in times:
        page.locator("#tl-range").fill(str(t))
        wait_for(page, f"Number(document.querySelector('#timeline').dataset.shownT) === {t}")
        expect(timeline).to_have_attribute("data-mode", "back")
        drawn: dict[str, Any] = {
            r["name"]: (r["x"], r["y"], r["state"]) for r in page.evaluate("__regolith.robots")
        }
        want = _expected(poses, t)
        assert set(drawn) == set(want), (t, sorted(drawn), sorted(want))
        for name, (x, y, state) in want.items():
            assert drawn[name][:2] == pytest.approx((x, y), abs=1e-6), (t, name)
            assert drawn[name][2] == state, (t, name)
        rows = page.locator("#robot-table tr[data-robot]")
        expect(rows).to_have_count(len(want))
    ARTIFACTS.mkdir(parents=True, exist_ok=True)
    page.screenshot(path=str(ARTIFACTS / "field-playback-scrubbed.png"))
    assert refused == []
    assert console.errors == []
