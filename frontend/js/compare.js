// The compare page: pick finished missions (or a sweep) and see the three figures per policy.

import { $, h, fmt } from "./dom.js";
import { get, qs } from "./api.js";
import { barChart, stripChart } from "./charts.js";
import { KIND_LABEL } from "./palette.js";
import { missionMetrics, shortId } from "./missions.js";
import { policyColour as colour, policyLabel, policyRank as rank, policyShort } from "./policies.js";
import { SweepPanel } from "./sweeps.js";

const TYPES = ["scout", "excavator", "hauler"];
const KINDS = ["scout_excavator", "excavator_hauler"];

/** Mean and a 95% confidence interval of the mean (normal approximation; t for small n). */
export function meanCi(values) {
  const n = values.length;
  if (!n) return null;
  const mean = values.reduce((a, b) => a + b, 0) / n;
  if (n < 2) return { mean, lo: mean, hi: mean, n };
  const sd = Math.sqrt(values.reduce((a, b) => a + (b - mean) ** 2, 0) / (n - 1));
  const t = [12.71, 4.3, 3.18, 2.78, 2.57, 2.45, 2.36, 2.31, 2.26][n - 2] ?? 1.96;
  const half = (t * sd) / Math.sqrt(n);
  return { mean, lo: mean - half, hi: mean + half, n };
}

export class ComparePage {
  constructor() {
    this.missions = [];
    this.selected = new Set();
    this.metrics = new Map(); // mission id -> metrics
    this.sweep = null; // a picked sweep's runs, shown instead of the missions
    this.sweepId = null;
    this.touched = false;
    this.sweeps = new SweepPanel({
      onPick: (detail) => {
        this.sweep = detail ? detail.runs : null;
        this.sweepId = detail ? detail.id : null;
        this.draw();
      },
    });
    $("#compare-all").addEventListener("click", () => {
      for (const m of this.missions) this.selected.add(m.id);
      this.dropSweep();
      this.renderList();
      this.update();
    });
    $("#compare-none").addEventListener("click", () => {
      this.touched = true;
      this.selected.clear();
      this.dropSweep();
      this.renderList();
      this.update();
    });
    new ResizeObserver(() => this.draw()).observe($(".compare-figs"));
  }

  async show() {
    try {
      const data = await get(`/missions${qs({ status: "completed", limit: 200 })}`);
      this.missions = data.items;
    } catch {
      this.missions = [];
    }
    if (!this.touched) for (const m of this.missions) this.selected.add(m.id); // all, until the user picks
    this.renderList();
    this.sweeps.show();
    this.update();
  }

  dropSweep() {
    this.sweep = null;
    this.sweepId = null;
    this.sweeps.clear();
  }

  renderList() {
    const rows = this.missions.map((m) =>
      h(
        "tr",
        { dataset: { mission: m.id } },
        h(
          "td",
          {},
          h("input", {
            type: "checkbox",
            checked: this.selected.has(m.id),
            "aria-label": `Compare mission ${m.id}`,
            onchange: (e) => {
              this.touched = true;
              if (e.target.checked) this.selected.add(m.id);
              else this.selected.delete(m.id);
              this.dropSweep();
              this.update();
            },
          }),
        ),
        h("td", {}, h("a", { href: `#/live/${encodeURIComponent(m.id)}` }, shortId(m.id))),
        h("td", {}, policyLabel(m.policy)),
        h("td", { class: "num" }, m.seed),
        h("td", { class: "num" }, fmt(this.metrics.get(m.id)?.makespan_s, 0)),
      ),
    );
    if (!rows.length) rows.push(h("tr", {}, h("td", { colspan: 5, class: "muted" }, "No completed missions yet.")));
    $("#compare-table tbody").replaceChildren(...rows);
  }

  async update() {
    const missing = [...this.selected].filter((id) => !this.metrics.has(id));
    for (let i = 0; i < missing.length; i += 8) {
      // a few at a time: a long history must not flood the server
      await Promise.all(
        missing.slice(i, i + 8).map(async (id) => {
          const metrics = await missionMetrics(id);
          if (metrics) this.metrics.set(id, metrics);
        }),
      );
    }
    if (missing.length) this.renderList();
    this.draw();
  }

  runs() {
    if (this.sweep) return this.sweep;
    return [...this.selected].map((id) => this.metrics.get(id)).filter(Boolean);
  }

  draw() {
    const runs = this.runs();
    const present = [...new Set(runs.map((r) => r.policy))].filter(Boolean).sort((a, b) => rank(a) - rank(b) || a.localeCompare(b));
    const by = Object.fromEntries(present.map((p) => [p, runs.filter((r) => r.policy === p)]));
    const source = this.sweep ? `sweep ${this.sweepId} · ` : "";
    $("#compare-n").textContent = runs.length ? `· ${source}${runs.length} runs` : "";
    const empty = this.sweep ? "no finished runs in this sweep yet" : "pick finished missions";
    stripChart(
      $("#cmp-makespan"),
      present.map((p) => ({ label: policyShort(p), colour: colour(p), values: by[p].map((r) => r.makespan_s).filter(Number.isFinite) })),
      { emptyText: empty },
    );
    const bars = (getter) =>
      present.map((p) => {
        const ci = meanCi(by[p].map(getter).filter(Number.isFinite));
        return { name: policyLabel(p), value: ci ? ci.mean : 0, colour: colour(p), err: ci && ci.n > 1 ? [ci.lo, ci.hi] : undefined };
      });
    barChart(
      $("#cmp-distance"),
      TYPES.map((t) => ({ label: t, bars: bars((r) => r.distance?.[t]) })),
      { emptyText: empty, unit: " m" },
    );
    barChart(
      $("#cmp-auction"),
      KINDS.map((k) => ({ label: KIND_LABEL[k], bars: bars((r) => r.auction_open_s?.[k]?.mean) })),
      { emptyText: empty, unit: " s" },
    );
    this.summary(present, by);
  }

  summary(present, by) {
    const table = $("#compare-summary");
    if (!present.length) return table.replaceChildren();
    const cell = (vals, d = 0) => {
      const ci = meanCi(vals.filter(Number.isFinite));
      if (!ci) return "–";
      return ci.n > 1 ? `${fmt(ci.mean, d)} ± ${fmt(ci.hi - ci.mean, d)}` : fmt(ci.mean, d);
    };
    const ratio = present.some((p) => by[p].some((r) => Number.isFinite(r.makespan_ratio)));
    const rows = [
      ["runs", (rs) => String(rs.length)],
      ["makespan (s)", (rs) => cell(rs.map((r) => r.makespan_s))],
      ...(ratio ? [["makespan / lower bound", (rs) => cell(rs.map((r) => r.makespan_ratio), 2)]] : []),
      ...TYPES.map((t) => [`distance ${t} (m)`, (rs) => cell(rs.map((r) => r.distance?.[t]))]),
      ...KINDS.map((k) => [`open time ${KIND_LABEL[k]} (s)`, (rs) => cell(rs.map((r) => r.auction_open_s?.[k]?.mean), 2)]),
      ["auctions", (rs) => cell(rs.map((r) => r.auctions))],
      ["bids", (rs) => cell(rs.map((r) => r.bids))],
      ["declines", (rs) => cell(rs.map((r) => r.declines))],
      ["messages", (rs) => cell(rs.map((r) => r.messages))],
    ];
    table.replaceChildren(
      h("caption", { class: "sr-only" }, "Mean ± 95% confidence interval per policy"),
      h("thead", {}, h("tr", {}, h("th", { scope: "col" }, "mean ± 95% CI"), present.map((p) => h("th", { scope: "col", class: "num", style: `color:${colour(p)}` }, policyLabel(p))))),
      h("tbody", {}, rows.map(([label, f]) => h("tr", {}, h("th", { scope: "row" }, label), present.map((p) => h("td", { class: "num" }, f(by[p])))))),
    );
  }
}
