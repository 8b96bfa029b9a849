// The live view's back-fill when a stream opens: what happened before the page joined.

import { get, qs } from "./api.js";

/** The newest 200 auctions into the feed and the stored deliveries into the chart, unless
 * the view moved on meanwhile (`current()` false). */
export async function loadHistory(id, { feed, charts, current }) {
  try {
    // the API lists auctions oldest first: read the total, then the newest page
    const path = `/missions/${encodeURIComponent(id)}/auctions`;
    const head = await get(`${path}${qs({ limit: 1 })}`);
    const offset = Math.max(0, head.total - 200);
    const data = offset ? await get(`${path}${qs({ limit: 200, offset })}`) : await get(`${path}${qs({ limit: 200 })}`);
    if (!current()) return;
    feed.load(data.items);
  } catch {
    /* the stream carries new auctions anyway */
  }
  try {
    const data = await get(`/missions/${encodeURIComponent(id)}/events${qs({ kind: "delivered", limit: 1000 })}`);
    if (!current()) return;
    charts.loadDeliveries(data.items);
  } catch {
    /* the chart fills from frames */
  }
}
