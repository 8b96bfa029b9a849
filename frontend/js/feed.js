// The auction feed: one card per auction, newest first, updated as bids, awards and the close
// arrive. Up to VIRTUAL_FROM auctions the newest MAX_CARDS cards are kept in the list; past
// that the list is virtualized (virtual.js): every auction can be scrolled to, and only the
// cards in view are in the DOM, each one line per part.

import { h, fmt } from "./dom.js";
import { KIND_LABEL } from "./palette.js";
import { shortName } from "./maprobots.js";
import { VirtualRows } from "./virtual.js";

const MAX_CARDS = 80;
export const VIRTUAL_FROM = 200;
const CARD_PX = 69; // a card's height in the virtualized list, its 5 px gap included
const MAX_BIDS = 12; // bids shown on a card (a scaled-up mission has hundreds of bidders)

export class AuctionFeed {
  constructor(list, countEl) {
    this.list = list;
    this.countEl = countEl;
    this.records = new Map(); // id -> AuctionRecord
    this.cards = new Map(); // id -> <li>
    this.order = []; // ids, first seen first (shown newest first)
    this.openIds = new Set();
    this.flashing = new Set();
    this.virtual = null;
    this.now = 0;
  }

  reset() {
    this.known = 0;
    this.records.clear();
    this.cards.clear();
    this.order = [];
    this.openIds.clear();
    this.virtual = null;
    this.list.classList.remove("virtual");
    this.list.replaceChildren();
    this._count();
  }

  /** Insert or update one auction record (AuctionRead: REST, the stream and snapshots alike). */
  upsert(rec, { flash = true } = {}) {
    const old = this.records.get(rec.id);
    this.records.set(rec.id, rec);
    if (!old) this.order.push(rec.id);
    if (rec.status === "open") this.openIds.add(rec.id);
    else this.openIds.delete(rec.id);
    const changed = !old || old.status !== rec.status || old.bids.length !== rec.bids.length;
    if (this.virtual || this.records.size > VIRTUAL_FROM) {
      if (flash && changed) this.flashing.add(rec.id);
      this.cards.delete(rec.id);
      this._virtual();
      this._count();
      return;
    }
    const card = this._card(rec);
    const prev = this.cards.get(rec.id);
    if (prev) prev.replaceWith(card);
    else this.list.prepend(card);
    this.cards.set(rec.id, card);
    if (flash && changed) card.classList.add("flash");
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

  /** Many auctions: a virtual list, newest first; cards are built when they come into view. */
  _virtual() {
    if (!this.virtual) {
      this.list.classList.add("virtual");
      this.cards.clear();
      this.virtual = new VirtualRows({
        scroller: this.list,
        body: this.list,
        spacer: (px) => h("li", { class: "spacer", "aria-hidden": "true", style: `height:${px}px` }),
        rowHeight: CARD_PX,
        render: (i) => {
          const id = this.order[this.order.length - 1 - i];
          let card = this.cards.get(id);
          if (!card) {
            card = this._card(this.records.get(id));
            if (this.flashing.delete(id)) card.classList.add("flash");
            this.cards.set(id, card);
          }
          return card;
        },
      });
    }
    if (this.cards.size > 400) this.cards.clear(); // built again when scrolled to
    this.virtual.count = this.order.length;
    this.virtual.schedule();
  }

  open() {
    return [...this.openIds].map((id) => this.records.get(id));
  }

  /** Refresh the running open time of open auctions (those with a card). */
  tick(now) {
    this.now = now;
    for (const id of this.openIds) {
      const el = this.cards.get(id)?.querySelector(".open-time");
      if (el) el.textContent = `open ${fmt(Math.max(0, now - this.records.get(id).opened_at), 1)} s`;
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

  /** How many auctions the mission has, as its counters say: the feed may hold fewer (the
   * page joined late and read the newest 200) or more (auctions newer than the last frame). */
  setKnown(n) {
    if (n === this.known) return;
    this.known = n;
    this._count();
  }

  /** {total, open}: what the header says, and the counters box too (one count, not two). */
  counts() {
    return { total: Math.max(this.records.size, this.known || 0), open: this.openIds.size };
  }

  _count() {
    const { total, open } = this.counts();
    this.countEl.textContent = `${total} · ${open} open`;
  }

  _card(r) {
    const loc = `(${fmt(r.location[0])}, ${fmt(r.location[1])})`;
    const openFor = r.status === "open" ? `open ${fmt(Math.max(0, this.now - r.opened_at), 1)} s` : r.closed_at !== null && r.closed_at !== undefined ? `${fmt(r.closed_at - r.opened_at, 1)} s` : r.status;
    const awards = r.awards;
    const lastAccepted = awards.find((a) => a.outcome === "accepted");
    const winner = r.allocated_to || lastAccepted?.winner;
    // a re-announced auction collects a new round of bids each time: show the latest round
    const round = Math.max(0, ...r.bids.map((b) => b.round));
    const latest = r.bids.filter((b) => b.round === round);
    const shown = latest.length > MAX_BIDS ? [...latest].sort((a, b) => (b.utility ?? -Infinity) - (a.utility ?? -Infinity)).slice(0, MAX_BIDS) : latest;
    const bids = shown.map((b) =>
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
      h(
        "div",
        { class: "bids" },
        round ? h("span", { class: "round" }, `round ${round + 1}:`) : null,
        bids.length ? bids : "waiting for bids…",
        latest.length > shown.length ? h("span", { class: "more" }, ` +${latest.length - shown.length} more`) : null,
      ),
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
