// The live view's read-only state for tests and the curious: the canvas cannot be queried.

/** Install `window.__regolith`, reading `view` (a LiveView) on every access. */
export function exposeLive(view) {
  window.__regolith = {
    get missionId() {
      return view.id;
    },
    get status() {
      return view.status.status;
    },
    get policy() {
      return view.status.policy;
    },
    get frames() {
      return view.state.frames;
    },
    get lastCounters() {
      return { ...view.state.counters };
    },
    get t() {
      return view.state.t;
    },
    get map() {
      return view.state.map;
    },
    get robots() {
      return [...view.state.robots.values()].map((r) => ({ ...r }));
    },
    get auctions() {
      return [...view.feed.records.values()];
    },
    /** The charts' figures as last drawn: {t, delivered: [[t, n]], total, distance}. */
    get charts() {
      return view.charts.figures();
    },
    /** True once the view shows the stored ending (the record, not the stream). */
    get final() {
      return view.finalShown === view.id && view.id !== null;
    },
    /** The map as last drawn: robots bottom to top, labels and glyph boxes (CSS pixels). */
    get drawn() {
      return view.map.drawn ?? null;
    },
    /** The stream's own state (snapshot + deltas): {seq, t, status, policy, robots, counters, scanned_count}. */
    get stream() {
      const f = view.frames;
      return { seq: f.seq, ...f.head, robots: [...f.robots.values()].map((r) => ({ ...r })), counters: { ...f.counters }, scanned_count: f.scannedCount };
    },
    /** How many times the map was drawn (one per animation frame while anything moves). */
    get mapDraws() {
      return view.map.draws || 0;
    },
    /** Script time spent drawing the map, in total (ms). */
    get mapDrawMs() {
      return view.map.drawMs || 0;
    },
    pagePoint: (x, y) => view.map.pagePoint(x, y),
  };
}
