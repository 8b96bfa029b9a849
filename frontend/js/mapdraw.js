// Drawing the map scene: area, scanned cells, craters, plant, sites, paths, pairs, robots.

import { Labels, label } from "./maplabels.js";
import { FAILED_COLOUR, KIND_COLOUR, PLANT_COLOUR, SITE_COLOUR, TYPE_COLOUR, robotType, traceShape } from "./palette.js";

const DOWN = new Set(["failed", "disabled"]);
export const WORKING = new Set(["digging", "loading", "unloading"]);

export function shortName(name) {
  const m = /^([a-z])[a-z]*-(\d+)$/.exec(name);
  return m ? `${m[1].toUpperCase()}${m[2]}` : name;
}

export function drawScene(ctx, mv, poses) {
  const { map } = mv;
  const { scene } = mv;
  const s = mv.view.scale;
  const P = (x, y) => mv.toScreen(x, y);
  const now = performance.now();

  // area
  const [x0, y0] = P(0, map.height);
  ctx.fillStyle = "#11161d";
  ctx.fillRect(x0, y0, map.width * s, map.height * s);

  // scanned cells (one image pixel per cell, scaled without smoothing)
  if (scene.scanned) {
    ctx.imageSmoothingEnabled = false;
    ctx.drawImage(scene.scanned, x0, y0, map.width * s, map.height * s);
  }
  // faint grid when zoomed in far enough to read it
  const { cols, rows, cell_w: cw, cell_h: ch } = map.grid;
  if (cw * s > 14) {
    ctx.strokeStyle = "rgba(255,255,255,0.045)";
    ctx.lineWidth = 1;
    ctx.beginPath();
    for (let c = 1; c < cols; c++) {
      const [gx] = P(c * cw, 0);
      ctx.moveTo(gx, y0);
      ctx.lineTo(gx, y0 + map.height * s);
    }
    for (let r = 1; r < rows; r++) {
      const [, gy] = P(0, r * ch);
      ctx.moveTo(x0, gy);
      ctx.lineTo(x0 + map.width * s, gy);
    }
    ctx.stroke();
  }
  ctx.strokeStyle = "#3a4655";
  ctx.lineWidth = 1;
  ctx.strokeRect(x0 + 0.5, y0 + 0.5, map.width * s, map.height * s);
  drawScale(ctx, mv);

  // craters
  for (const o of map.obstacles) {
    const [cx, cy] = P(o.x, o.y);
    ctx.beginPath();
    ctx.arc(cx, cy, o.r * s, 0, 2 * Math.PI);
    ctx.fillStyle = "#06080b";
    ctx.fill();
    ctx.strokeStyle = "#4a5666";
    ctx.lineWidth = 1.5;
    ctx.stroke();
  }

  // plant
  const [px, py] = P(map.plant.x, map.plant.y);
  const pr = Math.max(7, 1.8 * s);
  ctx.beginPath();
  for (let i = 0; i < 6; i++) {
    const a = (Math.PI / 3) * i + Math.PI / 6;
    ctx.lineTo(px + pr * Math.cos(a), py + pr * Math.sin(a));
  }
  ctx.closePath();
  ctx.fillStyle = "#2a3441";
  ctx.fill();
  ctx.strokeStyle = PLANT_COLOUR;
  ctx.lineWidth = 1.5;
  ctx.stroke();
  const labels = new Labels(ctx);
  labels.block(px, py, pr);
  labels.add("plant", [[px, py + pr + 11, "center"], [px, py - pr - 3, "center"]], "#c9d4e0");
  const siteLabels = drawSites(ctx, mv, P, s, labels);

  // dropped minerals
  for (const d of scene.dropped) {
    const [dx, dy] = P(d.x, d.y);
    ctx.beginPath();
    ctx.arc(dx, dy, 3.5, 0, 2 * Math.PI);
    ctx.fillStyle = SITE_COLOUR;
    ctx.fill();
    ctx.strokeStyle = FAILED_COLOUR;
    ctx.lineWidth = 2;
    ctx.stroke();
  }

  // open auctions: a pulsing ring where the task is
  const pulse = (now % 1600) / 1600;
  for (const a of scene.openAuctions) {
    if (!a.location) continue;
    const [ax, ay] = P(a.location[0], a.location[1]);
    ctx.beginPath();
    ctx.arc(ax, ay, 6 + pulse * 10, 0, 2 * Math.PI);
    ctx.strokeStyle = withAlpha(KIND_COLOUR[a.kind] || "#ffffff", 1 - pulse);
    ctx.lineWidth = 2;
    ctx.stroke();
  }

  // the point the operator picked
  if (scene.pick) {
    const [qx, qy] = P(scene.pick.x, scene.pick.y);
    ctx.strokeStyle = "#ffffff";
    ctx.lineWidth = 2;
    ctx.beginPath();
    ctx.moveTo(qx - 8, qy);
    ctx.lineTo(qx + 8, qy);
    ctx.moveTo(qx, qy - 8);
    ctx.lineTo(qx, qy + 8);
    ctx.stroke();
  }

  if (scene.options.paths) drawPaths(ctx, mv, poses, P);
  drawPairs(ctx, mv, poses, P);
  const robotLabels = drawRobots(ctx, mv, poses, P, s, now, labels);
  // robots' names first, then the sites' counts, none over another or over a glyph
  for (const [text, c, colour] of [...robotLabels, ...siteLabels]) labels.add(text, c, colour);
  mv.drawn = { ...labels.draw(), order: robotLabels.order };
}

function drawScale(ctx, mv) {
  // a 10 m bar in the bottom-right corner, above the cursor read-out
  const s = mv.view.scale;
  const len = 10 * s;
  const x = mv.canvas.clientWidth - len - 16;
  const y = mv.canvas.clientHeight - 48;
  ctx.strokeStyle = "#a3b1c2";
  ctx.lineWidth = 2;
  ctx.beginPath();
  ctx.moveTo(x, y - 4);
  ctx.lineTo(x, y);
  ctx.lineTo(x + len, y);
  ctx.lineTo(x + len, y - 4);
  ctx.stroke();
  label(ctx, "10 m", x + len / 2, y + 12, "#a3b1c2");
}

/** Draws the sites; returns their labels ([text, candidates, colour]) for placing. */
function drawSites(ctx, mv, P, s, labels) {
  const { scene, map } = mv;
  const r = Math.max(5, 1.2 * s);
  const out = [];
  if (scene.options.truth) {
    for (const site of map.sites) {
      const known = scene.sites.get(site.id);
      if (known && known.found) continue;
      const [sx, sy] = P(site.x, site.y);
      ctx.setLineDash([3, 3]);
      ctx.beginPath();
      ctx.arc(sx, sy, r, 0, 2 * Math.PI);
      ctx.strokeStyle = withAlpha(SITE_COLOUR, 0.6);
      ctx.lineWidth = 1.5;
      ctx.stroke();
      ctx.setLineDash([]);
      out.push([String(site.minerals), around(sx, sy, r + 2), withAlpha(SITE_COLOUR, 0.7)]);
    }
  }
  for (const site of scene.sites.values()) {
    if (!site.found) continue;
    const [sx, sy] = P(site.x, site.y);
    const empty = site.remaining === 0;
    ctx.beginPath();
    ctx.moveTo(sx, sy - r * 1.25);
    ctx.lineTo(sx + r * 1.25, sy);
    ctx.lineTo(sx, sy + r * 1.25);
    ctx.lineTo(sx - r * 1.25, sy);
    ctx.closePath();
    ctx.fillStyle = empty ? "#2a3441" : withAlpha(SITE_COLOUR, 0.9);
    ctx.fill();
    ctx.strokeStyle = empty ? "#6e7d8f" : "#0d1117";
    ctx.lineWidth = 1;
    ctx.stroke();
    labels.block(sx, sy, r * 1.25);
    const text = site.total ? `${site.remaining}/${site.total}` : String(site.remaining ?? "");
    out.push([text, around(sx, sy, r * 1.25 + 2), empty ? "#8796a8" : SITE_COLOUR]);
  }
  return out;
}

/** Spots for a label beside a glyph of radius r at (x, y): right, left, below, above. */
function around(x, y, r) {
  return [
    [x + r + 2, y + 4, "left"],
    [x - r - 2, y + 4, "right"],
    [x, y + r + 11, "center"],
    [x, y - r - 3, "center"],
  ];
}

function drawPaths(ctx, mv, poses, P) {
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
    ctx.beginPath();
    ctx.moveTo(...P(pose.x, pose.y));
    for (let i = best + 1; i < d.path.length; i++) ctx.lineTo(...P(d.path[i][0], d.path[i][1]));
    ctx.strokeStyle = withAlpha(TYPE_COLOUR[robotType(pose)] || "#fff", 0.55);
    ctx.setLineDash([5, 4]);
    ctx.lineWidth = 1.5;
    ctx.stroke();
    ctx.setLineDash([]);
    const end = d.path[d.path.length - 1];
    const [ex, ey] = P(end[0], end[1]);
    ctx.beginPath();
    ctx.arc(ex, ey, 2.5, 0, 2 * Math.PI);
    ctx.fillStyle = withAlpha(TYPE_COLOUR[robotType(pose)] || "#fff", 0.8);
    ctx.fill();
  }
}

function drawPairs(ctx, mv, poses, P) {
  // Policy 2 coalitions: a double line between each excavator and its hauler
  for (const [name, d] of mv.scene.detail) {
    if (!d.partner || robotType(d) !== "excavator") continue;
    const a = poses.get(name);
    const b = poses.get(d.partner);
    if (!a || !b) continue;
    ctx.beginPath();
    ctx.moveTo(...P(a.x, a.y));
    ctx.lineTo(...P(b.x, b.y));
    ctx.strokeStyle = "rgba(240,228,66,0.55)";
    ctx.setLineDash([1, 3]);
    ctx.lineWidth = 2;
    ctx.stroke();
    ctx.setLineDash([]);
  }
}

/** Draws the robots (one that is down last, on top: a failed robot must never hide under a
 * working one); returns their labels ([text, candidates, colour]) for placing. */
function drawRobots(ctx, mv, poses, P, s, now, labels) {
  const r = Math.min(11, Math.max(6, 0.9 * s));
  const scanR = mv.map.grid.cell_w / Math.SQRT2;
  const isDown = (rb) => DOWN.has(rb.state) || rb.alive === false;
  const list = [...poses.values()].sort((a, b) => Number(isDown(a)) - Number(isDown(b)));
  const names = [];
  for (const rb of list) {
    const type = robotType(rb);
    const colour = TYPE_COLOUR[type] || TYPE_COLOUR.other;
    const [x, y] = P(rb.x, rb.y);
    const down = DOWN.has(rb.state) || rb.alive === false;
    if (rb.state === "scanning") {
      ctx.beginPath();
      ctx.arc(x, y, scanR * s, 0, 2 * Math.PI);
      ctx.fillStyle = "rgba(86,180,233,0.08)";
      ctx.fill();
      ctx.strokeStyle = "rgba(86,180,233,0.35)";
      ctx.lineWidth = 1;
      ctx.stroke();
    }
    if (WORKING.has(rb.state)) {
      ctx.beginPath();
      ctx.arc(x, y, r + 5, 0, 2 * Math.PI);
      ctx.setLineDash([4, 4]);
      ctx.lineDashOffset = -(now / 60) % 8;
      ctx.strokeStyle = "#ffffff";
      ctx.lineWidth = 1.5;
      ctx.stroke();
      ctx.setLineDash([]);
      ctx.lineDashOffset = 0;
    }
    ctx.save();
    ctx.translate(x, y);
    ctx.rotate(-(rb.heading || 0)); // world angles run anticlockwise with y up
    traceShape(ctx, type, r);
    const idle = rb.state === "idle";
    ctx.fillStyle = down ? "#3a3f46" : idle ? "#11161d" : colour;
    ctx.fill();
    ctx.lineWidth = idle ? 2 : 1.2;
    ctx.strokeStyle = down ? "#8796a8" : idle ? colour : "#0d1117";
    if (rb.state === "disabled") ctx.setLineDash([3, 2]);
    ctx.stroke();
    ctx.setLineDash([]);
    ctx.restore();
    if ((rb.load || 0) > 0) {
      ctx.beginPath();
      ctx.arc(x, y, Math.max(2.5, r * 0.32), 0, 2 * Math.PI);
      ctx.fillStyle = SITE_COLOUR;
      ctx.fill();
      ctx.strokeStyle = "#0d1117";
      ctx.lineWidth = 1;
      ctx.stroke();
    }
    if (rb.state === "failed" || rb.alive === false) {
      ctx.strokeStyle = FAILED_COLOUR;
      ctx.lineWidth = 3;
      ctx.beginPath();
      ctx.moveTo(x - r, y - r);
      ctx.lineTo(x + r, y + r);
      ctx.moveTo(x + r, y - r);
      ctx.lineTo(x - r, y + r);
      ctx.stroke();
    }
    labels.block(x, y, r);
    const spots = [[x, y - r - 4, "center"], ...around(x, y, r)];
    // a robot that is down is named first, so a crowd never hides it
    if (mv.scene.options.labels) names[down ? "unshift" : "push"]([shortName(rb.name), spots, down ? "#ffb38a" : "#e6edf3"]);
  }
  names.order = list.map((rb) => rb.name); // the drawing order, bottom to top
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
