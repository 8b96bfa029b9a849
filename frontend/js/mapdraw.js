// Drawing the map scene: area, scanned cells, craters, plant, sites, dropped minerals, open
// auctions; the robots, their paths and pairs are maprobots.js's.

import { Labels, label } from "./maplabels.js";
import { FAILED_COLOUR, KIND_COLOUR, PLANT_COLOUR, SITE_COLOUR } from "./palette.js";
import { around, drawPairs, drawPaths, drawRobots, withAlpha } from "./maprobots.js";

const SCANNED_MS = 250;

/** The layer that moves only with the view or the scanned cells (area, scanned cells, grid,
 * craters, plant), kept in an offscreen canvas and redrawn only when one of those changes. */
function background(mv) {
  const { canvas, map, scene, view, dpr } = mv;
  const place = `${canvas.width}x${canvas.height}@${dpr}:${view.scale},${view.ox},${view.oy}`;
  const key = `${place}:${scene.scannedVersion || 0}`;
  let bg = mv.bg;
  if (bg && bg.key === key) return bg.canvas;
  // newly scanned cells alone redraw it at most 4 times a second (a moved view at once)
  const now = performance.now();
  if (bg && bg.key.startsWith(`${place}:`) && now - bg.at < SCANNED_MS) return bg.canvas;
  if (!bg || bg.canvas.width !== canvas.width || bg.canvas.height !== canvas.height) {
    const c = document.createElement("canvas");
    c.width = canvas.width;
    c.height = canvas.height;
    bg = mv.bg = { canvas: c, key: "" };
  }
  bg.key = key;
  bg.at = now;
  const ctx = bg.canvas.getContext("2d");
  ctx.setTransform(dpr, 0, 0, dpr, 0, 0);
  ctx.clearRect(0, 0, canvas.width, canvas.height);
  const s = view.scale;
  const P = (x, y) => mv.toScreen(x, y);
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
  // craters: one path
  ctx.beginPath();
  for (const o of map.obstacles) {
    const [cx, cy] = P(o.x, o.y);
    ctx.moveTo(cx + o.r * s, cy);
    ctx.arc(cx, cy, o.r * s, 0, 2 * Math.PI);
  }
  ctx.fillStyle = "#06080b";
  ctx.fill();
  ctx.strokeStyle = "#4a5666";
  ctx.lineWidth = 1.5;
  ctx.stroke();
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
  drawScale(ctx, mv);
  return bg.canvas;
}

export function drawScene(ctx, mv, poses) {
  const { map } = mv;
  const { scene } = mv;
  const s = mv.view.scale;
  const P = (x, y) => mv.toScreen(x, y);
  const now = performance.now();

  ctx.save();
  ctx.setTransform(1, 0, 0, 1, 0, 0);
  ctx.drawImage(background(mv), 0, 0);
  ctx.restore();

  const [px, py] = P(map.plant.x, map.plant.y);
  const pr = Math.max(7, 1.8 * s);
  const labels = new Labels(ctx);
  labels.block(px, py, pr);
  labels.add("plant", [[px, py + pr + 11, "center"], [px, py - pr - 3, "center"]], "#c9d4e0");
  const siteLabels = drawSites(ctx, mv, P, s, labels);

  // dropped minerals: one path
  if (scene.dropped.length) {
    ctx.beginPath();
    for (const d of scene.dropped) {
      const [dx, dy] = P(d.x, d.y);
      ctx.moveTo(dx + 3.5, dy);
      ctx.arc(dx, dy, 3.5, 0, 2 * Math.PI);
    }
    ctx.fillStyle = SITE_COLOUR;
    ctx.fill();
    ctx.strokeStyle = FAILED_COLOUR;
    ctx.lineWidth = 2;
    ctx.stroke();
  }

  // open auctions: a pulsing ring where the task is (one path per kind)
  const pulse = (now % 1600) / 1600;
  const rings = new Map();
  for (const a of scene.openAuctions) {
    if (!a.location) continue;
    const [ax, ay] = P(a.location[0], a.location[1]);
    const ring = rings.get(a.kind) || rings.set(a.kind, new Path2D()).get(a.kind);
    ring.moveTo(ax + 6 + pulse * 10, ay);
    ring.arc(ax, ay, 6 + pulse * 10, 0, 2 * Math.PI);
  }
  ctx.lineWidth = 2;
  for (const [kind, ring] of rings) {
    ctx.strokeStyle = withAlpha(KIND_COLOUR[kind] || "#ffffff", 1 - pulse);
    ctx.stroke(ring);
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
  mv.drawn = { ...labels.draw(), order: robotLabels.order, batches: robotLabels.batches, onScreen: robotLabels.onScreen, batteries: robotLabels.batteries };
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

/** Draws the sites (one path per look); returns their labels ([text, candidates, colour]). */
function drawSites(ctx, mv, P, s, labels) {
  const { scene, map } = mv;
  const r = Math.max(5, 1.2 * s);
  const out = [];
  if (scene.options.truth) {
    const hidden = new Path2D();
    for (const site of map.sites) {
      const known = scene.sites.get(site.id);
      if (known && known.found) continue;
      const [sx, sy] = P(site.x, site.y);
      hidden.moveTo(sx + r, sy);
      hidden.arc(sx, sy, r, 0, 2 * Math.PI);
      out.push([String(site.minerals), around(sx, sy, r + 2), withAlpha(SITE_COLOUR, 0.7)]);
    }
    ctx.setLineDash([3, 3]);
    ctx.strokeStyle = withAlpha(SITE_COLOUR, 0.6);
    ctx.lineWidth = 1.5;
    ctx.stroke(hidden);
    ctx.setLineDash([]);
  }
  const full = new Path2D();
  const empty = new Path2D();
  const k = r * 1.25;
  for (const site of scene.sites.values()) {
    if (!site.found) continue;
    const [sx, sy] = P(site.x, site.y);
    const none = site.remaining === 0;
    const path = none ? empty : full;
    path.moveTo(sx, sy - k);
    path.lineTo(sx + k, sy);
    path.lineTo(sx, sy + k);
    path.lineTo(sx - k, sy);
    path.closePath();
    labels.block(sx, sy, k);
    const text = site.total ? `${site.remaining}/${site.total}` : String(site.remaining ?? "");
    out.push([text, around(sx, sy, k + 2), none ? "#8796a8" : SITE_COLOUR]);
  }
  ctx.lineWidth = 1;
  ctx.fillStyle = withAlpha(SITE_COLOUR, 0.9);
  ctx.fill(full);
  ctx.strokeStyle = "#0d1117";
  ctx.stroke(full);
  ctx.fillStyle = "#2a3441";
  ctx.fill(empty);
  ctx.strokeStyle = "#6e7d8f";
  ctx.stroke(empty);
  return out;
}


