// The operator's controls in the live view: policy, speed, stop, robots, injected tasks.
// It knows the live view only through the callbacks it is given.

import { $, $$, fmt, toast } from "./dom.js";
import { isOperator, post, put } from "./api.js";
import { policyLabel } from "./policies.js";
import { ENDED, LIVE } from "./status.js";

export class Controls {
  /**
   * mission(): the mission shown, as the server last said: {id, status, policy, speed, map};
   * onStatus(m): a control call's answer (MissionRead: status, policy, speed);
   * onRobotsChanged(): a robot was added, disabled or enabled;
   * showPick({x, y} | null): mark (or unmark) the point about to get a task;
   * toScreen(x, y): the map point's pixel in the map's box, [sx, sy].
   */
  constructor({ mission, onStatus, onRobotsChanged, showPick, toScreen }) {
    this.mission = mission;
    this.onStatus = onStatus;
    this.onRobotsChanged = onRobotsChanged;
    this.showPick = showPick;
    this.toScreen = toScreen;
    this.form = $("#inject-form");
    this._bindMission();
    this._bindRobots();
    this._bindInject();
  }

  _path(suffix = "") {
    return `/missions/${encodeURIComponent(this.mission().id)}${suffix}`;
  }

  async _run(label, fn) {
    if (!isOperator()) {
      toast("Read-only: enter an operator token first.", "error");
      return undefined;
    }
    try {
      return await fn();
    } catch (err) {
      toast(`${label}: ${err.message}`, "error");
      return undefined;
    }
  }

  _bindMission() {
    const policySel = $("#policy-select");
    policySel.addEventListener("change", async () => {
      const policy = policySel.value;
      const res = await this._run("Policy", () => put(this._path("/policy"), { policy }));
      if (res) {
        this.onStatus({ policy: res.policy });
        toast(`Policy switched to ${policyLabel(res.policy)}`);
      } else {
        policySel.value = this.mission().policy;
      }
    });

    // speed: pause, 1×, 10×, 100×, max
    for (const b of $$("[data-speed]")) {
      b.addEventListener("click", async () => {
        const raw = b.dataset.speed;
        const res = await this._run("Speed", async () => {
          if (raw === "0") return post(this._path("/pause"));
          const speed = raw === "max" ? "max" : Number(raw);
          const out = await put(this._path("/speed"), { speed });
          if (this.mission().status === "paused") return post(this._path("/resume"));
          return out;
        });
        // a paused mission keeps (and answers) the speed it will resume at
        if (res) this.onStatus({ status: res.status, speed: res.speed });
      });
    }

    $("#stop-button").addEventListener("click", async () => {
      if (!window.confirm(`Stop mission ${this.mission().id}? It cannot be resumed.`)) return;
      const res = await this._run("Stop", () => post(this._path("/stop")));
      if (res) this.onStatus({ status: res.status });
    });
  }

  _bindRobots() {
    $("#add-robot-form").addEventListener("submit", async (e) => {
      e.preventDefault();
      const type = $("#add-robot-type").value;
      const res = await this._run("Add robot", () => post(this._path("/robots"), { type }));
      if (res !== undefined) {
        toast(`Added ${res.name}`);
        this.onRobotsChanged();
      }
    });
  }

  /** A robot row's button: disable (graceful), fail (abrupt) or enable. */
  async robotAction(name, action) {
    const n = encodeURIComponent(name);
    const call = {
      disable: () => post(this._path(`/robots/${n}/disable`), { mode: "graceful" }),
      fail: () => post(this._path(`/robots/${n}/disable`), { mode: "abrupt" }),
      enable: () => post(this._path(`/robots/${n}/enable`)),
    }[action];
    const res = await this._run(`${action} ${name}`, call);
    if (res !== undefined) {
      toast(`${name}: ${action === "fail" ? "failed abruptly" : action === "disable" ? "disabled" : "enabled"}`);
      this.onRobotsChanged();
    }
  }

  // inject an excavate task: click the map (or the button), confirm in the popover
  _bindInject() {
    const form = this.form;
    for (const input of [form.x, form.y]) {
      input.addEventListener("input", () => {
        const x = Number(form.x.value);
        const y = Number(form.y.value);
        if (Number.isFinite(x) && Number.isFinite(y)) this.showPick({ x, y });
      });
    }
    $("#inject-cancel").addEventListener("click", () => {
      this.closePick();
      $("#map").focus();
    });
    form.addEventListener("keydown", (e) => {
      if (e.key === "Escape") this.closePick();
    });
    form.addEventListener("submit", async (e) => {
      e.preventDefault();
      const location = [Number(form.x.value), Number(form.y.value)];
      const res = await this._run("Inject task", () => post(this._path("/tasks"), { type: "excavate", location }));
      if (res !== undefined) {
        toast(`Excavate task injected at (${fmt(location[0])}, ${fmt(location[1])}): auction ${res.auction_id}`);
        this.closePick();
      }
    });
    $("#inject-open").addEventListener("click", () => {
      const m = this.mission().map;
      if (m) this.pick(m.plant.x + 10, m.plant.y);
    });
  }

  /** The operator picked map point (x, y): open the task form there. */
  pick(x, y) {
    const { map, status } = this.mission();
    if (!map) return;
    if (!isOperator() || !LIVE.has(status)) {
      if (ENDED.has(status)) toast("The mission has ended; it takes no new tasks.");
      else if (!isOperator()) toast("Read-only: enter an operator token to inject tasks.");
      else toast(`The mission is ${status || "not live yet"}; it takes no tasks until it runs again.`);
      return;
    }
    const form = this.form;
    const wrap = $("#map-stage"); // the canvas's own box: the form is placed in it
    form.x.value = fmt(x, 1);
    form.y.value = fmt(y, 1);
    this.showPick({ x, y });
    const [sx, sy] = this.toScreen(x, y);
    form.hidden = false;
    const w = form.offsetWidth;
    const hgt = form.offsetHeight;
    form.style.left = `${Math.min(wrap.clientWidth - w - 8, Math.max(8, sx + 12))}px`;
    form.style.top = `${Math.min(wrap.clientHeight - hgt - 8, Math.max(8, sy - hgt / 2))}px`;
    const submit = form.querySelector("button[type=submit]");
    (submit.disabled ? form.x : submit).focus({ preventScroll: true });
  }

  closePick() {
    this.form.hidden = true;
    this.showPick(null);
  }
}
