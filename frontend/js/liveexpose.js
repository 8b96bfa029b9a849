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
    pagePoint: (x, y) => view.map.pagePoint(x, y),
  };
}
