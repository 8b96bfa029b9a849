// The compare page: pick finished missions of one scenario (or a sweep) and see the three
// figures per policy. Different scenarios are never pooled, nor field runs with simulated
// ones, and a run whose policy was switched live counts under no single policy
// (comparegroups.js).

import { $, h, fmt } from "./dom.js";
import { get, qs } from "./api.js";
import { barChart, stripChart } from "./charts.js";
import { KIND_ABBR, KIND_LABEL, TYPE_ABBR } from "./palette.js";
import { fieldMark, missionMetrics, shortId } from "./missions.js";
import { SweepPanel } from "./sweeps.js";
import { groupColour as colour, groupLabel, groupOf, groupOrder, groupShort, meanCi, policyText, scenarioKey, scenarios } from "./comparegroups.js";

const TYPES = ["scout", "excavator", "hauler"];
const KINDS = ["scout_excavator", "excavator_hauler"];

export class ComparePage {
  constructor() {
    this.missions = [];
    this.selected = new Set();
    this.metrics = new Map(); // mission id -> metrics
    this.sweep = null; // a picked sweep: its runs are shown instead of the missions
    this.touched = false;
    this.scenario = null; // the scenario key compared (one at a time)
    this.includeMixed = false;
    this.sweeps = new SweepPanel({
      onPick: (detail) => {
        this.sweep = detail;
        this.renderList();
        this.draw();
      },
    });
    $("#compare-all").addEventListener("click", () => {
      for (const m of this.shown()) this.selected.add(m.id);
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
    $("#compare-scenario").addEventListener("change", (e) => {
      this.scenario = e.target.value;
      this.dropSweep();
      this.renderList();
      this.update();
    });
    $("#compare-mixed").addEventListener("change", (e) => {
      this.includeMixed = e.target.checked;
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
    this.renderScenarios();
    this.renderList();
    this.sweeps.show();
    this.update();
  }

  /** One scenario at a time: the one with most runs until the user picks another. */
  renderScenarios() {
    const list = scenarios(this.missions);
    if (!list.some((s) => s.key === this.scenario)) this.scenario = list[0]?.key ?? null;
    const sel = $("#compare-scenario");
    const options = list.map((s) => h("option", { value: s.key, selected: s.key === this.scenario }, `${s.name} · ${s.hash.slice(0, 6)}${s.field ? " · field" : ""} (${s.count})`));
    sel.replaceChildren(...(options.length ? options : [h("option", { value: "" }, "none yet")]));
    sel.disabled = list.length < 2;
    sel.title = list.length < 2 ? "Every finished mission has this scenario" : "Runs of different scenarios, or field runs and simulated ones, are never pooled: pick one";
  }

  /** The finished missions of the picked scenario. */
  shown() {
    return this.missions.filter((m) => scenarioKey(m) === this.scenario);
  }

  dropSweep() {
    this.sweep = null;
    this.sweeps.clear();
  }

  renderList() {
    const sweep = Boolean(this.sweep);
    const rows = this.shown().map((m) => {
      const off = m.mixed_policy && !this.includeMixed;
      return h(
        "tr",
        { dataset: { mission: m.id, mixed: m.mixed_policy ? "true" : "false", scenario: m.scenario_hash, mode: m.mode } },
        h(
          "td",
          {},
          h("input", {
            type: "checkbox",
            checked: !sweep && !off && this.selected.has(m.id),
            disabled: off,
            title: off ? "Its policy was switched live: tick “Include mixed-policy runs” to compare it" : "",
            "aria-label": `Compare mission ${m.id}`,
            onchange: (e) => {
              this.touched = true;
              if (e.target.checked) this.selected.add(m.id);
              else this.selected.delete(m.id);
              if (sweep) {
                // back from a sweep: the ticks shown are the selection
                this.selected = new Set(e.target.checked ? [m.id] : []);
                this.dropSweep();
                this.renderList();
              }
              this.update();
            },
          }),
        ),
        h("td", {}, h("a", { href: `#/live/${encodeURIComponent(m.id)}` }, shortId(m.id)), fieldMark(m)),
        h("td", { class: "policy-cell", title: policyText(m) }, policyText(m), m.mixed_policy ? h("span", { class: "badge mixed", title: "The policy was switched during the run" }, "mixed") : null),
        h("td", { class: "scenario-cell", title: `${m.scenario_name} (hash ${m.scenario_hash})` }, h("span", {}, m.scenario_name)),
        h("td", { class: "num" }, m.seed),
        h("td", { class: "num" }, fmt(this.metrics.get(m.id)?.makespan_s, 0)),
      );
    });
    if (!rows.length) rows.push(h("tr", {}, h("td", { colspan: 6, class: "muted" }, "No completed missions yet.")));
    $("#compare-table tbody").replaceChildren(...rows);
    $("#compare-table").dataset.sweep = sweep ? String(this.sweep.id) : "";
    $("#compare-missions-note").hidden = !sweep;
    $("#compare-missions-note").textContent = sweep ? `Showing sweep ${this.sweep.id}; tick a mission to compare missions again.` : "";
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

  /** The runs compared, each with the `group` it counts under. */
  runs() {
    if (this.sweep) return this.sweep.runs.map((r) => ({ ...r, group: r.policy }));
    return this.shown()
      .filter((m) => this.selected.has(m.id) && (this.includeMixed || !m.mixed_policy))
      .map((m) => this.metrics.has(m.id) && { ...this.metrics.get(m.id), group: groupOf(m) })
      .filter(Boolean);
  }

  draw() {
    const runs = this.runs();
    const present = [...new Set(runs.map((r) => r.group))].filter(Boolean).sort(groupOrder);
    const by = Object.fromEntries(present.map((p) => [p, runs.filter((r) => r.group === p)]));
    const first = this.shown()[0];
    const where = this.sweep ? `sweep ${this.sweep.id} · ${this.sweep.scenario_name}` : first && `${first.scenario_name}${first.mode === "field" ? " · field runs" : ""}`;
    $("#compare-n").textContent = runs.length ? `· ${where} · ${runs.length} runs` : "";
    const empty = this.sweep ? "no finished runs in this sweep yet" : "pick finished missions";
    stripChart(
      $("#cmp-makespan"),
      present.map((p) => ({ label: groupShort(p), colour: colour(p), values: by[p].map((r) => r.makespan_s).filter(Number.isFinite) })),
      { emptyText: empty },
    );
    const bars = (getter) =>
      present.map((p) => {
        const ci = meanCi(by[p].map(getter).filter(Number.isFinite));
        return { name: groupLabel(p), value: ci ? ci.mean : 0, colour: colour(p), err: ci && ci.n > 1 ? [ci.lo, ci.hi] : undefined };
      });
    barChart(
      $("#cmp-distance"),
      TYPES.map((t) => ({ label: t, abbr: TYPE_ABBR[t], bars: bars((r) => r.distance?.[t]) })),
      { emptyText: empty, unit: " m" },
    );
    barChart(
      $("#cmp-auction"),
      KINDS.map((k) => ({ label: KIND_LABEL[k], abbr: KIND_ABBR[k], bars: bars((r) => r.auction_open_s?.[k]?.mean) })),
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
    return table.replaceChildren(
      h("caption", { class: "sr-only" }, "Mean ± 95% confidence interval per policy"),
      h("thead", {}, h("tr", {}, h("th", { scope: "col" }, "mean ± 95% CI"), present.map((p) => h("th", { scope: "col", class: "num", style: `color:${colour(p)}` }, groupLabel(p))))),
      h("tbody", {}, rows.map(([label, f]) => h("tr", {}, h("th", { scope: "row" }, label), present.map((p) => h("td", { class: "num" }, f(by[p])))))),
    );
  }
}
