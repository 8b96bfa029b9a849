// Sweeps on the compare page: pick one to compare, start one (operator), watch its progress,
// show the figures the server drew for it.

import { $, h, clock, toast } from "./dom.js";
import { get, getToken, isOperator, onTokenChange, post } from "./api.js";
import { policies, policyLabel } from "./policies.js";

const ACTIVE = new Set(["running", "cancelling"]);
const RESUMABLE = new Set(["interrupted", "cancelled", "failed"]);

/** An image the API serves, as a data: URL (fetched with the token, which an <img> cannot send). */
async function loadImage(img, url) {
  try {
    const res = await fetch(url, { headers: getToken() ? { Authorization: `Bearer ${getToken()}` } : {} });
    if (!res.ok) throw new Error(res.statusText);
    const blob = await res.blob();
    img.src = await new Promise((ok, fail) => {
      const reader = new FileReader();
      reader.onload = () => ok(reader.result);
      reader.onerror = () => fail(reader.error);
      reader.readAsDataURL(blob);
    });
    img.dataset.loaded = "true";
  } catch (err) {
    img.replaceWith(h("p", { class: "form-error" }, `Could not load the figure: ${err.message}`));
  }
}

/** "#3 · reference ×1 · 1 · FCFS, 2 · Coalitions × 10 seeds (running)": the whole description. */
function describe(s) {
  const scale = s.scale > 1 && !s.scenario_name.endsWith(`-x${s.scale}`) ? ` ×${s.scale}` : ""; // "reference-x4" says it
  return `Sweep #${s.id}: ${s.scenario_name}${scale}, ${s.policies.map(policyLabel).join(", ")} × ${s.n_seeds} seeds, ${s.status}`;
}

/** A link that downloads `url` as `filename`; with a token it is fetched with it (reads may
 * need it) and handed over as a blob. */
function downloadLink(url, filename, text) {
  const a = h("a", { href: url, download: filename, class: "btn tiny", dataset: { download: filename } }, text);
  a.addEventListener("click", async (e) => {
    if (!getToken()) return; // same origin, no token: the plain link downloads
    e.preventDefault();
    try {
      const res = await fetch(url, { headers: { Authorization: `Bearer ${getToken()}` } });
      if (!res.ok) throw new Error(res.statusText);
      const blobUrl = URL.createObjectURL(await res.blob());
      const tmp = h("a", { href: blobUrl, download: filename });
      document.body.append(tmp);
      tmp.click();
      tmp.remove();
      setTimeout(() => URL.revokeObjectURL(blobUrl), 10_000);
    } catch (err) {
      toast(`Could not download ${filename}: ${err.message}`, "error");
    }
  });
  return a;
}

export class SweepPanel {
  /** onPick(detail | null): a sweep (with `runs` and `figures`) was picked, or the pick cleared. */
  constructor({ onPick }) {
    this.onPick = onPick;
    this.sweeps = [];
    this.picked = null;
    this.watching = null;
    this.timer = null;
    this.policiesDrawn = false;
    const form = $("#sweep-form");
    form.addEventListener("submit", (e) => {
      e.preventDefault();
      this.start(form);
    });
    $("#sweep-cancel").addEventListener("click", () => this.command("cancel"));
    $("#sweep-resume").addEventListener("click", () => this.command("resume"));
    onTokenChange(() => this.applyControl());
  }

  applyControl() {
    for (const el of document.querySelectorAll("#sweep-panel [data-control]")) el.disabled = !isOperator();
  }

  /** Show the panel if the server offers sweeps (asks the schema: probing would log a 404). */
  async show() {
    let spec = {};
    try {
      spec = await fetch("/openapi.json").then((r) => (r.ok ? r.json() : {}));
    } catch {
      spec = {};
    }
    const available = Boolean(spec.paths && "/api/sweeps" in spec.paths);
    $("#sweep-panel").hidden = !available;
    if (!available) return;
    if (!this.policiesDrawn) this.drawPolicies(spec);
    await this.refresh();
  }

  /** One checkbox per registered policy; those of the server's default sweep checked. */
  drawPolicies(spec) {
    const defaults = spec.components?.schemas?.SweepCreate?.properties?.policies?.default ?? [];
    const checked = (p) => defaults.includes(p.number) || defaults.includes(p.name);
    $("#sweep-policies").replaceChildren(
      ...policies().map((p) =>
        h(
          "label",
          { class: "check", title: p.description },
          h("input", { type: "checkbox", name: "policy", value: p.name, checked: checked(p), "data-control": true }),
          policyLabel(p.name),
        ),
      ),
    );
    this.policiesDrawn = policies().length > 0;
    this.applyControl();
  }

  async refresh() {
    try {
      const data = await get("/sweeps?limit=100");
      this.sweeps = data.items;
    } catch {
      this.sweeps = [];
    }
    this.renderPick();
    const active = this.sweeps.find((s) => ACTIVE.has(s.status));
    if (active && this.watching !== active.id) this.watch(active.id);
  }

  renderPick() {
    const box = $("#sweep-pick");
    if (!this.sweeps.length) return box.replaceChildren(h("p", { class: "hint" }, "No sweeps yet."));
    // the menu stays short; the picked sweep's whole description goes below it, wrapped
    const text = (s) => `#${s.id} · ${s.scenario_name} · ${s.policies.length} × ${s.n_seeds}${s.status === "completed" ? "" : ` (${s.status})`}`;
    const sel = h(
      "select",
      { id: "sweep-select", "aria-label": "Sweep" },
      h("option", { value: "" }, "—"),
      this.sweeps.map((s) => h("option", { value: s.id, selected: s.id === this.picked, title: describe(s) }, text(s))),
    );
    sel.addEventListener("change", () => this.pick(sel.value ? Number(sel.value) : null));
    const picked = this.sweeps.find((s) => s.id === this.picked);
    return box.replaceChildren(h("label", {}, "Compare a sweep instead", sel), h("p", { class: "hint sweep-desc", id: "sweep-desc" }, picked ? describe(picked) : ""));
  }

  /** Show sweep `id` in the charts, its figures below them (null: back to the missions). */
  async pick(id) {
    this.picked = id;
    const sel = $("#sweep-select");
    if (sel) sel.value = id ?? "";
    const desc = $("#sweep-desc");
    const known = this.sweeps.find((s) => s.id === id);
    if (desc) desc.textContent = known ? describe(known) : "";
    if (id === null) {
      this.renderFigures(null);
      return this.onPick(null);
    }
    let detail = null;
    try {
      detail = await get(`/sweeps/${encodeURIComponent(id)}`);
    } catch (err) {
      toast(`Could not load sweep ${id}: ${err.message}`, "error");
    }
    if (this.picked !== id) return undefined; // picked another meanwhile
    if (detail && !ACTIVE.has(detail.status) && this.watching === null) this.renderProgress(detail);
    this.renderFigures(detail);
    return this.onPick(detail);
  }

  /** The user went back to picking missions. */
  clear() {
    this.picked = null;
    const sel = $("#sweep-select");
    if (sel) sel.value = "";
    if ($("#sweep-desc")) $("#sweep-desc").textContent = "";
    this.renderFigures(null);
  }

  renderFigures(detail) {
    const box = $("#sweep-figures");
    const figures = detail ? detail.figures : [];
    const files = detail ? detail.files : [];
    box.hidden = !figures.length && !files.length;
    const name = (file) => `sweep-${detail.id}-${file}`;
    $("#sweep-downloads").replaceChildren(
      ...(files.length ? [h("span", { class: "hint" }, "Download:")] : []),
      ...files.map((f) => downloadLink(f.url, name(f.name), f.name)),
      ...figures.flatMap((f) => [downloadLink(f.svg, name(`${f.name}.svg`), `${f.name}.svg`), downloadLink(f.png, name(`${f.name}.png`), `${f.name}.png`)]),
    );
    box.dataset.sweep = detail?.id ?? "";
    $("#sweep-figures-title").textContent = detail ? `Sweep ${detail.id}: ${detail.scenario_name}, ${detail.n_seeds} seeds` : "Sweep figures";
    $("#sweep-figures .sweep-fig-grid").replaceChildren(
      ...figures.map((f) => {
        const img = h("img", { alt: f.title });
        loadImage(img, f.png);
        return h(
          "figure",
          { dataset: { figure: f.name } },
          h("figcaption", {}, f.title),
          img,
          f.verdict.map((v) => h("p", { class: "hint" }, v)),
        );
      }),
    );
  }

  async start(form) {
    const error = $("#sweep-error");
    error.textContent = "";
    const policies = [...form.querySelectorAll("input[name=policy]:checked")].map((i) => i.value);
    const body = { policies, seeds: form.seeds.value.trim(), scale: Number(form.scale.value) || 1 };
    const button = form.querySelector("button[type=submit]");
    button.disabled = true;
    try {
      const sweep = await post("/sweeps", body);
      toast(`Sweep ${sweep.id} started: ${sweep.total} runs`);
      this.watch(sweep.id);
      await this.refresh();
    } catch (err) {
      error.textContent = err.message;
    } finally {
      button.disabled = !isOperator();
    }
  }

  /** Poll a sweep's progress each second while it runs; show it once it is done. */
  watch(id) {
    this.watching = id;
    clearTimeout(this.timer);
    const tick = async () => {
      if (this.watching !== id) return;
      let sweep;
      try {
        sweep = await get(`/sweeps/${encodeURIComponent(id)}?runs=false`);
      } catch {
        this.timer = setTimeout(tick, 2000);
        return;
      }
      this.renderProgress(sweep);
      if (ACTIVE.has(sweep.status)) {
        this.timer = setTimeout(tick, 1000);
        return;
      }
      this.watching = null;
      await this.refresh();
      if (sweep.status === "completed") this.pick(id);
    };
    tick();
  }

  renderProgress(s) {
    const box = $("#sweep-progress");
    box.hidden = false;
    // every run done, the server writes the statistics and figures (a minute or so): say so
    const building = ACTIVE.has(s.status) && s.phase === "figures";
    Object.assign(box.dataset, { sweep: s.id, status: s.status, done: s.done, total: s.total, phase: building ? "figures" : "runs" });
    const bar = box.querySelector("progress");
    bar.max = s.total || 1;
    if (building) bar.removeAttribute("value"); // indeterminate: busy, no fraction to show
    else bar.value = s.done;
    const eta = building ? " · building figures…" : ACTIVE.has(s.status) && s.eta_s !== null && s.eta_s !== undefined ? ` · ETA ${clock(s.eta_s)}` : "";
    const failed = s.failed ? ` · ${s.failed} failed` : "";
    const error = s.error ? ` · ${s.error}` : "";
    $("#sweep-progress-text").textContent = `Sweep ${s.id} ${s.status}: ${s.done}/${s.total} runs${failed}${eta}${error}`;
    $("#sweep-cancel").hidden = !ACTIVE.has(s.status);
    $("#sweep-resume").hidden = !RESUMABLE.has(s.status);
    this.shown = s.id;
  }

  async command(verb) {
    const id = this.shown;
    if (id === undefined) return;
    try {
      const sweep = await post(`/sweeps/${encodeURIComponent(id)}/${verb}`);
      this.renderProgress(sweep);
      if (ACTIVE.has(sweep.status)) this.watch(id);
      await this.refresh();
    } catch (err) {
      toast(err.message, "error");
    }
  }
}
