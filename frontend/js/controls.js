// The operator's controls in the live view: policy, speed, stop, robots, injected tasks.

import { $, $$, fmt, toast } from "./dom.js";
import { isOperator, post, put } from "./api.js";
import { policyLabel } from "./policies.js";

export function bindControls(view) {
  const path = (suffix = "") => `/missions/${encodeURIComponent(view.id)}${suffix}`;

  async function run(label, fn) {
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

  // policy
  const policySel = $("#policy-select");
  policySel.addEventListener("change", async () => {
    const policy = policySel.value;
    const res = await run("Policy", () => put(path("/policy"), { policy }));
    if (res) {
      view._status({ policy: res.policy || policy });
      toast(`Policy switched to ${policyLabel(policy)}`);
    } else {
      policySel.value = view.state.policy;
    }
  });

  // speed: pause, 1×, 10×, 100×, max
  for (const b of $$("[data-speed]")) {
    b.addEventListener("click", async () => {
      const raw = b.dataset.speed;
      const res = await run("Speed", async () => {
        if (raw === "0") return post(path("/pause"));
        const speed = raw === "max" ? "max" : Number(raw);
        const out = await put(path("/speed"), { speed });
        if (view.state.status === "paused") return post(path("/resume"));
        return out;
      });
      if (res) view._status({ status: res.status, speed: raw === "0" ? view.state.speed : (res.speed ?? raw) });
    });
  }

  $("#stop-button").addEventListener("click", async () => {
    if (!window.confirm(`Stop mission ${view.id}? It cannot be resumed.`)) return;
    const res = await run("Stop", () => post(path("/stop")));
    if (res) view._status({ status: res.status || "stopped" });
  });

  // robots
  async function robotAction(name, action) {
    const n = encodeURIComponent(name);
    const call = {
      disable: () => post(path(`/robots/${n}/disable`), { mode: "graceful" }),
      fail: () => post(path(`/robots/${n}/disable`), { mode: "abrupt" }),
      enable: () => post(path(`/robots/${n}/enable`)),
    }[action];
    const res = await run(`${action} ${name}`, call);
    if (res !== undefined) {
      toast(`${name}: ${action === "fail" ? "failed abruptly" : action === "disable" ? "disabled" : "enabled"}`);
      view._refreshDetail();
    }
  }

  $("#add-robot-form").addEventListener("submit", async (e) => {
    e.preventDefault();
    const type = $("#add-robot-type").value;
    const res = await run("Add robot", () => post(path("/robots"), { type }));
    if (res !== undefined) {
      toast(`Added ${res?.name || `a ${type}`}`);
      view._refreshDetail();
    }
  });

  // inject an excavate task: click the map (or the button), confirm in the popover
  const form = $("#inject-form");
  const wrap = $("#map-wrap");

  function pick(x, y) {
    if (!view.state.map) return;
    if (!isOperator() || !view.live) {
      if (view.finished) toast("The mission has ended; it takes no new tasks.");
      else if (!isOperator()) toast("Read-only: enter an operator token to inject tasks.");
      else toast(`The mission is ${view.state.status || "not live yet"}; it takes no tasks until it runs again.`);
      return;
    }
    form.x.value = fmt(x, 1);
    form.y.value = fmt(y, 1);
    view.map.setPick({ x, y });
    const [sx, sy] = view.map.toScreen(x, y);
    form.hidden = false;
    const w = form.offsetWidth;
    const hgt = form.offsetHeight;
    form.style.left = `${Math.min(wrap.clientWidth - w - 8, Math.max(8, sx + 12))}px`;
    form.style.top = `${Math.min(wrap.clientHeight - hgt - 8, Math.max(8, sy - hgt / 2))}px`;
    const submit = form.querySelector("button[type=submit]");
    (submit.disabled ? form.x : submit).focus({ preventScroll: true });
  }

  function closePick() {
    form.hidden = true;
    view.map.setPick(null);
  }

  for (const input of [form.x, form.y]) {
    input.addEventListener("input", () => {
      const x = Number(form.x.value);
      const y = Number(form.y.value);
      if (Number.isFinite(x) && Number.isFinite(y)) view.map.setPick({ x, y });
    });
  }
  $("#inject-cancel").addEventListener("click", () => {
    closePick();
    $("#map").focus();
  });
  form.addEventListener("keydown", (e) => {
    if (e.key === "Escape") closePick();
  });
  form.addEventListener("submit", async (e) => {
    e.preventDefault();
    const location = [Number(form.x.value), Number(form.y.value)];
    const res = await run("Inject task", () => post(path("/tasks"), { type: "excavate", location }));
    if (res !== undefined) {
      const id = res?.auction_id || res?.id || "";
      toast(`Excavate task injected at (${fmt(location[0])}, ${fmt(location[1])})${id ? `: auction ${id}` : ""}`);
      closePick();
    }
  });
  $("#inject-open").addEventListener("click", () => {
    const m = view.state.map;
    if (m) pick(m.plant.x + 10, m.plant.y);
  });

  return { pick, robotAction, closePick };
}
