// The robots' layer of the map: their remaining paths, Policy 2's pairs and the robots
// themselves, drawn in batches (one canvas path per robot type and look), and their labels.

import { FAILED_COLOUR, SITE_COLOUR, TYPE_COLOUR, addShape, robotType } from "./palette.js";

const DOWN = new Set(["failed", "disabled"]);
export const WORKING = new Set(["digging", "loading", "unloading"]);
/** Past this many robots on screen the map is "dense": glyphs are filled without an outline,
 * paths are solid, not dashed (dashes and outlines are most of a software canvas's work). */
export const DENSE = 300;
/** Battery bars (energy on): a charge below `LOW` is amber, below `CRITICAL` red. On a dense
 * map only the red ones are drawn: those are the robots an operator must act on. */
export const LOW = 0.5;
export const CRITICAL = 0.2;
export const BATTERY_COLOUR = { ok: "#3fb950", low: "#e3b341", critical: "#f85149" };

function batteryLevel(charge) {
  return charge < CRITICAL ? "critical" : charge < LOW ? "low" : "ok";
}

const SHORT = new Map(); // name -> short name (asked for every robot on every frame)
export function shortName(name) {
  let short = SHORT.get(name);
  if (short === undefined) {
    const m = /^([a-z])[a-z]*-(\d+)$/.exec(name);
    short = m ? `${m[1].toUpperCase()}${m[2]}` : name;
    if (SHORT.size < 50000) SHORT.set(name, short);
  }
  return short;
}

/** Spots for a label beside a glyph of radius r at (x, y): right, left, below, above. */
export function around(x, y, r) {
  return [
    [x + r + 2, y + 4, "left"],
    [x - r - 2, y + 4, "right"],
    [x, y + r + 11, "center"],
    [x, y - r - 3, "center"],
  ];
}

export function drawPaths(ctx, mv, poses, P) {
  // one dashed path per robot type, one path of end dots per type
  const lines = new Map();
  const ends = new Map();
  const get = (m, k) => m.get(k) || m.set(k, new Path2D()).get(k);
  for (const [name, d] of mv.scene.detail) {
    const pose = poses.get(name);
    if (!pose || !Array.isArray(d.path) || d.path.length < 2 || DOWN.has(pose.state)) continue;
    // start from the segment the robot is on now; the detail list is refreshed about once a second
    let best = 0;
    let bestD = Infinity;
    for (let i = 0; i < d.path.length - 1; i++) {
      const dd = segDist(pose.x, pose.y, d.path[i], d.path[i + 1]);
      if (dd < bestD) {
        bestD = dd;
        best = i;
      }
    }
    const type = robotType(pose);
    const line = get(lines, type);
    line.moveTo(...P(pose.x, pose.y));
    for (let i = best + 1; i < d.path.length; i++) line.lineTo(...P(d.path[i][0], d.path[i][1]));
    const end = d.path[d.path.length - 1];
    const [ex, ey] = P(end[0], end[1]);
    const dot = get(ends, type);
    dot.moveTo(ex + 2.5, ey);
    dot.arc(ex, ey, 2.5, 0, 2 * Math.PI);
  }
  const dense = poses.size > DENSE;
  ctx.setLineDash(dense ? [] : [5, 4]);
  ctx.lineWidth = dense ? 1 : 1.5;
  for (const [type, line] of lines) {
    ctx.strokeStyle = withAlpha(TYPE_COLOUR[type] || "#ffffff", 0.55);
    ctx.stroke(line);
  }
  ctx.setLineDash([]);
  for (const [type, dot] of ends) {
    ctx.fillStyle = withAlpha(TYPE_COLOUR[type] || "#ffffff", 0.8);
    ctx.fill(dot);
  }
}

export function drawPairs(ctx, mv, poses, P) {
  // Policy 2 coalitions: a dotted line between each excavator and its hauler (one path)
  const pairs = new Path2D();
  let any = false;
  for (const [name, d] of mv.scene.detail) {
    if (!d.partner || robotType(d) !== "excavator") continue;
    const a = poses.get(name);
    const b = poses.get(d.partner);
    if (!a || !b) continue;
    pairs.moveTo(...P(a.x, a.y));
    pairs.lineTo(...P(b.x, b.y));
    any = true;
  }
  if (!any) return;
  ctx.strokeStyle = "rgba(240,228,66,0.55)";
  ctx.setLineDash([1, 3]);
  ctx.lineWidth = 2;
  ctx.stroke(pairs);
  ctx.setLineDash([]);
}

/** How a robot's glyph is painted: by type and by how it is (working, idle, down, disabled). */
function look(rb) {
  if (rb.state === "disabled") return "disabled";
  if (rb.state === "failed" || rb.alive === false) return "down";
  return rb.state === "idle" ? "idle" : "busy";
}

function paintGlyphs(ctx, type, how, path, dense) {
  const colour = TYPE_COLOUR[type] || TYPE_COLOUR.other;
  const down = how === "down" || how === "disabled";
  ctx.fillStyle = down ? "#3a3f46" : how === "idle" ? "#11161d" : colour;
  ctx.fill(path);
  if (dense && how === "busy") return; // a filled glyph reads without its outline
  ctx.lineWidth = how === "idle" ? 2 : 1.2;
  ctx.strokeStyle = down ? "#8796a8" : how === "idle" ? colour : "#0d1117";
  if (how === "disabled") ctx.setLineDash([3, 2]);
  ctx.stroke(path);
  ctx.setLineDash([]);
}

/** Draws the robots in batches: one path per type and look, one for the scan discs, the
 * working rings, the loads and the failure crosses, so a thousand robots cost a few dozen
 * canvas calls. A robot that is down is drawn last, on top: it must never hide under a
 * working one. Returns their labels ([text, candidates, colour]) for placing. */
export function drawRobots(ctx, mv, poses, P, s, now, labels) {
  const r = Math.min(11, Math.max(6, 0.9 * s));
  const scanR = (mv.map.grid.cell_w / Math.SQRT2) * s;
  const isDown = (rb) => DOWN.has(rb.state) || rb.alive === false;
  // robots that are down last (drawn on top); two passes rather than a sort
  const list = [];
  for (const rb of poses.values()) if (!isDown(rb)) list.push(rb);
  for (const rb of poses.values()) if (isDown(rb)) list.push(rb);
  const { scale: vs, ox, oy } = mv.view;
  const top = mv.map.height;
  const w = mv.canvas.clientWidth;
  const hgt = mv.canvas.clientHeight;
  const margin = Math.max(r * 2, scanR) + 2;
  const glyphs = new Map(); // "type look" -> Path2D, in first-seen order (down ones last)
  const scans = new Path2D();
  const rings = new Path2D();
  const loads = new Path2D();
  const crosses = new Path2D();
  const cells = new Path2D(); // battery bars' empty cases
  const charges = { ok: new Path2D(), low: new Path2D(), critical: new Path2D() };
  const count = { scans: 0, rings: 0, loads: 0, crosses: 0 };
  const batteries = { ok: 0, low: 0, critical: 0 };
  const names = [];
  const drawnNames = [];
  const lr = Math.max(2.5, r * 0.32);
  const dense = list.length > DENSE;
  const cursor = mv.cursor;
  const hovered = dense && cursor ? mv.robotAt(cursor.x, cursor.y, 12, poses)?.name : null;
  for (const rb of list) {
    const x = ox + rb.x * vs; // mv.toScreen, inlined: this loop runs for every robot
    const y = oy + (top - rb.y) * vs;
    if (x < -margin || y < -margin || x > w + margin || y > hgt + margin) continue; // off screen
    drawnNames.push(rb.name);
    const type = robotType(rb);
    const down = isDown(rb);
    if (rb.state === "scanning") {
      scans.moveTo(x + scanR, y);
      scans.arc(x, y, scanR, 0, 2 * Math.PI);
      count.scans++;
    }
    if (WORKING.has(rb.state)) {
      rings.moveTo(x + r + 5, y);
      rings.arc(x, y, r + 5, 0, 2 * Math.PI);
      count.rings++;
    }
    const key = `${type} ${look(rb)}`;
    const path = glyphs.get(key) || glyphs.set(key, new Path2D()).get(key);
    addShape(path, type, r, x, y, rb.heading || 0);
    if ((rb.load || 0) > 0) {
      loads.moveTo(x + lr, y);
      loads.arc(x, y, lr, 0, 2 * Math.PI);
      count.loads++;
    }
    if (rb.charge != null && !down) {
      const level = batteryLevel(rb.charge);
      if (!dense || level === "critical") {
        const bw = 2 * r;
        cells.rect(x - r, y + r + 3, bw, 3);
        charges[level].rect(x - r, y + r + 3, Math.max(1, bw * Math.min(1, rb.charge)), 3);
        batteries[level]++;
      }
    }
    if (rb.state === "failed" || rb.alive === false) {
      crosses.moveTo(x - r, y - r);
      crosses.lineTo(x + r, y + r);
      crosses.moveTo(x + r, y - r);
      crosses.lineTo(x - r, y + r);
      count.crosses++;
    }
    labels.block(x, y, r);
    // a robot that is down is named first, so a crowd never hides it; on a dense map only
    // those and the robot under the cursor are named (the others would collide anyway)
    if (!mv.scene.options.labels || (dense && !down && rb.name !== hovered)) continue;
    const spots = [[x, y - r - 4, "center"], ...around(x, y, r)];
    names[down ? "unshift" : "push"]([shortName(rb.name), spots, down ? "#ffb38a" : "#e6edf3"]);
  }
  if (count.scans) {
    ctx.fillStyle = "rgba(86,180,233,0.08)";
    ctx.fill(scans);
    ctx.strokeStyle = "rgba(86,180,233,0.35)";
    ctx.lineWidth = 1;
    if (drawnNames.length <= DENSE) ctx.stroke(scans);
  }
  if (count.rings) {
    ctx.setLineDash(drawnNames.length > DENSE ? [] : [4, 4]);
    ctx.lineDashOffset = -(now / 60) % 8;
    ctx.strokeStyle = "#ffffff";
    ctx.lineWidth = 1.5;
    ctx.stroke(rings);
    ctx.setLineDash([]);
    ctx.lineDashOffset = 0;
  }
  for (const [key, path] of glyphs) {
    const [type, how] = key.split(" ");
    paintGlyphs(ctx, type, how, path, drawnNames.length > DENSE);
  }
  if (count.loads) {
    ctx.fillStyle = SITE_COLOUR;
    ctx.fill(loads);
    ctx.strokeStyle = "#0d1117";
    ctx.lineWidth = 1;
    ctx.stroke(loads);
  }
  if (batteries.ok + batteries.low + batteries.critical) {
    ctx.fillStyle = "#0d1117";
    ctx.fill(cells);
    for (const level of ["ok", "low", "critical"]) {
      if (!batteries[level]) continue;
      ctx.fillStyle = BATTERY_COLOUR[level];
      ctx.fill(charges[level]);
    }
  }
  if (count.crosses) {
    ctx.strokeStyle = FAILED_COLOUR;
    ctx.lineWidth = 3;
    ctx.stroke(crosses);
  }
  names.order = list.map((rb) => rb.name); // the drawing order, bottom to top
  names.batches = glyphs.size; // canvas paths used for the glyphs (for tests and the bench)
  names.onScreen = drawnNames.length;
  names.batteries = batteries; // battery bars drawn, per level (for tests)
  return names;
}

function segDist(x, y, a, b) {
  const dx = b[0] - a[0];
  const dy = b[1] - a[1];
  const l2 = dx * dx + dy * dy;
  const t = l2 ? Math.max(0, Math.min(1, ((x - a[0]) * dx + (y - a[1]) * dy) / l2)) : 0;
  return Math.hypot(x - (a[0] + t * dx), y - (a[1] + t * dy));
}

export function withAlpha(hex, a) {
  const n = Number.parseInt(hex.slice(1), 16);
  return `rgba(${(n >> 16) & 255},${(n >> 8) & 255},${n & 255},${a.toFixed(3)})`;
}
