// A mission's status as the server reports it, and what it allows.
//
// The status comes only from the server's word on the mission: the snapshot's `mission`
// record, `status` messages and the answers to control calls. Frames never set it: they
// carry the engine's own view ("running" until the simulation ends), which knows nothing of
// the service's states (paused, interrupted), so a frame would overwrite the truth with a
// guess. This module shows the status (badge, notice, Resume) and enables the controls.

import { $, $$, toast } from "./dom.js";
import { get, isOperator, post } from "./api.js";
import { policyLabel } from "./policies.js";

/** A mission in one of these has ended for good: shown from its record, never resumed. */
export const ENDED = new Set(["completed", "timeout", "stopped", "stalled", "failed", "cancelled"]);
/** Only these take commands (policy, speed, stop, robots, tasks). */
export const LIVE = new Set(["running", "paused"]);
/** Rebuilt from its record by POST /api/missions/{id}/resume. */
export const RESUMABLE = new Set(["interrupted"]);

const ENDINGS = {
  completed: "every mineral was delivered",
  timeout: "it reached the scenario's time limit",
  stopped: "an operator stopped it",
  stalled: "it made no progress for the configured time",
  failed: "the simulation raised an error",
  cancelled: "it was cancelled",
};

/** The sentence under the toolbar for a status, or "" when the badge says enough. */
export function notice(status, { operator = false, error = null, field = false } = {}) {
  if (RESUMABLE.has(status) && field) {
    return "Interrupted: the server stopped while this field mission was live. Its robots were processes of that server and are gone, and a field run cannot be rebuilt by replay, so it cannot be resumed: this is its last stored state. Start a new field mission.";
  }
  if (RESUMABLE.has(status)) {
    const next = operator ? "Resume rebuilds it from its record and continues." : "An operator can resume it.";
    return `Interrupted: the server stopped while this mission was live, so it is frozen at its last stored state and takes no commands. ${next}`;
  }
  if (ENDED.has(status)) {
    const why = ENDINGS[status] || status;
    return `Ended (${status}): ${why}${status === "failed" && error ? ` (${error})` : ""}. This is its stored final state; it cannot be resumed.`;
  }
  return "";
}

const SETTLE_TRIES = 20;
const SETTLE_MS = 250;

export class MissionStatus {
  /**
   * missionId(): the mission shown (or null); onControls(operator, live): enable what works
   * now (the robot list's buttons, the task form); onEnded(simTime): the stored ending's time.
   */
  constructor({ missionId, onControls, onEnded }) {
    this.missionId = missionId;
    this.onControls = onControls;
    this.onEnded = onEnded;
    this.reset();
    this.resuming = false;
    this.settling = null;
    $("#resume-button").addEventListener("click", () => this.resume());
  }

  /** Nothing known yet (another mission is being opened). */
  reset() {
    this.status = "";
    this.policy = "";
    this.speed = null;
    this.error = null;
    this.field = false;
  }

  /** Apply what the server said: {status?, policy?, speed?, error?}. */
  set(m) {
    if (m.status) this.status = m.status;
    if (m.policy) this.policy = m.policy;
    if (m.speed !== undefined && m.speed !== null) this.speed = m.speed;
    if (m.error !== undefined) this.error = m.error;
    if (m.mode) this.field = m.mode === "field";
    $("#live-field").hidden = !this.field;
    const st = $("#live-status");
    st.textContent = this.status || "…";
    st.dataset.status = this.status;
    const pol = $("#live-policy");
    pol.dataset.policy = this.policy;
    pol.title = `Current policy: ${policyLabel(this.policy)}`;
    const sel = $("#policy-select");
    if (document.activeElement !== sel && this.policy) sel.value = this.policy;
    const paused = this.status === "paused" || String(this.speed) === "0";
    for (const b of $$("[data-speed]")) {
      const on = LIVE.has(this.status) && (paused ? b.dataset.speed === "0" : String(b.dataset.speed) === String(this.speed));
      b.setAttribute("aria-pressed", on ? "true" : "false");
    }
    this.apply();
  }

  /** Enable the controls that can work now: an operator's, on a live mission only. */
  apply() {
    const id = this.missionId();
    const status = this.status;
    const live = LIVE.has(status);
    const can = isOperator() && Boolean(id) && live;
    for (const el of $$("#live [data-control]")) {
      if (!el.closest("#robot-table") && el.id !== "resume-button") el.disabled = !can;
    }
    // a field mission's robots run on the wall clock × its speed: it pauses and takes a new
    // speed (its world service's clock, every agent's with it), but "max" means nothing there
    for (const b of $$("[data-speed]")) {
      const max = this.field && b.dataset.speed === "max";
      if (max) b.disabled = true;
      b.title = max ? "A field mission's robots run on the wall clock: no max speed" : "";
    }
    this.onControls(isOperator(), live);
    const resume = $("#resume-button");
    resume.hidden = !(isOperator() && RESUMABLE.has(status) && !this.field);
    resume.disabled = resume.hidden || this.resuming;
    resume.textContent = this.resuming ? "Resuming…" : "Resume";
    const box = $("#live-notice");
    const text = id ? notice(status, { operator: isOperator(), error: this.error, field: this.field }) : "";
    box.hidden = !text;
    box.dataset.status = status;
    if (box.textContent !== text) box.textContent = text;
  }

  /** Rebuild an interrupted mission by replay on the server and continue it live. */
  async resume() {
    const id = this.missionId();
    if (!id || this.resuming) return;
    this.resuming = true;
    this.apply();
    try {
      const m = await post(`/missions/${encodeURIComponent(id)}/resume`);
      if (id === this.missionId()) this.set({ status: m.status, policy: m.policy, speed: m.speed });
      toast(`Mission ${id} resumed`);
    } catch (err) {
      toast(`Resume: ${err.message}`, "error");
      this.settle(() => true); // whatever happened, show what the record now says
    } finally {
      this.resuming = false;
      if (id === this.missionId()) this.apply();
    }
  }

  /**
   * The stream said the mission ended: show the ending as stored (status, error, final
   * simulation time) once the record holds it, rather than the last frame's guess.
   * `ready(record)` says when the record is there (by default: it holds an ending).
   */
  settle(ready = (m) => ENDED.has(m.status)) {
    const id = this.missionId();
    if (!id || this.settling === id) return;
    this.settling = id;
    const path = `/missions/${encodeURIComponent(id)}`;
    const attempt = async (left) => {
      if (id !== this.missionId()) return;
      let m = null;
      try {
        m = await get(path);
      } catch {
        /* retried below */
      }
      if (id !== this.missionId()) return;
      if ((m && ready(m)) || left <= 0) {
        this.settling = null;
        if (!m) return;
        this.set({ status: m.status, policy: m.policy, error: m.error });
        if (ENDED.has(m.status)) this.onEnded(m.sim_time);
        return;
      }
      setTimeout(() => attempt(left - 1), SETTLE_MS);
    };
    attempt(SETTLE_TRIES);
  }
}
