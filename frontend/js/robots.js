// The robot list: name, type, state, task, load, charge, distance, with Disable / Fail / Enable.
// Rows are updated in place so keyboard focus survives the 10 Hz frames. Past VIRTUAL_FROM
// robots the list is virtualized (virtual.js): only the rows in view are in the DOM.

import { h, fmt } from "./dom.js";
import { glyph, robotType } from "./palette.js";
import { VirtualRows } from "./virtual.js";

export const VIRTUAL_FROM = 80;
const ROW_PX = 27; // a row's height in the compact table (CSS pins it when virtualized)

const DOWN = new Set(["failed", "disabled"]);
const ORDER = { scout: 0, excavator: 1, hauler: 2 };

const KEYS = new Map(); // name -> [type order, number]: computed once per robot
function sortKey(r) {
  let k = KEYS.get(r.name);
  if (!k) KEYS.set(r.name, (k = [ORDER[robotType(r)] ?? 9, Number(/\d+$/.exec(r.name)?.[0] ?? 0)]));
  return k;
}

function byName(a, b) {
  const [ta, na] = sortKey(a);
  const [tb, nb] = sortKey(b);
  return ta - tb || na - nb || a.name.localeCompare(b.name);
}

export class RobotTable {
  constructor(tbody, countEl, { onAction }) {
    this.tbody = tbody;
    this.countEl = countEl;
    this.onAction = onAction;
    this.rows = new Map(); // name -> {tr, cells, buttons, type}
    this.canControl = false;
    this.finished = false;
    this.sorted = [];
    this.names = ""; // the names last sorted, joined: the order is kept until they change
    this.virtual = null;
  }

  reset() {
    this.rows.clear();
    this.sorted = [];
    this.names = "";
    this.virtual = null;
    this.tbody.closest("table")?.classList.remove("virtual");
    this.tbody.replaceChildren();
  }

  setControl(canControl, finished) {
    this.canControl = canControl;
    this.finished = finished;
    for (const row of this.rows.values()) this._buttons(row);
  }

  /** robots: frame dicts (name, type, state, load, alive), merged with `detail` (the robot
   * list's task, distance, enabled by name) for the rows that are filled. */
  update(robots, detail = null) {
    this.detail = detail;
    const key = robots.map((r) => r.name).join(",");
    let changedOrder = key !== this.names;
    if (changedOrder) {
      if (!robots.some((r) => r.charge != null)) this.tbody.closest("table")?.classList.remove("with-charge");
      this.names = key;
      this.sorted = [...robots].sort(byName);
    } else {
      const by = new Map(robots.map((r) => [r.name, r]));
      this.sorted = this.sorted.map((r) => by.get(r.name));
    }
    const sorted = this.sorted;
    if (sorted.length > VIRTUAL_FROM) return this._virtual(sorted);
    if (this.virtual) {
      this.virtual = null;
      this.tbody.closest("table")?.classList.remove("virtual");
      changedOrder = true;
    }
    const names = new Set();
    for (const r of sorted) {
      names.add(r.name);
      let row = this.rows.get(r.name);
      if (!row) {
        row = this._row(r);
        this.rows.set(r.name, row);
        changedOrder = true;
      }
      this._fill(row, this._merged(r));
    }
    for (const name of [...this.rows.keys()]) {
      if (!names.has(name)) {
        this.rows.get(name).tr.remove();
        this.rows.delete(name);
        changedOrder = true;
      }
    }
    if (changedOrder) this.tbody.replaceChildren(...sorted.map((r) => this.rows.get(r.name).tr));
    this._count(sorted);
    return undefined;
  }

  /** Many robots: rows only for those in view (built on first sight, then kept and refilled). */
  _virtual(sorted) {
    if (!this.virtual) {
      const table = this.tbody.closest("table");
      table.classList.add("virtual");
      this.headPx = table.tHead?.offsetHeight ?? 0; // read once: no layout on every frame
      this.virtual = new VirtualRows({
        scroller: table.parentElement,
        body: this.tbody,
        spacer: (px) => h("tr", { class: "spacer", style: `height:${px}px` }, h("td", { colspan: "7" })),
        rowHeight: ROW_PX,
        offset: () => this.headPx,
        render: (i) => {
          const r = this.sorted[i];
          let row = this.rows.get(r.name);
          if (!row) this.rows.set(r.name, (row = this._row(r)));
          this._fill(row, this._merged(r));
          return row.tr;
        },
      });
    }
    this.virtual.update(sorted.length);
    this._count(sorted);
  }

  _merged(r) {
    const d = this.detail?.get(r.name);
    return d ? { ...d, ...r } : r;
  }

  _count(sorted) {
    let down = 0;
    for (const r of sorted) if (DOWN.has(r.state)) down += 1;
    this.countEl.textContent = `${sorted.length}${down ? ` · ${down} down` : ""}`;
  }

  _row(r) {
    const type = robotType(r);
    const cells = {
      name: h("td", {}, glyph(type), r.name),
      state: h("td", {}, h("span", { class: "state" })),
      task: h("td", { class: "task" }),
      load: h("td", { class: "num" }),
      charge: h("td", { class: "num charge" }),
      dist: h("td", { class: "num" }),
    };
    const mk = (action, text, title) =>
      h("button", { type: "button", class: "btn", dataset: { action, control: "" }, title, "aria-label": `${title}: ${r.name}`, onclick: () => this.onAction(r.name, action) }, text);
    const buttons = {
      disable: mk("disable", "Disable", "Disable gracefully (finishes nothing new)"),
      fail: mk("fail", "Fail", "Fail abruptly (stops where it is)"),
      enable: mk("enable", "Enable", "Enable again"),
    };
    const tr = h("tr", { dataset: { robot: r.name, type } }, cells.name, cells.state, cells.task, cells.load, cells.charge, cells.dist, h("td", { class: "acts" }, buttons.disable, buttons.fail, buttons.enable));
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
    // battery charge (scenarios with energy on; docs/model.md#energy)
    setText(row.cells.charge, r.charge === undefined || r.charge === null ? "" : `${Math.round(r.charge * 100)}%`);
    row.tr.dataset.charge = r.charge ?? "";
    if (r.charge !== undefined && r.charge !== null) this.tbody.closest("table")?.classList.add("with-charge");
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
