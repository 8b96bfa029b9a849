// The auction feed: one card per auction, newest first, updated as bids, awards and the close arrive.

import { h, fmt } from "./dom.js";
import { KIND_LABEL } from "./palette.js";
import { shortName } from "./mapdraw.js";

const MAX_CARDS = 80;

export class AuctionFeed {
  constructor(list, countEl) {
    this.list = list;
    this.countEl = countEl;
    this.records = new Map(); // id -> AuctionRecord
    this.cards = new Map(); // id -> <li>
    this.now = 0;
  }

  reset() {
    this.records.clear();
    this.cards.clear();
    this.list.replaceChildren();
    this._count();
  }

  /** Insert or update one auction record (AuctionRead: REST, the stream and snapshots alike). */
  upsert(rec, { flash = true } = {}) {
    const old = this.records.get(rec.id);
    this.records.set(rec.id, rec);
    const card = this._card(rec);
    const prev = this.cards.get(rec.id);
    if (prev) prev.replaceWith(card);
    else this.list.prepend(card);
    this.cards.set(rec.id, card);
    if (flash && (!old || old.status !== rec.status || old.bids.length !== rec.bids.length)) {
      card.classList.add("flash");
    }
    while (this.list.children.length > MAX_CARDS) {
      const last = this.list.lastElementChild;
      this.cards.delete(last.dataset.auctionId);
      last.remove();
    }
    this._count();
  }

  /** Bulk load (history on connect), oldest first so the newest ends on top. */
  load(records) {
    const sorted = [...records].sort((a, b) => a.opened_at - b.opened_at || String(a.id).localeCompare(String(b.id)));
    for (const r of sorted) this.upsert(r, { flash: false });
  }

  open() {
    return [...this.records.values()].filter((r) => r.status === "open");
  }

  /** Refresh the running open time of open auctions. */
  tick(now) {
    this.now = now;
    for (const r of this.records.values()) {
      if (r.status !== "open") continue;
      const el = this.cards.get(r.id)?.querySelector(".open-time");
      if (el) el.textContent = `open ${fmt(Math.max(0, now - r.opened_at), 1)} s`;
    }
  }

  /** Open times of closed auctions, by kind. */
  openTimes() {
    const out = {};
    for (const r of this.records.values()) {
      if (r.status !== "closed" || r.closed_at === null || r.closed_at === undefined) continue;
      (out[r.kind] ||= []).push(r.closed_at - r.opened_at);
    }
    return out;
  }

  _count() {
    const open = this.open().length;
    this.countEl.textContent = `${this.records.size} · ${open} open`;
  }

  _card(r) {
    const loc = `(${fmt(r.location[0])}, ${fmt(r.location[1])})`;
    const openFor = r.status === "open" ? `open ${fmt(Math.max(0, this.now - r.opened_at), 1)} s` : r.closed_at !== null && r.closed_at !== undefined ? `${fmt(r.closed_at - r.opened_at, 1)} s` : r.status;
    const awards = r.awards;
    const lastAccepted = awards.find((a) => a.outcome === "accepted");
    const winner = r.allocated_to || lastAccepted?.winner;
    // a re-announced auction collects a new round of bids each time: show the latest round
    const round = Math.max(0, ...r.bids.map((b) => b.round));
    const bids = r.bids.filter((b) => b.round === round).map((b) =>
      h(
        "span",
        { class: `bid${b.utility === null ? " inf" : ""}${b.bidder === winner ? " win" : ""}`, dataset: { bidder: b.bidder } },
        `${shortName(b.bidder)} ${b.utility === null ? "−∞" : fmt(b.utility, 1)}`,
      ),
    );
    return h(
      "li",
      {
        dataset: {
          auctionId: r.id,
          kind: r.kind,
          status: r.status,
          auctioneer: r.auctioneer,
          taskType: r.task_type,
          taskId: r.task_id ?? "",
          reauctionOf: r.reauction_of ?? "",
          location: r.location.join(","),
          openedAt: r.opened_at,
          winner: winner || "",
        },
      },
      h(
        "div",
        { class: "head" },
        h("span", { class: "id" }, r.id),
        h("span", { class: "kind" }, `${KIND_LABEL[r.kind] || r.kind} · ${r.task_type} ${loc}`),
        r.reauction_of ? h("span", { class: "re", title: `re-auction of ${r.reauction_of}` }, "↻") : null,
        h("span", { class: "open-time", title: "announcement to close" }, openFor),
      ),
      h("div", { class: "bids" }, round ? h("span", { class: "round" }, `round ${round + 1}:`) : null, bids.length ? bids : "waiting for bids…"),
      awards.length || r.status !== "open"
        ? h(
            "div",
            { class: "award" },
            awards.map((a) => [h("span", { class: a.outcome }, `${shortName(a.winner)} ${a.outcome}`), " "]),
            r.reannouncements ? `· re-announced ${r.reannouncements}× ` : "",
            r.status === "closed" ? `· closed → ${winner || "–"}` : r.status === "cancelled" ? "· cancelled" : "",
          )
        : null,
    );
  }
}
