"""The live view at scale: a real server, a live mission, the dashboard in Debian's
chromium, and what the browser sees of the stream.

    .venv/bin/python bench/live_view_bench.py                 # --scale 10, then --scale 100
    .venv/bin/python bench/live_view_bench.py --scales 10 --seconds 20

For each scale it starts a mission (reference scenario scaled K×, seed 1, straight-line
planner so the engine's planning is not what is measured), opens `/#/live/{id}` at
1280×800 and, over a window after a warm-up, prints: frames/s received; frame delay p50/p99
(the frame's server stamp `wall` → the dashboard has applied it, page clock); map draws per
second (one per animation frame while anything moves) and animation frames per second;
frame bytes p50/p99/max for deltas and for full frames / the snapshot. The engine at scale
100 is slow (minutes per mission), so that run is bounded by `--seconds`: the figures cover
however much of the mission ran in that time, which the report says.

Targets: scale 10, full frame rate (10/s), delay p99 < 100 ms, map at 60 fps with 120
robots; scale 100, delta frames < 64 KB and a usable map.
"""

from __future__ import annotations

import argparse
import os
import socket
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

import httpx
from playwright.sync_api import sync_playwright

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))
from service_bench import start_server  # noqa: E402 - bench/, beside this script

from engine import reference_scenario  # noqa: E402 - after the path is set

TOKEN = "bench-operator-token-0123456789"
AUTH = {"Authorization": f"Bearer {TOKEN}"}
CHROMIUM = os.environ.get("REGOLITH_CHROMIUM", "/usr/bin/chromium")
ARGS = ["--headless", "--no-sandbox", "--disable-gpu", "--disable-background-networking"]
ARGS += ["--disable-component-update", "--disable-sync", "--no-first-run"]

# Recorded in the page before the app runs: every stream message's size and kind, and for
# frames the delay from the server's stamp to the end of the app's handler (applied).
PROBE = """
(() => {
  const log = (window.__bench = { msgs: [], rafs: 0 });
  const tick = () => { log.rafs++; requestAnimationFrame(tick); };
  requestAnimationFrame(tick);
  const Native = window.WebSocket;
  window.WebSocket = class extends Native {
    set onmessage(fn) {
      super.onmessage = (e) => {
        const at = performance.timeOrigin + performance.now();
        let kind = "other", full = false, wall = null;
        const head = e.data.slice(0, 40);
        if (head.startsWith('{"type":"frame"')) {
          kind = "frame";
          full = e.data.includes('"full":true');
          const m = /"wall":([0-9.e+]+)/.exec(head);
          wall = m ? Number(m[1]) * 1000 : null;
        } else if (head.startsWith('{"type":"snapshot"')) kind = "snapshot";
        fn(e);
        const done = performance.timeOrigin + performance.now();
        const delay = wall === null ? null : done - wall;
        log.msgs.push({ kind, full, bytes: e.data.length, at, handled: done - at, delay });
      };
    }
  };
})();
"""


def free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])


def pct(values: list[float], q: float) -> float:
    ordered = sorted(values)
    return ordered[min(len(ordered) - 1, int(q * len(ordered)))] if ordered else float("nan")


def kb(n: float) -> str:
    return f"{n / 1024:.1f} KB"


def measure(
    base: str, api: httpx.Client, scale: int, speed: float, warm: float, window: float
) -> None:
    scenario = reference_scenario().scaled(scale).model_dump(mode="json")
    body = {"seed": 1, "speed": speed, "planner": "straight", "scenario": scenario}
    t0 = time.monotonic()
    r = api.post("/api/missions", json=body, timeout=600)
    r.raise_for_status()
    mid = r.json()["id"]
    built = time.monotonic() - t0
    with sync_playwright() as pw:
        browser = pw.chromium.launch(executable_path=CHROMIUM, headless=True, args=ARGS)
        page = browser.new_page(viewport={"width": 1280, "height": 800})
        page.add_init_script(PROBE)
        page.goto(f"{base}/#/live/{mid}")
        deadline = time.monotonic() + 600
        while not page.evaluate("Boolean(window.__regolith && window.__regolith.frames > 1)"):
            if time.monotonic() > deadline:
                raise SystemExit("no frames in the dashboard after 600 s")
            page.wait_for_timeout(200)
        page.wait_for_timeout(warm * 1000)
        before = page.evaluate(
            "({n: __bench.msgs.length, rafs: __bench.rafs, draws: __regolith.mapDraws,"
            " ms: __regolith.mapDrawMs, t: __regolith.t,"
            " now: performance.timeOrigin + performance.now()})"
        )
        page.wait_for_timeout(window * 1000)
        after = page.evaluate(
            "({n: __bench.msgs.length, rafs: __bench.rafs, draws: __regolith.mapDraws,"
            " ms: __regolith.mapDrawMs, t: __regolith.t,"
            " now: performance.timeOrigin + performance.now(),"
            " robots: __regolith.robots.length, onScreen: (__regolith.drawn || {}).onScreen,"
            " batches: (__regolith.drawn || {}).batches,"
            " labels: ((__regolith.drawn || {}).labels || []).length,"
            " rows: document.querySelectorAll('#robot-table tbody tr[data-robot]').length,"
            " cards: document.querySelectorAll('#auction-feed li[data-auction-id]').length,"
            " auctions: __regolith.auctions.length})"
        )
        msgs: list[dict[str, Any]] = page.evaluate("__bench.msgs")
        browser.close()
    api.post(f"/api/missions/{mid}/stop")
    secs = (after["now"] - before["now"]) / 1000
    inside = msgs[before["n"] : after["n"]]
    frames = [m for m in inside if m["kind"] == "frame"]
    delays = [m["delay"] for m in frames if m["delay"] is not None]
    handled = [m["handled"] for m in frames]
    draws = after["draws"] - before["draws"]
    draw_ms = (after["ms"] - before["ms"]) / max(1, draws)
    deltas = [m["bytes"] for m in msgs if m["kind"] == "frame" and not m["full"]]
    fulls = [m["bytes"] for m in msgs if m["kind"] == "frame" and m["full"]]
    snaps = [m["bytes"] for m in msgs if m["kind"] == "snapshot"]
    print(
        f"--scale {scale}: {after['robots']} robots, speed {speed}, mission built in {built:.1f} s"
    )
    print(f"  window {secs:.1f} s: simulated {before['t']:.0f} → {after['t']:.0f} s")
    print(f"  frames received   {len(frames) / secs:.1f} /s")
    print(f"  frame delay       p50 {pct(delays, 0.5):.1f} ms  p99 {pct(delays, 0.99):.1f} ms")
    print(f"  frame handling    p50 {pct(handled, 0.5):.1f} ms  p99 {pct(handled, 0.99):.1f} ms")
    print(
        f"  map               {draws / secs:.1f} draws/s ({draw_ms:.1f} ms each), "
        f"{(after['rafs'] - before['rafs']) / secs:.1f} animation frames/s "
        f"({after['onScreen']} robots on screen in {after['batches']} glyph paths, "
        f"{after['labels']} labels)"
    )
    print(
        f"  lists             {after['rows']} robot rows and {after['cards']} auction cards in "
        f"the DOM for {after['robots']} robots and {after['auctions']} auctions"
    )
    print(
        f"  delta bytes       p50 {kb(pct(deltas, 0.5))}  p99 {kb(pct(deltas, 0.99))}  "
        f"max {kb(max(deltas, default=0))}  ({len(deltas)} deltas, whole run)"
    )
    print(
        f"  snapshot bytes    {', '.join(kb(b) for b in snaps)}; full frames: "
        f"{', '.join(kb(b) for b in fulls) or 'none'}"
    )


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--scales", type=int, nargs="+", default=[10, 100])
    parser.add_argument("--seconds", type=float, default=20.0, help="measured window per scale")
    parser.add_argument("--warm", type=float, default=3.0, help="seconds before the window")
    parser.add_argument("--speed", type=float, default=20.0, help="simulated s per wall s")
    args = parser.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        port = free_port()
        # a scale-100 team is 1,200 robots (the default allows 500)
        proc = start_server(Path(tmp), port, {"REGOLITH_MAX_ROBOTS": "2000"})
        base = f"http://127.0.0.1:{port}"
        try:
            with httpx.Client(base_url=base, headers=AUTH, timeout=60) as api:
                for scale in args.scales:
                    measure(base, api, scale, args.speed, args.warm, args.seconds)
        finally:
            proc.terminate()
            proc.wait(timeout=30)


if __name__ == "__main__":
    main()
