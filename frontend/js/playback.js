// Mission playback: show any earlier moment of the mission in the live view. The state at a
// simulated time t comes from the server (`GET /api/missions/{id}/state?t=`, rebuilt there by
// replay, so it is exact; a field run's from its robots' stored poses and events, in the same
// shape, since it cannot be re-simulated); this module asks for it as the timeline is scrubbed or played and
// puts it on the map, the robot table, the auction feed and the charts. While it looks back
// at a live mission the stream stays connected: status messages still reach the badge, the
// timeline's end follows the frames, and "Back to live" reconnects for a fresh snapshot.

import { $, toast } from "./dom.js";
import { get, qs } from "./api.js";
import { ENDED } from "./status.js";
import { Timeline } from "./timeline.js";

const TICK_MS = 100; // playback pacing (wall clock); answers slower than this skip frames
const MARKERS_MS = 10000; // marker refresh while the mission is live
const MARKER_EVENTS = { robot_failed: "failure", policy_changed: "policy", site_found: "site" };
const MARKER_PAGES = 10;
const MARKER_KINDS = Object.keys(MARKER_EVENTS).map((k) => `&kind=${k}`).join("");

function scalar(v) {
  if (Array.isArray(v)) return `(${v.map((x) => (typeof x === "number" ? x.toFixed(1) : x)).join(", ")})`;
  return typeof v === "object" && v !== null ? "" : String(v);
}

/** A marker's text: what happened, from the event's documented fields or the action's args. */
function eventText(ev) {
  const d = ev.data;
  if (ev.kind === "robot_failed") return `${d.robot} failed`;
  if (ev.kind === "policy_changed") return `${d.old} → ${d.new}`;
  return `${d.site} found by ${d.by}`;
}

/** Put a mission state at t (the `/state` answer) on every part of the live view. */
function render(view, p, snap) {
  const s = p.state;
  view._unfinal(); // a moment of the run, not the stored ending: frames may move it again
  view.map.setSites(s.sites); // every site, found or not, so later finds are hidden again
  view.map.setDropped(s.dropped);
  view.feed.reset();
  view.feed.load(p.auctions);
  view.charts.reset();
  view._setDetail(s.robots); // the robot table's details and the distance chart
  view.charts.loadDeliveries(p.deliveries);
  view._frame(s, { snap });
}

export class Playback {
  /** view: the LiveView whose parts it fills while looking back. */
  constructor(view) {
    this.view = view;
    this.timeline = new Timeline($("#live-notice"), {
      onSeek: (t) => this.seek(t),
      onPlay: () => this.play(),
      onPause: () => this.pause(),
      onSpeed: (x) => (this.speed = x),
      onLatest: () => this.latest(),
    });
    this.speed = 10;
    this.timer = null;
    this.markerTimer = null;
    this.open(null);
  }

  /** Looking back (the view shows an earlier moment, not the stream). */
  get active() {
    return this.mode === "back";
  }

  /** A new mission (or none): follow its stream (its markers are read at its first snapshot). */
  open(id) {
    this.pause();
    clearInterval(this.markerTimer);
    this.id = id;
    this.mode = "latest";
    this.t = 0;
    this.want = null;
    this.busy = false;
    this.timeline.end = -1;
    this.timeline.setEnd(0);
    this.timeline.setTime(0);
    this.timeline.setMarkers([], () => {});
    this.timeline.setDisabled(null);
    this.timeline.setSource("replay");
    this._mode("latest");
    this.loaded = false; // markers are read once the stream says the mission exists
  }

  _loadMarkers() {
    const id = this.id;
    this.loaded = true;
    this._markers();
    this.markerTimer = setInterval(() => this.view.id === id && this.view.live && !document.hidden && this._markers(), MARKERS_MS);
  }

  /** A stream message: true if the view must not apply it (it is looking back). */
  intercept(msg) {
    if (msg.type === "frame") this._liveTime(msg.t);
    else if (msg.type === "snapshot") {
      const m = msg.mission; // the badge is the server's word, even while looking back
      this.timeline.setSource(m.mode === "field" ? "poses" : "replay"); // said; played back alike
      if (!this.loaded) this._loadMarkers();
      this._liveTime(m.sim_time);
      if (this.active) this.view.status.set({ status: m.status, policy: m.policy, speed: m.speed, error: m.error });
    } else if (msg.type === "status" && ENDED.has(msg.status)) this._ended();
    return this.active && msg.type !== "status";
  }

  _liveTime(t) {
    if (!(t >= 0)) return;
    if (t > this.timeline.end) this.timeline.setEnd(t);
    if (!this.active) {
      this.t = t;
      this.timeline.setTime(t);
    }
  }

  async _ended() {
    const id = this.id;
    try {
      const m = await get(`/missions/${encodeURIComponent(id)}`);
      if (id !== this.id) return;
      this.timeline.setEnd(m.sim_time);
      this._mode(this.mode);
      this._markers();
    } catch {
      /* the next answer carries the end */
    }
  }

  /** Show the mission at simulated time t (entering look-back). */
  seek(t) {
    if (!this.id || this.timeline.disabled) return;
    const end = this.timeline.end;
    t = Math.max(0, Math.min(end, Number(t) || 0));
    if (!this.active) this._mode("back");
    this.t = t;
    this.timeline.setTime(t);
    this.want = t;
    this._pump();
  }

  /** One request at a time; a scrub that moves on meanwhile asks only for its latest time. */
  async _pump() {
    if (this.busy) return;
    this.busy = true;
    try {
      while (this.want !== null) {
        const t = this.want;
        const id = this.id;
        this.want = null;
        let p;
        try {
          p = await get(`/missions/${encodeURIComponent(id)}/state${qs({ t })}`);
        } catch (e) {
          if (id === this.id) {
            toast(`Playback: ${e.message}`, "error");
            // never leave the view on a moment it could not show: back to the present
            if (this.active) return this.latest();
            this.pause();
          }
          continue;
        }
        if (id !== this.id || !this.active) return;
        this.timeline.setEnd(p.end);
        render(this.view, p, !this.playing);
        this.timeline.shown(p.t, p.state.policy);
      }
    } finally {
      this.busy = false;
    }
  }

  play() {
    if (!this.id) return;
    if (!this.active || this.t >= this.timeline.end - 1e-6) this.t = 0;
    this.playing = true;
    this.timeline.setPlaying(true);
    this.last = performance.now();
    clearInterval(this.timer);
    this.timer = setInterval(() => this._tick(), TICK_MS);
    this.seek(this.t);
  }

  pause() {
    clearInterval(this.timer);
    this.timer = null;
    this.playing = false;
    this.timeline.setPlaying(false);
  }

  _tick() {
    const now = performance.now();
    const dt = (now - this.last) / 1000;
    this.last = now;
    if (this.id !== this.view.id || !this.active) return this.pause();
    const end = this.timeline.end;
    const t = Math.min(end, this.t + dt * this.speed);
    this.seek(t);
    if (t < end) return undefined;
    // caught up: a live mission goes back to its stream, a finished one stops at its end
    return this.view.live ? this.latest() : this.pause();
  }

  /** Back to the stream (live) or the final state: reconnect for a fresh snapshot. */
  latest() {
    const id = this.id;
    this.pause();
    this._mode("latest");
    this.view.close();
    this.view.open(id);
  }

  _mode(mode) {
    this.mode = mode;
    const label = this.view.live ? "Back to live" : this.view.finished ? "Final state" : "Latest state";
    this.timeline.setMode(mode, label);
    $("#live").classList.toggle("looking-back", mode === "back");
    if (mode === "back") this.view.controls.closePick();
  }

  /** Markers from the stored events and operator actions. */
  async _markers() {
    const id = this.id;
    const path = `/missions/${encodeURIComponent(id)}`;
    try {
      const marks = [];
      let after = -1;
      for (let page = 0; page < MARKER_PAGES && after !== null; page += 1) {
        const data = await get(`${path}/events${qs({ after, limit: 1000 })}${MARKER_KINDS}`);
        for (const ev of data.items) marks.push({ t: ev.t, kind: MARKER_EVENTS[ev.kind], text: eventText(ev) });
        after = data.next_after;
      }
      for (const a of await get(`${path}/actions`)) {
        if (!a.replay && a.kind !== "stop") continue;
        const args = Object.values(a.args || {}).map(scalar).filter(Boolean).join(" ");
        marks.push({ t: a.t, kind: "operator", text: `${a.kind.replace("_", " ")} ${args}`.trim() });
      }
      if (id !== this.id) return;
      marks.sort((a, b) => a.t - b.t);
      this.timeline.setMarkers(marks, (t) => this.seek(t));
    } catch {
      /* markers are a help, not the state: the next refresh retries */
    }
  }
}
