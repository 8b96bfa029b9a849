// A mission's stored ending, read once its record holds it. The stream may skip frames (at
// Max it sends what the link can take), so when a mission has ended or was interrupted the
// view redraws everything from what the server stored, never from the last frame it saw.

import { h } from "./dom.js";
import { get, qs } from "./api.js";

/** The counters the view shows, as the stored metrics name them. */
export const COUNTER_KEYS = ["sites_found", "sites_total", "minerals_delivered", "minerals_total", "auctions", "bids", "declines"];

/** {mission, metrics, robots, deliveries, openTimes}: the record, its metrics, the final robot
 * list, every `delivered` event (the minerals curve) and every closed auction's open time by
 * kind, all as stored. */
export async function loadFinal(id) {
  const path = `/missions/${encodeURIComponent(id)}`;
  const [mission, robots, deliveries, openTimes] = await Promise.all([get(path), get(`${path}/robots`), allEvents(path, "delivered"), allOpenTimes(path)]);
  return { mission, metrics: mission.metrics, robots, deliveries, openTimes };
}

/** {kind: [seconds]} over every closed auction, page after page. */
async function allOpenTimes(path) {
  const out = {};
  for (let offset = 0; ; ) {
    const page = await get(`${path}/auctions${qs({ status: "closed", limit: 500, offset })}`);
    for (const a of page.items) if (a.closed_at !== null) (out[a.kind] ||= []).push(a.closed_at - a.opened_at);
    offset += page.items.length;
    if (!page.items.length || offset >= page.total) return out;
  }
}

/** Every stored event of one kind, page after page. */
async function allEvents(path, kind) {
  const out = [];
  let after = -1;
  for (;;) {
    const page = await get(`${path}/events${qs({ kind, after, limit: 1000 })}`);
    out.push(...page.items);
    if (page.next_after === null || page.next_after === undefined) return out;
    after = page.next_after;
  }
}

/** The distance by robot type: the stored metrics' figure, else the robot list's sum. */
export function distanceByType(metrics, robots, typeOf) {
  if (metrics && metrics.distance) return { ...metrics.distance };
  const sum = {};
  for (const r of robots) sum[typeOf(r)] = (sum[typeOf(r)] || 0) + (Number(r.distance) || 0);
  return sum;
}

/** Is `text` a mission id the API could know (1 … 2^31−1)? */
export function validId(text) {
  return /^[1-9][0-9]{0,9}$/.test(String(text)) && Number(text) <= 2 ** 31 - 1;
}

/** The progress box on the map: a frame's (or the stored) counters and scanned share.
 * `feed` ({total, open}: the auction feed's count, `AuctionFeed.counts()`) makes the auctions
 * read as the feed's header does, so the two never disagree. */
export function showCounters(box, f, grid, feed = null) {
  const c = f.counters || {}; // {} until the first frame of a mission stored without a state
  const auctions = feed ? feed.total : c.auctions;
  const cells = grid ? grid.cols * grid.rows : null;
  const items = [
    ["sites", `${c.sites_found ?? "–"}/${c.sites_total ?? "–"}`],
    ["minerals", `${c.minerals_delivered ?? "–"}/${c.minerals_total ?? "–"}`],
    ["scanned", cells && f.scanned_count !== undefined ? `${Math.round((100 * f.scanned_count) / cells)}%` : "–"],
    ["auctions", auctions ?? "–"],
    ["open", feed ? feed.open : "–"],
    ["bids", c.bids ?? "–"],
    ["declines", c.declines ?? "–"],
  ];
  const text = items.map(([k, v]) => `${k}=${v}`).join(";");
  if (box.dataset.text !== text) {
    box.dataset.text = text;
    box.replaceChildren(...items.flatMap(([k, v]) => [h("span", {}, k), h("b", { dataset: { counter: k } }, v)]));
  }
}
