// The playback timeline: play/pause, speed, a scrubber over the mission's simulated time with
// markers (failures, operator actions, policy switches, site discoveries), and "back to live".
// It only draws and reports: the Playback controller (playback.js) decides what to show.

import { clock, h } from "./dom.js";

export const SPEEDS = [1, 10, 60, 300];

/** Marker kinds: colour (Okabe–Ito) and a glyph, so they differ without colour too. */
export const MARK = {
  failure: { label: "failure", glyph: "✕", colour: "#d55e00" },
  operator: { label: "operator action", glyph: "◆", colour: "#56b4e9" },
  policy: { label: "policy switch", glyph: "▲", colour: "#cc79a7" },
  site: { label: "site found", glyph: "●", colour: "#f0e442" },
};

/** Where a moment shown comes from, said on the timeline (its accessible description) and,
 * for a field run, in a small note beside it: a simulated mission is replayed, a field run
 * cannot be. (Not a title on the whole timeline: it would pop up over the slider.) */
export const SOURCE = {
  replay: "Playback: the server rebuilds each moment by replaying the mission (exact)",
  poses:
    "Playback of a field run: its robots were real processes and cannot be re-simulated, so each moment is drawn from the poses they reported every 5 s of mission time (on the straight line between two) and the stored events",
};

/** Each kind on a row of its own, so markers at one time do not hide each other. */
const ROW = { failure: 0, policy: 1, operator: 2, site: 3 };

export class Timeline {
  /** onSeek(t) (scrub, marker, keys), onPlay(), onPause(), onSpeed(x), onLatest(). */
  constructor(host, { onSeek, onPlay, onPause, onSpeed, onLatest }) {
    this.end = 0;
    this.marks = [];
    this.playing = false;
    this.dragging = false; // the scrubber's value is the user's while the pointer holds it
    this.range = h("input", {
      type: "range",
      id: "tl-range",
      min: "0",
      max: "0",
      step: "any",
      value: "0",
      "aria-label": "Simulated time",
      oninput: () => onSeek(Number(this.range.value)),
      onpointerdown: () => (this.dragging = true),
    });
    window.addEventListener("pointerup", () => (this.dragging = false));
    this.play = h("button", { type: "button", class: "btn small", id: "tl-play", onclick: () => (this.playing ? onPause() : onPlay()) }, "▶ Play");
    this.speed = h(
      "select",
      { id: "tl-speed", "aria-label": "Playback speed", onchange: () => onSpeed(Number(this.speed.value)) },
      SPEEDS.map((x) => h("option", { value: String(x), selected: x === 10 }, `${x}×`)),
    );
    this.markLayer = h("div", { class: "tl-marks", "aria-label": "Markers" });
    this.time = h("output", { id: "tl-time", class: "tl-time" }, "–");
    this.latest = h("button", { type: "button", class: "btn small primary", id: "tl-latest", onclick: () => onLatest() }, "Back to live");
    this.why = h("p", { id: "tl-why", class: "tl-why", hidden: true });
    this.note = h("span", { id: "tl-source", class: "badge field tl-source", title: SOURCE.poses, hidden: true }, "field: stored poses");
    this.el = h(
      "section",
      { id: "timeline", class: "timeline", "aria-label": "Mission playback", "aria-description": SOURCE.replay, dataset: { mode: "latest", t: "", end: "0", shownT: "", source: "replay" } },
      this.note,
      this.play,
      this.speed,
      h("div", { class: "tl-track" }, this.range, this.markLayer),
      this.time,
      this.latest,
      this.why,
    );
    host.after(this.el);
  }

  /** Off (with the reason shown in its place) or on again (reason null): a mission that
   * cannot be looked back at gets a timeline that says so instead of one that answers 409. */
  setDisabled(reason) {
    const off = Boolean(reason);
    this.disabled = off;
    for (const el of [this.range, this.play, this.speed]) el.disabled = off;
    this.markLayer.inert = off;
    this.el.classList.toggle("off", off);
    this.why.hidden = !off;
    this.why.textContent = reason || "";
    if (off) this.el.dataset.disabled = "true";
    else delete this.el.dataset.disabled;
  }

  /** "replay" (a simulated mission) or "poses" (a field run's stored poses): said, not acted on. */
  setSource(source) {
    this.el.dataset.source = source;
    this.el.setAttribute("aria-description", SOURCE[source]);
    this.note.hidden = source !== "poses";
  }

  /** The timeline's end: the mission's simulated time (grows while it is live). */
  setEnd(end) {
    if (!(end >= 0) || end === this.end) return;
    this.end = end;
    this.range.max = String(end);
    this.el.dataset.end = String(end);
    for (const m of this.marks) m.el.style.left = this._left(m.t);
    this._label();
  }

  /** The time the scrubber shows (not necessarily rendered yet). */
  setTime(t) {
    if (!this.dragging) this.range.value = String(t);
    this.t = t;
    this.el.dataset.t = String(t);
    this._label();
  }

  /** A state at `t` is on screen (tests wait for this). */
  shown(t, policy) {
    this.el.dataset.shownT = String(t);
    this.policy = policy;
    this._label();
  }

  /** "latest": following the stream (or the final state); "back": showing an earlier moment. */
  setMode(mode, latestLabel) {
    this.el.dataset.mode = mode;
    // out of sight but in its place while idle (see playback.css): the slider keeps its width
    this.latest.classList.toggle("idle", mode !== "back");
    this.latest.setAttribute("aria-hidden", String(mode !== "back"));
    this.latest.tabIndex = mode === "back" ? 0 : -1;
    this.latest.textContent = latestLabel;
    this._label();
  }

  setPlaying(playing) {
    this.playing = playing;
    this.play.textContent = playing ? "❚❚ Pause" : "▶ Play";
    this.play.setAttribute("aria-pressed", String(playing));
  }

  /** [{t, kind: failure|operator|policy|site, text}] → markers a click seeks to. */
  setMarkers(list, onSeek) {
    this.marks = list.map((m) => {
      const look = MARK[m.kind];
      const el = h(
        "button",
        {
          type: "button",
          class: "tl-mark",
          dataset: { kind: m.kind, t: String(m.t) },
          title: `${clock(m.t)} · ${look.label}: ${m.text}`,
          "aria-label": `${look.label} at ${clock(m.t)}: ${m.text}`,
          style: `left:${this._left(m.t)};color:${look.colour};top:${ROW[m.kind] * 8}px`,
          onclick: () => onSeek(m.t),
        },
        look.glyph,
      );
      return { ...m, el };
    });
    this.markLayer.replaceChildren(...this.marks.map((m) => m.el));
    this.el.dataset.markers = String(this.marks.length);
  }

  _left(t) {
    return `${this.end > 0 ? Math.min(100, (100 * t) / this.end) : 0}%`;
  }

  _label() {
    const back = this.el.dataset.mode === "back";
    const policy = back && this.policy ? ` · ${this.policy}` : "";
    this.time.textContent = `${back ? "looking back at " : ""}${clock(this.t)} / ${clock(this.end)}${policy}`;
    this.time.title = this.time.textContent;
  }
}
