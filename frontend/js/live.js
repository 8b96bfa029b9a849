// The live mission view: one WebSocket stream feeding the map, the robot list, the auction
// feed and the charts; the operator's controls call the REST API. The mission's status is
// the server's word only (status.js): frames move robots and the clock, never the status.

import { $, clock, toast } from "./dom.js";
import { get } from "./api.js";
import { LiveStream } from "./stream.js";
import { MapView } from "./mapview.js";
import { AuctionFeed } from "./feed.js";
import { RobotTable } from "./robots.js";
import { LiveCharts } from "./livecharts.js";
import { Controls } from "./controls.js";
import { ENDED, LIVE, MissionStatus } from "./status.js";
import { COUNTER_KEYS, loadFinal, showCounters, validId } from "./final.js";
import { exposeLive } from "./liveexpose.js";
import { Playback } from "./playback.js";
import { FrameState } from "./framestate.js";
import { loadHistory } from "./livehistory.js";
import { showHover, showLegendItem, siteEvent } from "./livemap.js";

const DETAIL_MS = 1000; // robot list (paths, tasks, distance) refresh while the stream runs
const FRAME_FIELDS = ["name", "type", "state", "x", "y", "heading", "load", "alive"];

function pick(obj, keys) {
  const out = {};
  for (const k of keys) if (k in obj) out[k] = obj[k];
  return out;
}

export class LiveView {
  constructor() {
    this.id = null;
    this.stream = new LiveStream({
      onMessage: (msg) => this.handle(msg),
      onNotFound: () => this._notFound(this.id),
      retry: () => !this.finished,
    });
    this.poll = null;
    this.finalShown = null; // the id whose stored ending is shown
    this.state = this._empty();
    this.frames = new FrameState(); // the stream's state: snapshot + deltas (framestate.js)
    this.resyncAsked = false;
    // the parts below know this view only through these callbacks
    this.map = new MapView($("#map"), {
      onPick: (x, y) => this.playback.active || this.controls.pick(x, y), // none while looking back
      onCursor: (x, y) => showHover(this.map, this.state.detail, x, y),
    });
    this.feed = new AuctionFeed($("#auction-feed"), $("#feed-count"));
    this.table = new RobotTable($("#robot-table tbody"), $("#robot-count"), {
      onAction: (name, action) => this.controls.robotAction(name, action),
    });
    this.charts = new LiveCharts({ openTimes: () => this.feed.openTimes() });
    this.status = new MissionStatus({
      missionId: () => this.id,
      onControls: (operator, live) => {
        this.table.setControl(operator, !live);
        if (!live) this.controls.closePick();
        if (live && this.finalShown !== null) this._unfinal({ resumed: true });
      },
      onEnded: (simTime) => {
        this.state.t = simTime;
        $("#live-time").textContent = clock(simTime);
        this._showFinal();
      },
    });
    this.controls = new Controls({
      mission: () => ({ id: this.id, status: this.status.status, policy: this.status.policy, speed: this.status.speed, map: this.state.map }),
      onStatus: (m) => this.status.set(m),
      onRobotsChanged: () => this._refreshDetail({ now: true }),
      showPick: (point) => this.map.setPick(point),
      toScreen: (x, y) => this.map.toScreen(x, y),
    });
    $("#toggle-truth").addEventListener("change", (e) => this.map.setOption("truth", e.target.checked));
    $("#toggle-paths").addEventListener("change", (e) => this.map.setOption("paths", e.target.checked));
    $("#toggle-labels").addEventListener("change", (e) => this.map.setOption("labels", e.target.checked));
    $("#map-fit").addEventListener("click", () => this.map.fit());
    $("#feed-open-only").addEventListener("change", (e) => $("#auction-feed").classList.toggle("open-only", e.target.checked));
    this.playback = new Playback(this); // the timeline: looks back at any moment (playback.js)
    exposeLive(this);
  }

  _empty() {
    return {
      mission: null,
      map: null,
      t: 0,
      frames: 0,
      lastFrame: null,
      robots: new Map(), // name -> latest frame robot
      detail: new Map(), // name -> robot-list entry
      counters: {},
      events: [],
    };
  }

  /** Ended for good (completed, stopped, stalled, …): shown from its record. */
  get finished() {
    return ENDED.has(this.status.status);
  }

  /** Running or paused: the only states in which controls work. */
  get live() {
    return LIVE.has(this.status.status);
  }

  /** Show mission `id` (or nothing), reconnecting the stream. */
  open(id) {
    if (id === this.id && this.stream.open) return undefined;
    this.close();
    this.id = id;
    this.playback.open(id);
    this._unfinal();
    this._empty_view(id ? "" : "none");
    if (!id) return;
    if (!validId(id)) return this._notFound(id);
    this.state = this._empty();
    this.status.reset();
    this.status.set({});
    this.feed.reset();
    this.table.reset();
    this.charts.reset();
    $("#live-mission-id").textContent = id;
    this.opened = (this.opened || 0) + 1;
    this._start(id, this.opened);
    return undefined;
  }

  /** Ask for the record first: an unknown mission is said so, without a stream or polls. */
  async _start(id, opened) {
    const current = () => opened === this.opened && id === this.id; // not reopened meanwhile
    try {
      await get(`/missions/${encodeURIComponent(id)}`);
    } catch (err) {
      if (current() && err.status === 404) this._notFound(id);
      else if (current()) toast(`Mission ${id}: ${err.message}`, "error");
      if (err.status === 404 || err.status === 422) return;
    }
    if (!current()) return;
    this.stream.connect(id);
    loadHistory(id, { feed: this.feed, charts: this.charts, current: () => id === this.id }).then(() => id === this.id && this._recount());
    this.poll = setInterval(() => this._refreshDetail(), DETAIL_MS);
  }

  /** The empty live page: "none" (no mission picked), "not-found", or "" (a mission shown). */
  _empty_view(reason) {
    const box = $("#live-empty");
    box.hidden = !reason;
    box.dataset.reason = reason;
    $("#live-empty-none").hidden = reason !== "none";
    $("#live-empty-missing").hidden = reason !== "not-found";
    $("#live").hidden = Boolean(reason);
  }

  _notFound(id) {
    this._empty_view("not-found");
    $("#live-missing-id").textContent = id;
    document.title = "Regolith · mission not found";
  }

  close() {
    this.opened = (this.opened || 0) + 1; // a pending _start gives up
    this.stream.close();
    clearInterval(this.poll);
    this.poll = null;
    this.map.stop();
    this.id = null;
  }

  /** One message from the live stream. */
  handle(msg) {
    // frames are deltas: the stream's state follows every one, even while looking back
    if (msg.type === "snapshot") this.frames.snapshot(msg);
    if (msg.type === "frame" && !this._follow(msg)) return undefined;
    if (this.playback.intercept(msg)) return undefined; // looking back: the stream waits
    switch (msg.type) {
      case "snapshot":
        return this._snapshot(msg);
      case "frame":
        return this._frame(this.frames.view());
      case "auction":
        this.feed.upsert(msg.auction);
        return this._recount(); // the box counts auctions as the feed does
      case "event":
        return this._event(msg.event);
      case "status":
        this.status.set(msg);
        return ENDED.has(msg.status) ? this.status.settle() : undefined;
      default:
        return undefined;
    }
  }

  /** Apply a frame to the stream's state; after a gap, ask once for a full frame. */
  _follow(msg) {
    if (this.frames.apply(msg)) {
      this.resyncAsked = false;
      return true;
    }
    if (!this.resyncAsked) this.resyncAsked = this.stream.send({ type: "resync" });
    return false;
  }

  /** {mission: MissionRead, map: world map, seq, state: Mission.snapshot() or null}. */
  _snapshot(msg) {
    const m = msg.mission;
    // `state` is null only when the server crashed before storing one: nothing at the record's time
    const snap = msg.state ?? { t: m.sim_time, robots: [], sites: [], dropped: [], auctions: [], counters: {}, scanned: null };
    this.state.mission = m;
    if (msg.map) this.map.setMap(msg.map);
    this.state.map = msg.map;
    this.map.setSites(snap.sites);
    this.map.setDropped(snap.dropped);
    for (const a of snap.auctions) this.feed.upsert(a, { flash: false });
    this._setDetail(snap.robots);
    // the record's status, never the engine's (a stored state says "running" after a stop
    // or a restart); the record's policy is the current one
    this.status.set({ status: m.status, policy: m.policy, speed: m.speed, error: m.error, mode: m.mode });
    this._frame(snap, { snap: true });
    if (m.status && !LIVE.has(m.status)) this._showFinal(); // ended or interrupted: as stored
  }

  _frame(f, { snap = false } = {}) {
    if (this.finalShown === this.id && !snap) return; // the stored ending is shown
    const s = this.state;
    s.t = f.t;
    s.frames += 1;
    s.lastFrame = f;
    s.counters = f.counters;
    const robots = f.robots;
    // keep only the per-frame fields: task, distance and path come from the robot list
    const names = new Set();
    for (const r of robots) {
      names.add(r.name);
      s.robots.set(r.name, pick(r, FRAME_FIELDS));
    }
    for (const name of [...s.robots.keys()]) if (!names.has(name)) s.robots.delete(name);
    this.map.setRobots(robots, { snap });
    showLegendItem("charge", robots.some((r) => r.charge !== undefined && r.charge !== null));
    if (f.scannedBits) this.map.setScannedBits(f.scannedBits);
    else if (f.scanned) this.map.setScanned(f.scanned);
    const canvas = $("#map");
    canvas.dataset.robotCount = String(robots.length);
    canvas.dataset.frameCount = String(s.frames);
    $("#live-time").textContent = clock(s.t);
    this.feed.tick(s.t);
    this.map.setOpenAuctions(this.feed.open());
    this.table.update([...s.robots.values()], s.detail);
    this._counters(f);
    this.charts.onFrame({ t: s.t, counters: s.counters });
  }

  /** The counters box again, with the counters shown (a frame's, or the stored ending's). */
  _recount() {
    this._counters({ ...(this.state.lastFrame || {}), counters: this.state.counters });
  }

  _counters(f) {
    if (f.counters?.auctions !== undefined) this.feed.setKnown(f.counters.auctions);
    showCounters($("#live-counters"), f, this.state.map?.grid, this.feed.counts());
  }

  /** {seq, t, kind, data}: the engine's event (data as docs/engine-api.md lists it). */
  _event(ev) {
    const d = ev.data;
    this.state.events.push(ev);
    if (this.state.events.length > 500) this.state.events.splice(0, 250);
    switch (ev.kind) {
      case "site_found":
      case "dug":
        siteEvent(this.map, this.state.map, ev.kind, d);
        break;
      case "mineral_dropped":
        this.map.addDropped(d.x, d.y);
        break;
      case "mineral_recovered":
        this.map.removeDropped(d.x, d.y);
        break;
      case "policy_changed": // {old, new}
        this.status.set({ policy: d.new });
        this._refreshDetail({ now: true });
        break;
      case "robot_added":
      case "robot_failed":
      case "robot_disabled":
      case "robot_enabled":
      case "failure_detected":
        this._refreshDetail({ now: true });
        break;
      default:
        break;
    }
  }

  /** Enable or disable every control for the current token and mission state. */
  applyControl() {
    this.status.apply();
  }

  _setDetail(list) {
    showLegendItem("pair", list.some((r) => r.partner));
    this.state.detail = new Map(list.map((r) => [r.name, r]));
    this.map.setDetail(list);
    this.charts.onDetail(list);
  }

  /**
   * The robot list was read after the latest frame, so its poses and states are at least as
   * new: apply them when frames have stopped (paused), so a robot the operator failed shows
   * as failed at once.
   */
  _poseFromDetail(list) {
    const s = this.state;
    // while frames flow they are fresher, and extra poses would upset the glide timing
    if (!list.length || !s.map || this.map.framesFlowing()) return;
    for (const r of list) s.robots.set(r.name, pick(r, FRAME_FIELDS));
    const robots = [...s.robots.values()];
    this.map.setRobots(robots, { polled: true });
    $("#map").dataset.robotCount = String(robots.length);
    this.table.update(robots, s.detail);
  }

  async _refreshDetail({ now = false } = {}) {
    const id = this.id;
    if (!id || document.hidden || this.playback.active) return; // looking back: not now
    // a big team's list (paths and all) is read less often: every 1 s up to 200 robots, up to 5 s
    const every = Math.min(5000, DETAIL_MS * Math.max(1, this.state.robots.size / 200));
    if (!now && performance.now() - (this.detailAt || 0) < every - 50) return;
    this.detailAt = performance.now();
    try {
      const list = await get(`/missions/${encodeURIComponent(id)}/robots`); // [RobotRead]
      if (id !== this.id || this.finalShown === id) return; // may predate the ending
      this._setDetail(list);
      this._poseFromDetail(list);
      if (this.finished) {
        clearInterval(this.poll);
        this.poll = null;
      }
    } catch {
      // the stream still shows positions; the next poll retries
    }
  }

  /** Redraw everything (robots, table, counters, clock, charts) from the stored ending. */
  async _showFinal() {
    const id = this.id;
    if (!id || this.finalLoading === id) return;
    this.finalLoading = id;
    let fin = null;
    try {
      fin = await loadFinal(id);
    } catch {
      /* the stream's view stays; a reconnect tries again */
    }
    if (this.finalLoading === id) this.finalLoading = null;
    if (!fin || id !== this.id || LIVE.has(this.status.status) || this.playback.active) return;
    const s = this.state;
    this.finalShown = id;
    clearInterval(this.poll);
    this.poll = null;
    this._setDetail(fin.robots);
    s.robots = new Map(fin.robots.map((r) => [r.name, pick(r, FRAME_FIELDS)]));
    this.map.setRobots(fin.robots, { snap: true });
    $("#map").dataset.robotCount = String(fin.robots.length);
    this.table.update(fin.robots);
    s.t = fin.mission.sim_time;
    $("#live-time").textContent = clock(s.t);
    if (fin.metrics) s.counters = { ...s.counters, ...pick(fin.metrics, COUNTER_KEYS) };
    this._recount();
    this.charts.showFinal({ t: s.t, deliveries: fin.deliveries, metrics: fin.metrics, robots: fin.robots, openTimes: fin.openTimes });
    $("#live").dataset.final = "true";
    // an auction the feed still shows open is read again as stored (its close may have come
    // after the stream's last word)
    if (this.feed.openIds.size) {
      const current = () => this.finalShown === id && id === this.id;
      loadHistory(id, { feed: this.feed, charts: this.charts, current }).then(() => current() && this._recount());
    }
  }

  /** Back to the stream's word: another mission, or this one resumed (polls again). */
  _unfinal({ resumed = false } = {}) {
    this.finalShown = null;
    this.charts.final = false;
    delete $("#live").dataset.final;
    if (resumed && this.id && !this.poll) this.poll = setInterval(() => this._refreshDetail(), DETAIL_MS);
  }
}
