// The live map: a Canvas 2D view of the area to scale, with zoom (wheel, +/-), pan (drag,
// arrow keys), smooth robot motion between frames, and click-to-pick a point.

import { drawScene } from "./mapdraw.js";
import { WORKING } from "./maprobots.js";

const DRAG_PX = 4; // a press that moves less than this is a click, not a pan
const LABEL_PAD = 22; // px kept clear around the fitted area for the labels at its edge

/** Shortest signed angle from a to b. */
function angleDelta(a, b) {
  let d = (b - a) % (2 * Math.PI);
  if (d > Math.PI) d -= 2 * Math.PI;
  if (d < -Math.PI) d += 2 * Math.PI;
  return d;
}

export class MapView {
  constructor(canvas, { onPick, onCursor } = {}) {
    this.canvas = canvas;
    this.ctx = canvas.getContext("2d");
    this.onPick = onPick || (() => {});
    this.onCursor = onCursor || (() => {});
    this.map = null;
    this.scene = {
      robots: new Map(), // name -> {name, type, state, load, alive, x, y, heading}
      detail: new Map(), // name -> robot-list entry (path, partner, task, type)
      sites: new Map(), // id -> {id, x, y, found, remaining, total}
      dropped: [],
      openAuctions: [],
      scanned: null, // offscreen canvas, one pixel per grid cell
      pick: null, // {x, y} the operator is about to inject at
      options: { truth: false, paths: true, labels: true },
    };
    this.motion = new Map(); // name -> {from, to, start, dur}
    this.lastFrameWall = 0;
    this.frameGap = 100;
    this.view = { scale: 1, ox: 0, oy: 0, fit: 1 };
    this.fitted = false;
    this.dpr = window.devicePixelRatio || 1;
    this.running = false;
    this._bindInput();
    new ResizeObserver(() => this._resize()).observe(canvas.parentElement);
    this._resize();
  }

  // ---- data in ----
  setMap(map) {
    this.map = map;
    this.scene.sites = new Map();
    this.scene.scanned = null;
    this.motion.clear();
    this.scene.robots.clear();
    this.fitted = false;
    this.fit();
  }

  /** A new frame of robot poses: start gliding from where each robot is drawn now. */
  setRobots(robots, { snap = false, polled = false } = {}) {
    const now = performance.now();
    if (!polled) {
      // frames set the glide duration: a smoothed measure of the interval between them
      if (this.lastFrameWall) {
        const gap = now - this.lastFrameWall;
        this.frameGap = Math.min(400, Math.max(40, this.frameGap * 0.7 + gap * 0.3));
      }
      this.lastFrameWall = now;
    }
    const seen = new Set();
    for (const r of robots) {
      seen.add(r.name);
      const drawn = this.scene.robots.get(r.name);
      const cur = drawn && !snap ? this._pose(r.name, now) : null;
      const from = cur || { x: r.x, y: r.y, heading: r.heading ?? 0 };
      this.motion.set(r.name, { from, to: { x: r.x, y: r.y, heading: r.heading ?? from.heading }, start: now, dur: this.frameGap * 1.1 });
      this.scene.robots.set(r.name, { ...(drawn || {}), ...r });
    }
    for (const name of [...this.scene.robots.keys()]) if (!seen.has(name)) this.scene.robots.delete(name);
    this.dirty = true;
    this.start();
  }

  setDetail(list) {
    this.dirty = true;
    this.scene.detail = new Map(list.map((r) => [r.name, r]));
  }

  setSites(sites) {
    this.dirty = true;
    for (const s of sites) this.scene.sites.set(s.id, { ...(this.scene.sites.get(s.id) || {}), ...s });
  }

  setDropped(points) {
    this.dirty = true;
    this.scene.dropped = points;
  }

  /** A mineral dropped at (x, y) (`mineral_dropped`), or picked up from there (`mineral_recovered`). */
  addDropped(x, y) {
    this.setDropped([...this.scene.dropped, { x, y }]);
  }

  removeDropped(x, y) {
    this.setDropped(this.scene.dropped.filter((p) => Math.hypot(p.x - x, p.y - y) > 0.05));
  }

  /** A site as the map shows it ({id, x, y, found, remaining, total}), or undefined. */
  site(id) {
    return this.scene.sites.get(id);
  }

  setOpenAuctions(list) {
    this.dirty = true;
    this.scene.openAuctions = list;
  }

  setOption(key, value) {
    this.dirty = true;
    this.scene.options[key] = value;
  }

  setPick(point) {
    this.dirty = true;
    this.scene.pick = point;
  }

  /** The scanned-cell bitmask (base64, row-major, bit i = cell i) as a tiny image. */
  setScanned(b64) {
    if (!this.map || !b64) return;
    let bytes;
    try {
      bytes = Uint8Array.from(atob(b64), (c) => c.charCodeAt(0));
    } catch {
      return;
    }
    this.setScannedBits(bytes);
  }

  /** The same bitmask as bytes. */
  setScannedBits(bytes) {
    if (!this.map) return;
    const { cols, rows } = this.map.grid;
    let off = this.scene.scanned;
    if (!off || off.width !== cols || off.height !== rows) {
      off = document.createElement("canvas");
      off.width = cols;
      off.height = rows;
      this.scene.scanned = off;
    }
    const g = off.getContext("2d");
    const img = g.createImageData(cols, rows);
    for (let i = 0; i < cols * rows; i++) {
      const on = (bytes[i >> 3] >> (i & 7)) & 1; // little-endian bit order within a byte
      if (!on) continue;
      const r = Math.floor(i / cols);
      const c = i % cols;
      const p = ((rows - 1 - r) * cols + c) * 4; // image rows run top-down, map rows bottom-up
      img.data[p] = 86;
      img.data[p + 1] = 180;
      img.data[p + 2] = 233;
      img.data[p + 3] = 46;
    }
    g.putImageData(img, 0, 0);
    this.scene.scannedVersion = (this.scene.scannedVersion || 0) + 1; // the background redraws
    this.dirty = true;
  }

  // ---- view transform ----
  toScreen(x, y) {
    const { scale, ox, oy } = this.view;
    return [ox + x * scale, oy + (this.map ? this.map.height - y : y) * scale];
  }

  toWorld(sx, sy) {
    const { scale, ox, oy } = this.view;
    return [(sx - ox) / scale, (this.map ? this.map.height : 0) - (sy - oy) / scale];
  }

  /** Screen point (CSS pixels, page coordinates) of a world point, for tests and popovers. */
  pagePoint(x, y) {
    const rect = this.canvas.getBoundingClientRect();
    const [sx, sy] = this.toScreen(x, y);
    return [rect.left + sx, rect.top + sy];
  }

  fit() {
    if (!this.map) return;
    const w = this.canvas.clientWidth;
    const hgt = this.canvas.clientHeight;
    if (!w || !hgt) return;
    // a margin for the labels of glyphs at the area's edge (a site's count, a robot's name)
    const pad = Math.min(LABEL_PAD, w / 8, hgt / 8);
    const scale = Math.min((w - 2 * pad) / this.map.width, (hgt - 2 * pad) / this.map.height);
    this.view = {
      scale,
      fit: scale,
      ox: (w - this.map.width * scale) / 2,
      oy: (hgt - this.map.height * scale) / 2,
    };
    this.fitted = true;
    this.moved = false; // until the user zooms or pans, a resize fits again
    this.draw();
  }

  zoomAt(sx, sy, factor) {
    const v = this.view;
    const scale = Math.min(v.fit * 40, Math.max(v.fit * 0.5, v.scale * factor));
    const k = scale / v.scale;
    this.view = { ...v, scale, ox: sx - (sx - v.ox) * k, oy: sy - (sy - v.oy) * k };
    this.moved = true;
    this.draw();
  }

  panBy(dx, dy) {
    this.view = { ...this.view, ox: this.view.ox + dx, oy: this.view.oy + dy };
    this.moved = true;
    this.draw();
  }

  _resize() {
    const w = this.canvas.clientWidth;
    const hgt = this.canvas.clientHeight;
    this.dpr = window.devicePixelRatio || 1;
    this.canvas.width = Math.max(1, Math.round(w * this.dpr));
    this.canvas.height = Math.max(1, Math.round(hgt * this.dpr));
    // the page settles after the map is set (notices, the timeline, the lists fill in): the
    // whole area stays in view until the user moves it
    if (!this.fitted || !this.moved) this.fit();
    this.draw();
  }

  _bindInput() {
    const c = this.canvas;
    c.tabIndex = 0;
    let press = null;
    c.addEventListener("pointerdown", (e) => {
      if (e.button !== 0) return;
      press = { x: e.clientX, y: e.clientY, ox: this.view.ox, oy: this.view.oy, moved: false };
      c.setPointerCapture(e.pointerId);
    });
    c.addEventListener("pointermove", (e) => {
      const rect = c.getBoundingClientRect();
      const [wx, wy] = this.toWorld(e.clientX - rect.left, e.clientY - rect.top);
      this.onCursor(wx, wy);
      this.cursor = { x: wx, y: wy }; // a dense map names the robot under the cursor
      this.dirty = true;
      if (!press) return;
      const dx = e.clientX - press.x;
      const dy = e.clientY - press.y;
      if (!press.moved && Math.hypot(dx, dy) < DRAG_PX) return;
      press.moved = true;
      c.classList.add("panning");
      this.view = { ...this.view, ox: press.ox + dx, oy: press.oy + dy };
      this.moved = true;
      this.draw();
    });
    c.addEventListener("pointerup", (e) => {
      if (!press) return;
      const wasClick = !press.moved;
      press = null;
      c.classList.remove("panning");
      if (!wasClick || !this.map) return;
      const rect = c.getBoundingClientRect();
      const sx = e.clientX - rect.left;
      const sy = e.clientY - rect.top;
      const [wx, wy] = this.toWorld(sx, sy);
      if (wx < 0 || wy < 0 || wx > this.map.width || wy > this.map.height) return;
      this.onPick(wx, wy, sx, sy);
    });
    c.addEventListener("pointerleave", () => {
      this.cursor = null;
      this.onCursor(null, null);
    });
    c.addEventListener(
      "wheel",
      (e) => {
        e.preventDefault();
        const rect = c.getBoundingClientRect();
        this.zoomAt(e.clientX - rect.left, e.clientY - rect.top, Math.exp(-e.deltaY * 0.0015));
      },
      { passive: false },
    );
    c.addEventListener("keydown", (e) => {
      const cx = c.clientWidth / 2;
      const cy = c.clientHeight / 2;
      const step = 40;
      const keys = {
        "+": () => this.zoomAt(cx, cy, 1.25),
        "=": () => this.zoomAt(cx, cy, 1.25),
        "-": () => this.zoomAt(cx, cy, 0.8),
        0: () => this.fit(),
        ArrowLeft: () => this.panBy(step, 0),
        ArrowRight: () => this.panBy(-step, 0),
        ArrowUp: () => this.panBy(0, step),
        ArrowDown: () => this.panBy(0, -step),
        Enter: () => this.map && this.onPick(this.map.width / 2, this.map.height / 2, cx, cy),
      };
      if (keys[e.key]) {
        e.preventDefault();
        keys[e.key]();
      }
    });
  }

  // ---- drawing ----
  _pose(name, now) {
    const m = this.motion.get(name);
    if (!m) return null;
    const a = Math.min(1, Math.max(0, (now - m.start) / m.dur));
    const e = a; // linear: constant speed between frames reads as steady driving
    return {
      x: m.from.x + (m.to.x - m.from.x) * e,
      y: m.from.y + (m.to.y - m.from.y) * e,
      heading: m.from.heading + angleDelta(m.from.heading, m.to.heading) * e,
    };
  }

  /** Poses of every robot as drawn at this instant. */
  poses(now = performance.now()) {
    const out = new Map();
    for (const [name, r] of this.scene.robots) {
      const pose = this._pose(name, now);
      out.set(name, pose ? Object.assign({}, r, pose) : r);
    }
    return out;
  }

  /** The drawn robot nearest map point (x, y) within `px` screen pixels, or null. */
  robotAt(x, y, px = 12, poses = this.poses()) {
    const reach = px / this.view.scale;
    let best = null;
    for (const p of poses.values()) {
      const d = Math.hypot(p.x - x, p.y - y);
      if (d < reach && (!best || d < best.d)) best = { d, p };
    }
    return best && best.p;
  }

  /** Whether frames arrived in the last `ms` milliseconds (they are fresher than a poll). */
  framesFlowing(ms = 500) {
    return performance.now() - this.lastFrameWall < ms;
  }

  /** Whether anything on the map moves by itself now (gliding robots, pulses, dashes). */
  _animating(now) {
    if (this.scene.openAuctions.length) return true;
    for (const m of this.motion.values()) if (now - m.start < m.dur) return true;
    for (const r of this.scene.robots.values()) if (WORKING.has(r.state)) return true;
    return false;
  }

  /** Redraw on every animation frame while something moves, else only when data changes. */
  start() {
    if (this.running) return;
    this.running = true;
    const tick = () => {
      if (!this.running) return;
      if (this.dirty || this._animating(performance.now())) this.draw();
      requestAnimationFrame(tick);
    };
    requestAnimationFrame(tick);
  }

  stop() {
    this.running = false;
  }

  draw() {
    const t0 = performance.now();
    this.dirty = false;
    const { ctx, canvas } = this;
    ctx.setTransform(this.dpr, 0, 0, this.dpr, 0, 0);
    ctx.clearRect(0, 0, canvas.width, canvas.height);
    if (this.map) drawScene(ctx, this, this.poses());
    // for the bench: how often the map is drawn, and the script time it takes
    this.draws = (this.draws || 0) + 1;
    this.drawMs = (this.drawMs || 0) + performance.now() - t0;
  }
}
