// The missions page: the run history (filtered, paginated) and the form that starts a mission.

import { $, h, fmt, toast } from "./dom.js";
import { get, isOperator, post, qs } from "./api.js";
import { policyText } from "./comparegroups.js";
import { ENDED } from "./status.js";

const PAGE = 20;

/** The small "field" mark of a field run (real agent processes, docs/field.md), else null. */
export const fieldMark = (m) =>
  m.mode === "field" ? h("span", { class: "badge field", title: "A field run (real agent processes): played back from its stored poses, never re-simulated; kept apart from simulated runs" }, "field") : null;

export class MissionsPage {
  constructor() {
    this.offset = 0;
    this.total = 0;
    this.file = null; // the chosen scenario file
    this.scenario = null; // promise of the server's reading of it (the scenario, or null)
    this.filter = $("#history-filter");
    this.filter.addEventListener("change", () => {
      this.offset = 0;
      this.refresh();
    });
    $("#history-refresh").addEventListener("click", () => this.refresh());
    $("#history-prev").addEventListener("click", () => {
      this.offset = Math.max(0, this.offset - PAGE);
      this.refresh();
    });
    $("#history-next").addEventListener("click", () => {
      this.offset += PAGE;
      this.refresh();
    });
    const form = $("#start-form");
    form.addEventListener("submit", (e) => {
      e.preventDefault();
      this.start(form);
    });
    form.scenario_file.addEventListener("change", () => this.readScenario(form));
    for (const r of form.querySelectorAll("input[name=scenario]")) r.addEventListener("change", () => this._fileState(form));
    this._fileState(form);
    this.timer = null;
  }

  show() {
    this.refresh();
    clearInterval(this.timer);
    this.timer = setInterval(() => !document.hidden && this.refresh(), 5000);
  }

  hide() {
    clearInterval(this.timer);
  }

  applyControl() {
    for (const el of document.querySelectorAll("#start-form [data-control]")) el.disabled = !isOperator();
    this._fileState($("#start-form"));
  }

  _fileState(form) {
    const useFile = form.querySelector("input[name=scenario]:checked").value === "file";
    form.scenario_file.disabled = !useFile || !isOperator();
  }

  async refresh() {
    const f = this.filter;
    try {
      const data = await get(`/missions${qs({ status: f.status.value, policy: f.policy.value, mode: f.mode.value, limit: PAGE, offset: this.offset })}`);
      this.total = data.total;
      this.render(data.items);
    } catch (err) {
      $("#history tbody").replaceChildren(h("tr", {}, h("td", { colspan: 8, class: "muted" }, `Could not load missions: ${err.message}`)));
    }
  }

  render(items) {
    const rows = items.map((m) => {
      const metrics = metricsCache.get(m.id) ?? {}; // the list carries no metrics
      const delivered = metrics.minerals_delivered;
      const total = metrics.minerals_total;
      return h(
        "tr",
        { dataset: { mission: m.id, status: m.status, policy: m.policy, mixed: m.mixed_policy ? "true" : "false", mode: m.mode } },
        h("td", {}, h("a", { href: `#/live/${encodeURIComponent(m.id)}` }, shortId(m.id)), fieldMark(m)),
        h("td", {}, h("span", { class: "badge", dataset: { status: m.status } }, m.status)),
        h("td", { title: m.mixed_policy ? "The policy was switched during the run: initial → … → current" : "" }, policyText(m), m.mixed_policy ? h("span", { class: "badge mixed" }, "mixed") : null),
        h("td", { class: "num" }, m.seed),
        h("td", { title: `scenario hash ${m.scenario_hash}` }, m.scenario_name),
        h("td", { class: "num", dataset: { cell: "makespan" } }, makespanText(metrics)),
        h("td", { class: "num", dataset: { cell: "minerals" } }, delivered !== undefined ? `${delivered}/${total}` : "–"),
        h("td", {}, m.created_at ? new Date(m.created_at).toLocaleString() : "–"),
      );
    });
    if (!rows.length) rows.push(h("tr", {}, h("td", { colspan: 8, class: "muted" }, "No missions yet. Start one with the form.")));
    $("#history tbody").replaceChildren(...rows);
    const last = Math.min(this.total, this.offset + items.length);
    $("#history-page").textContent = this.total ? `${this.offset + 1}–${last} of ${this.total}` : "";
    $("#history-prev").disabled = this.offset === 0;
    $("#history-next").disabled = last >= this.total;
    this.fillMetrics(items);
  }

  /** The list carries no metrics: read each mission's (cached once it has ended). */
  async fillMetrics(items) {
    await Promise.all(
      items
        .filter((m) => !(metricsCache.has(m.id) && FINISHED.has(m.status)))
        .map(async (m) => {
          const metrics = await missionMetrics(m.id);
          const row = document.querySelector(`#history tr[data-mission="${m.id}"]`);
          if (!metrics || !row) return;
          row.querySelector('[data-cell="makespan"]').textContent = makespanText(metrics);
          row.querySelector('[data-cell="minerals"]').textContent = `${metrics.minerals_delivered}/${metrics.minerals_total}`;
        }),
    );
  }

  /** The chosen file's text goes to the server, which parses it (TOML or JSON) and answers
   * the validated scenario, every default spelled out, or an error naming the field or line. */
  readScenario(form) {
    const file = form.scenario_file.files[0];
    $("#scenario-summary").textContent = "";
    this.file = file || null;
    this.scenario = file ? this._parse(file, form) : null;
  }

  async _parse(file, form) {
    const out = $("#scenario-summary");
    try {
      const format = file.name.toLowerCase().endsWith(".toml") ? "toml" : "json";
      const s = await post("/scenarios/parse", { text: await file.text(), format });
      if (this.file !== file) return null;
      out.textContent = `${s.name}: ${s.width}×${s.height} m, ${s.sites} sites, team ${s.team.scouts}/${s.team.excavators}/${s.team.haulers}`;
      form.querySelector("input[name=scenario][value=file]").checked = true;
      return s;
    } catch (err) {
      if (this.file === file) out.textContent = `Cannot read ${file.name}: ${err.message}`;
      return null;
    }
  }

  async start(form) {
    const err = $("#start-error");
    err.textContent = "";
    const body = {
      policy: form.policy.value,
      seed: Number(form.seed.value),
      speed: form.speed.value === "max" ? "max" : Number(form.speed.value),
    };
    if (form.querySelector("input[name=scenario]:checked").value === "file") {
      const scenario = await this.scenario; // the server's reading of the chosen file
      if (!scenario) {
        err.textContent = this.file ? `${this.file.name} is not a scenario this server takes (see above).` : "Choose a scenario file first (or use the reference scenario).";
        return;
      }
      body.scenario = scenario;
    }
    try {
      const m = await post("/missions", body);
      toast(`Mission ${shortId(m.id)} started`);
      location.hash = `#/live/${encodeURIComponent(m.id)}`;
    } catch (e) {
      err.textContent = e.message;
    }
  }
}

// an interrupted mission's metrics change again once it is resumed: only endings are cached
const FINISHED = ENDED;
const metricsCache = new Map(); // mission id -> metrics of a mission that has ended

/** A mission's metrics (live or final); those of ended missions are read once. */
export async function missionMetrics(id) {
  if (metricsCache.has(id)) return metricsCache.get(id);
  try {
    const m = await get(`/missions/${encodeURIComponent(id)}`);
    if (m.metrics && FINISHED.has(m.status)) metricsCache.set(id, m.metrics);
    return m.metrics;
  } catch {
    return null;
  }
}

function makespanText(metrics) {
  if (metrics.makespan_s !== undefined && metrics.makespan_s !== null) return `${fmt(metrics.makespan_s, 0)} s`;
  return metrics.sim_time_s !== undefined ? `(${fmt(metrics.sim_time_s, 0)} s)` : "–";
}

export function shortId(id) {
  const s = String(id);
  return s.length > 12 ? s.slice(0, 8) : s;
}
