// The live view's three charts: minerals delivered over sim time, distance by robot type,
// and auction open times by kind. Redrawn at most once a second, and always after the last
// change: a chart never stays behind the table and counters once the figures stop moving.

import { $ } from "./dom.js";
import { barChart, stepChart, stripChart, timeTicks } from "./charts.js";
import { KIND_ABBR, KIND_COLOUR, KIND_LABEL, TYPE_ABBR, TYPE_COLOUR, robotType } from "./palette.js";
import { distanceByType } from "./final.js";

const REDRAW_MS = 1000;

/** An axis label for sim seconds, in the unit that suits the range shown. */
function timeFmt(range) {
  if (range < 120) return (t) => `${Math.round(t)}s`;
  if (range < 4 * 3600) return (t) => `${+(t / 60).toFixed(1)}m`;
  return (t) => `${+(t / 3600).toFixed(1)}h`;
}

export class LiveCharts {
  /** openTimes(): closed auctions' open times by kind ({kind: [seconds]}), read when drawing. */
  constructor({ openTimes }) {
    this.openTimes = openTimes;
    this.reset();
    new ResizeObserver(() => this.draw()).observe($(".charts"));
  }

  reset() {
    this.delivered = []; // [[t, count]]
    this.last = null;
    this.distance = {};
    this.total = null;
    this.t = 0;
    this.drawnAt = 0;
    this.shown = null; // the figures as last drawn
    this.final = false; // showing the stored ending: the stream no longer moves the charts
  }

  /** A frame: its simulation time and the engine's counters. */
  onFrame({ t, counters }) {
    if (this.final) return;
    this.t = t;
    const c = counters;
    if (c.minerals_total !== undefined) this.total = c.minerals_total;
    const v = c.minerals_delivered;
    if (v !== undefined && v !== this.last) {
      if (this.last === null && v > 0 && !this.delivered.length) this.delivered.push([t, v]);
      else if (this.last !== null) this.delivered.push([t, v]);
      this.last = v;
    }
    this._soon();
  }

  /** Draw now if the last draw is a second old, else once that second is over. */
  _soon() {
    const wait = REDRAW_MS - (performance.now() - this.drawnAt);
    if (wait <= 0) return this.draw();
    if (!this.timer) {
      this.timer = setTimeout(() => {
        this.timer = null;
        this.draw();
      }, wait);
    }
    return undefined;
  }

  onDetail(list) {
    if (this.final) return;
    const sum = {};
    for (const r of list) {
      const type = robotType(r);
      sum[type] = (sum[type] || 0) + (Number(r.distance) || 0);
    }
    this.distance = sum;
    this._soon();
  }

  /** Backfill from stored `delivered` events when joining a running mission. The answer may
   * come after frames moved the curve on (the stored events lag the stream): they are merged
   * by count, never replacing what frames already showed, so the curve never falls behind
   * the counters (a pause right after would have left it there). */
  loadDeliveries(events) {
    if (!events.length || this.final) return;
    const byCount = new Map(this.delivered.map(([t, n]) => [n, t]));
    for (const e of events) byCount.set(e.data.delivered, e.t); // the event's own time is exact
    this.delivered = [...byCount].map(([n, t]) => [t, n]).sort((a, b) => a[1] - b[1]);
    const stored = this.delivered[this.delivered.length - 1][1];
    this.last = this.last === null ? stored : Math.max(this.last, stored);
    this.draw();
  }

  /** The stored ending: the whole delivery curve, the final time, the stored distances. */
  showFinal({ t, deliveries, metrics, robots, openTimes }) {
    this.final = true;
    this.finalOpen = openTimes;
    this.t = t;
    const sorted = [...deliveries].sort((a, b) => a.t - b.t || a.seq - b.seq);
    this.delivered = sorted.map((e) => [e.t, e.data.delivered]);
    this.last = this.delivered.length ? this.delivered[this.delivered.length - 1][1] : null;
    if (metrics && metrics.minerals_total !== undefined) this.total = metrics.minerals_total;
    this.distance = distanceByType(metrics, robots, robotType);
    this.draw();
  }

  /** The charts' figures (for tests): {t, delivered, total, distance, final}, and `shown`:
   * {t, delivered (the curve's last count), distance} as last drawn. */
  figures() {
    const open = this.final && this.finalOpen ? this.finalOpen : this.openTimes();
    return { t: this.t, delivered: this.delivered.map((p) => [...p]), total: this.total, distance: { ...this.distance }, openTimes: open, final: this.final, shown: this.shown };
  }

  draw() {
    if ($("#live").hidden) return;
    this.drawnAt = performance.now();
    clearTimeout(this.timer);
    this.timer = null;
    const last = this.delivered.length ? this.delivered[this.delivered.length - 1][1] : 0;
    this.shown = { t: this.t, delivered: last, distance: { ...this.distance } };
    stepChart($("#chart-minerals"), [{ name: "delivered", colour: "#f0e442", points: this.delivered, dashedMax: this.total ?? undefined }], {
      xMax: this.t,
      yMax: this.total ?? 0,
      xFmt: timeFmt(this.t),
      xTicks: timeTicks,
      emptyText: "no minerals delivered yet",
    });
    const types = ["scout", "excavator", "hauler"].filter((t) => t in this.distance);
    barChart(
      $("#chart-distance"),
      types.map((t) => ({ label: t, abbr: TYPE_ABBR[t], bars: [{ name: t, value: this.distance[t], colour: TYPE_COLOUR[t] }] })),
      { unit: " m" },
    );
    const times = this.final && this.finalOpen ? this.finalOpen : this.openTimes();
    const kinds = ["scout_excavator", "excavator_hauler", "operator"].filter((k) => k in times || k !== "operator");
    stripChart(
      $("#chart-auctions"),
      kinds.map((k) => ({ label: KIND_LABEL[k], abbr: KIND_ABBR[k], colour: KIND_COLOUR[k], values: times[k] || [] })),
      { emptyText: "no auction closed yet" },
    );
  }
}
