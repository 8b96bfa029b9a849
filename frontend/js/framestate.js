// The live stream's frames as the server sent them (docs/service.md, "Live stream"): a
// snapshot, then deltas applied in order. A delta that does not follow on from the last
// one applied (`base` is not our `seq`) is refused: the caller asks for a full frame.

const FRAME_FIELDS = ["name", "type", "state", "x", "y", "heading", "load", "alive", "charge"];

function decode(b64) {
  try {
    return Uint8Array.from(atob(b64 || ""), (c) => c.charCodeAt(0));
  } catch {
    return new Uint8Array(0);
  }
}

function pick(r) {
  const out = {};
  for (const k of FRAME_FIELDS) if (k in r) out[k] = r[k];
  return out;
}

export class FrameState {
  constructor() {
    this.reset();
  }

  reset() {
    this.seq = null;
    this.head = {};
    this.robots = new Map(); // name -> frame fields, in index order
    this.names = []; // index -> name
    this.scanned = new Uint8Array(0);
    this.scannedCount = 0;
    this.scannedDirty = false; // scanned changed since the last view()
    this.counters = {};
  }

  /** A snapshot message ({seq, state}); state may be null (a crashed mission's record). */
  snapshot(msg) {
    this._whole(msg.state || { robots: [] }, msg.seq ?? null);
  }

  _whole(s, seq) {
    this.seq = seq;
    this.head = { t: s.t, status: s.status, policy: s.policy };
    this.robots = new Map(s.robots.map((r) => [r.name, pick(r)]));
    this.names = [...this.robots.keys()];
    this.scanned = decode(s.scanned);
    this.scannedCount = s.scanned_count ?? 0;
    this.scannedDirty = true;
    this.counters = { ...(s.counters || {}) };
  }

  /** Apply a frame message; false (nothing applied) when it does not follow on. */
  apply(f) {
    if (f.full) {
      this._whole(f, f.seq);
      return true;
    }
    if (this.seq === null || f.base !== this.seq) return false;
    this.seq = f.seq;
    this.head = { t: f.t, status: f.status, policy: f.policy };
    for (const r of f.robots) {
      if (!this.robots.has(r.name)) this.names.push(r.name);
      this.robots.set(r.name, pick(r));
    }
    const p = f.poses || [];
    for (let j = 0; j < p.length; j += 4) {
      const r = this.robots.get(this.names[p[j]]);
      r.x = p[j + 1];
      r.y = p[j + 2];
      r.heading = p[j + 3];
    }
    Object.assign(this.counters, f.counters || {});
    const cells = f.scanned_new || [];
    if (cells.length) {
      const need = (cells.reduce((a, b) => (b > a ? b : a), 0) >> 3) + 1;
      if (need > this.scanned.length) {
        const grown = new Uint8Array(need);
        grown.set(this.scanned);
        this.scanned = grown;
      }
      for (const c of cells) this.scanned[c >> 3] |= 1 << (c & 7);
      this.scannedDirty = true;
    }
    this.scannedCount = f.scanned_count;
    return true;
  }

  /** The state as one full frame for the view: {t, status, policy, robots, scanned_count,
   * counters, scannedBits (only when it changed since the last call)}. */
  view() {
    const out = { ...this.head, robots: [...this.robots.values()], scanned_count: this.scannedCount, counters: this.counters };
    if (this.scannedDirty) out.scannedBits = this.scanned;
    this.scannedDirty = false;
    return out;
  }
}
