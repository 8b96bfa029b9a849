// The robot list: name, type, state, task, load, distance, with Disable / Fail / Enable.
// Rows are updated in place so keyboard focus survives the 10 Hz frames.

import { h, fmt } from "./dom.js";
import { glyph, robotType } from "./palette.js";

const DOWN = new Set(["failed", "disabled"]);
const ORDER = { scout: 0, excavator: 1, hauler: 2 };

function byName(a, b) {
  const ta = ORDER[robotType(a)] ?? 9;
  const tb = ORDER[robotType(b)] ?? 9;
  if (ta !== tb) return ta - tb;
  const na = Number(/\d+$/.exec(a.name)?.[0] ?? 0);
  const nb = Number(/\d+$/.exec(b.name)?.[0] ?? 0);
  return na - nb || a.name.localeCompare(b.name);
}

export class RobotTable {
  constructor(tbody, countEl, { onAction }) {
    this.tbody = tbody;
    this.countEl = countEl;
    this.onAction = onAction;
    this.rows = new Map(); // name -> {tr, cells, buttons, type}
    this.canControl = false;
    this.finished = false;
  }

  reset() {
    this.rows.clear();
    this.tbody.replaceChildren();
  }

  setControl(canControl, finished) {
    this.canControl = canControl;
    this.finished = finished;
    for (const row of this.rows.values()) this._buttons(row);
  }

  /** robots: merged frame + detail dicts (name, type, state, task, load, distance, alive, enabled). */
  update(robots) {
    const sorted = [...robots].sort(byName);
    let changedOrder = sorted.length !== this.rows.size;
    for (const r of sorted) {
      let row = this.rows.get(r.name);
      if (!row) {
        row = this._row(r);
        this.rows.set(r.name, row);
        changedOrder = true;
      }
      this._fill(row, r);
    }
    for (const name of [...this.rows.keys()]) {
      if (!sorted.some((r) => r.name === name)) {
        this.rows.get(name).tr.remove();
        this.rows.delete(name);
        changedOrder = true;
      }
    }
    if (changedOrder) this.tbody.replaceChildren(...sorted.map((r) => this.rows.get(r.name).tr));
    const down = sorted.filter((r) => DOWN.has(r.state)).length;
    this.countEl.textContent = `${sorted.length}${down ? ` · ${down} down` : ""}`;
  }

  _row(r) {
    const type = robotType(r);
    const cells = {
      name: h("td", {}, glyph(type), r.name),
      state: h("td", {}, h("span", { class: "state" })),
      task: h("td", { class: "task" }),
      load: h("td", { class: "num" }),
      dist: h("td", { class: "num" }),
    };
    const mk = (action, text, title) =>
      h("button", { type: "button", class: "btn", dataset: { action, control: "" }, title, "aria-label": `${title}: ${r.name}`, onclick: () => this.onAction(r.name, action) }, text);
    const buttons = {
      disable: mk("disable", "Disable", "Disable gracefully (finishes nothing new)"),
      fail: mk("fail", "Fail", "Fail abruptly (stops where it is)"),
      enable: mk("enable", "Enable", "Enable again"),
    };
    const tr = h("tr", { dataset: { robot: r.name, type } }, cells.name, cells.state, cells.task, cells.load, cells.dist, h("td", { class: "acts" }, buttons.disable, buttons.fail, buttons.enable));
    return { tr, cells, buttons, type, state: null };
  }

  _fill(row, r) {
    const state = r.alive === false && r.state !== "disabled" ? "failed" : r.state;
    // a gracefully disabled robot finishes its hand-over first: alive, but no longer enabled
    const leaving = r.alive !== false && r.enabled === false && !DOWN.has(state);
    if (row.state !== state || row.leaving !== leaving) {
      row.state = state;
      row.leaving = leaving;
      row.tr.dataset.state = state;
      row.tr.dataset.leaving = leaving ? "true" : "false";
      const badge = row.cells.state.firstChild;
      badge.dataset.state = state;
      badge.textContent = leaving ? `${state} · leaving` : state;
      badge.title = leaving ? "Disabled: finishing its current hand-over, then it stops" : "";
      this._buttons(row);
    }
    setText(row.cells.task, shortTask(r.task));
    row.cells.task.title = r.task || "";
    setText(row.cells.load, r.load ?? "");
    setText(row.cells.dist, r.distance === undefined ? "" : fmt(r.distance, 0));
    row.tr.dataset.distance = r.distance ?? ""; // exact, for tests (the cell is rounded)
    row.tr.dataset.task = r.task ?? "";
  }

  _buttons(row) {
    const down = DOWN.has(row.state) || row.leaving;
    const off = !this.canControl || this.finished;
    // an active robot offers Disable and Fail; a robot that is down offers Enable
    row.buttons.disable.hidden = down;
    row.buttons.fail.hidden = down;
    row.buttons.enable.hidden = !down;
    row.buttons.disable.disabled = off || down;
    row.buttons.fail.disabled = off || down;
    row.buttons.enable.disabled = off || !down;
  }
}

/** "excavate@(75.7,73.9)" -> "dig 75.7,73.9"; the full text stays in the tooltip. */
export function shortTask(task) {
  if (!task) return "";
  const m = /^(\w+)@\(?([^)]*)\)?$/.exec(task);
  if (!m) return task;
  const verb = { excavate: "dig", transport: "haul", localize: "scan" }[m[1]] || m[1];
  return `${verb} ${m[2]}`;
}

function setText(el, value) {
  const s = String(value);
  if (el.textContent !== s) el.textContent = s;
}
