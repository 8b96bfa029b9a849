// Small pieces of the live view around the map: the hover text, a site event drawn on the
// map, and the legend items that apply only to some missions.

import { $, fmt } from "./dom.js";

/** The cursor's map position, and the robot under it (name, state, task, load). */
export function showHover(map, detail, x, y) {
  const out = $("#cursor-pos");
  if (x === null) {
    out.textContent = "";
    return;
  }
  let text = `x ${fmt(x)}  y ${fmt(y)}`;
  const pose = map.robotAt(x, y);
  if (pose) {
    const r = { ...detail.get(pose.name), ...pose };
    text += ` · ${r.name} ${r.state}${r.task ? ` · ${r.task}` : ""}${r.load ? ` · load ${r.load}` : ""}`;
  }
  out.textContent = text;
}

/** site_found {site, by, x, y} and dug {robot, site, remaining}: the site as the map shows it
 * (known from the snapshot, which lists every site, or else from the ground-truth `world`). */
export function siteEvent(map, world, kind, d) {
  const truth = world?.sites.find((s) => s.id === d.site);
  const known = map.site(d.site) ?? (truth && { id: truth.id, x: truth.x, y: truth.y, total: truth.minerals, remaining: truth.minerals });
  if (!known) return;
  map.setSites([{ ...known, found: true, ...(kind === "dug" ? { remaining: d.remaining } : { x: d.x, y: d.y }) }]);
}

/** Show a legend item only while the map can draw it: `pair` (a Policy 2 pair is on the
 * map), `charge` (battery bars: energy on). */
export function showLegendItem(kind, on) {
  const el = document.querySelector(`#legend [data-legend="${kind}"]`);
  if (el && el.hidden === on) el.hidden = !on;
}
