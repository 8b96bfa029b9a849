// Hand-drawn SVG charts: a step/line chart, grouped bars, and a strip (dot) plot.

const NS = "http://www.w3.org/2000/svg";
const PAD = { l: 34, r: 8, t: 8, b: 18 };

function svgEl(tag, attrs = {}, text) {
  const el = document.createElementNS(NS, tag);
  for (const [k, v] of Object.entries(attrs)) el.setAttribute(k, v);
  if (text !== undefined) el.textContent = text;
  return el;
}

/** The chart's SVG; `lines` x-label lines (1 or 2) are kept clear below the plot. */
function frame(container, lines = 1) {
  const w = Math.max(160, container.clientWidth || 300);
  const hgt = Math.max(80, container.clientHeight || 120);
  const svg = svgEl("svg", { viewBox: `0 0 ${w} ${hgt}`, role: "img" });
  container.replaceChildren(svg);
  const b = PAD.b + (lines - 1) * 11;
  return { svg, w, hgt, b, iw: w - PAD.l - PAD.r, ih: hgt - PAD.t - b };
}

let measurer = null;
/** Width of `text` in the charts' 10 px font. */
export function textWidth(text) {
  measurer ||= document.createElement("canvas").getContext("2d");
  measurer.font = "10px system-ui, sans-serif";
  return measurer.measureText(text).width;
}

/**
 * `text` as at most two lines no wider than `max`: on one line, else split at its last space,
 * else the same with `abbr` (a shorter name), else cut with "…".
 */
export function fitLabel(text, max, abbr) {
  const fits = (t) => textWidth(t) <= max;
  const split = (t) => {
    const at = t.lastIndexOf(" ");
    return at > 0 ? [t.slice(0, at), t.slice(at + 1)] : [t];
  };
  for (const t of abbr ? [text, abbr] : [text]) {
    if (fits(t)) return [t];
    if (split(t).every(fits)) return split(t);
  }
  const cut = (t) => {
    if (fits(t)) return t;
    let n = t.length;
    while (n > 1 && !fits(`${t.slice(0, n)}…`)) n -= 1;
    return `${t.slice(0, n)}…`;
  };
  return split(abbr || text).map(cut);
}

/** Fitted x labels of one width (with their short forms): their lines, and the most lines any needs. */
function fitAll(labels, max, abbrs = []) {
  const fitted = labels.map((t, i) => fitLabel(t, max, abbrs[i]));
  return { fitted, lines: Math.max(1, ...fitted.map((f) => f.length)) };
}

/** An x label under the plot (its full text in a tooltip when cut or wrapped). */
function xLabel(svg, x, top, lines, full) {
  const t = svgEl("text", { x, y: top, "text-anchor": "middle", class: "xlabel" });
  lines.forEach((line, i) => t.append(svgEl("tspan", { x, dy: i ? 11 : 0 }, line)));
  if (lines.join(" ") !== full) t.append(svgEl("title", {}, full));
  svg.append(t);
}

/** Round numbers for axis ticks: 0, step, 2·step … ≥ max. */
export function niceTicks(max, count = 4) {
  if (!(max > 0)) return [0, 1];
  const raw = max / count;
  const mag = 10 ** Math.floor(Math.log10(raw));
  const step = [1, 2, 2.5, 5, 10].map((m) => m * mag).find((s) => s >= raw) || raw;
  const ticks = [];
  for (let v = 0; v <= max + step * 0.999; v += step) ticks.push(+v.toPrecision(6));
  return ticks;
}

const TIME_STEPS = [1, 2, 5, 10, 15, 30, 60, 120, 300, 600, 900, 1800, 3600, 7200, 10800, 21600, 43200, 86400];

/** Ticks for a sim-time axis on whole seconds, minutes or hours. */
export function timeTicks(max, count = 4) {
  const step = TIME_STEPS.find((s) => s >= max / count) || Math.ceil(max / count / 86400) * 86400;
  const ticks = [];
  for (let v = 0; v <= max; v += step) ticks.push(v);
  return ticks;
}

function short(v) {
  if (Math.abs(v) >= 10000) return `${+(v / 1000).toFixed(0)}k`;
  if (Math.abs(v) >= 1000) return `${+(v / 1000).toFixed(1)}k`;
  return `${+v.toFixed(Math.abs(v) < 10 && v % 1 ? 2 : 0)}`;
}

function yAxis(svg, ticks, y, w) {
  for (const t of ticks) {
    const yy = y(t);
    svg.append(svgEl("line", { x1: PAD.l, x2: w - PAD.r, y1: yy, y2: yy, class: t ? "grid" : "axis" }));
    svg.append(svgEl("text", { x: PAD.l - 4, y: yy + 3, "text-anchor": "end" }, short(t)));
  }
}

function empty(svg, w, hgt, text) {
  svg.append(svgEl("text", { x: w / 2, y: hgt / 2, "text-anchor": "middle", class: "empty" }, text));
}

/**
 * Step chart of cumulative counts over sim time.
 * series: [{name, colour, points: [[t, v], …]}]; xMax: the time the axis reaches.
 */
export function stepChart(container, series, { xMax, yMax, xFmt = short, xTicks = niceTicks, emptyText = "no data yet" } = {}) {
  const { svg, w, hgt, iw, ih } = frame(container);
  const allY = series.flatMap((s) => s.points.map((p) => p[1]));
  const allX = series.flatMap((s) => s.points.map((p) => p[0]));
  const xm = Math.max(1, xMax ?? 0, ...allX);
  const ticks = niceTicks(Math.max(yMax ?? 0, ...allY, 1));
  const ym = ticks[ticks.length - 1];
  const x = (v) => PAD.l + (v / xm) * iw;
  const y = (v) => PAD.t + ih - (v / ym) * ih;
  yAxis(svg, ticks, y, w);
  for (const t of xTicks(xm, 4)) {
    if (t > xm) break;
    svg.append(svgEl("text", { x: x(t), y: hgt - 4, "text-anchor": "middle" }, xFmt(t)));
  }
  if (!allY.length) return empty(svg, w, hgt, emptyText);
  for (const s of series) {
    if (!s.points.length) continue;
    let d = `M${x(0)},${y(0)}`;
    for (const [t, v] of s.points) d += `H${x(t)}V${y(v)}`;
    d += `H${x(xm)}`;
    svg.append(svgEl("path", { d, fill: "none", stroke: s.colour, "stroke-width": 2 }));
    if (s.dashedMax !== undefined) {
      svg.append(svgEl("line", { x1: PAD.l, x2: w - PAD.r, y1: y(s.dashedMax), y2: y(s.dashedMax), stroke: s.colour, "stroke-dasharray": "3 3", opacity: 0.5 }));
    }
  }
}

/**
 * Grouped bars. groups: [{label, bars: [{name, value, colour, err?: [lo, hi]}]}].
 */
export function barChart(container, groups, { emptyText = "no data yet", unit = "" } = {}) {
  const probe = Math.max(160, container.clientWidth || 300);
  const gw = (probe - PAD.l - PAD.r) / Math.max(1, groups.length);
  const { fitted, lines } = fitAll(
    groups.map((g) => g.label),
    gw - 4,
    groups.map((g) => g.abbr),
  );
  const { svg, w, hgt, b: bottom, ih } = frame(container, lines);
  const values = groups.flatMap((g) => g.bars.flatMap((b) => [b.value, ...(b.err || [])]));
  if (!values.some((v) => v > 0)) return empty(svg, w, hgt, emptyText);
  // room above the tallest bar or whisker for its value
  const ticks = niceTicks(Math.max(...values) * 1.12);
  const ym = ticks[ticks.length - 1];
  const y = (v) => PAD.t + ih - (Math.max(0, v) / ym) * ih;
  yAxis(svg, ticks, y, w);
  groups.forEach((g, gi) => {
    const n = g.bars.length;
    const bw = Math.min(34, (gw * 0.8) / n);
    const left = PAD.l + gi * gw + (gw - bw * n) / 2;
    g.bars.forEach((b, bi) => {
      const bx = left + bi * bw;
      const top = y(b.value);
      const rect = svgEl("rect", { x: bx + 1, y: top, width: bw - 2, height: PAD.t + ih - top, fill: b.colour, rx: 1 });
      rect.append(svgEl("title", {}, `${g.label} · ${b.name}: ${b.value.toFixed(1)}${unit}`));
      svg.append(rect);
      if (b.err) {
        const cx = bx + bw / 2;
        svg.append(svgEl("path", { d: `M${cx},${y(b.err[0])}V${y(b.err[1])}M${cx - 3},${y(b.err[0])}H${cx + 3}M${cx - 3},${y(b.err[1])}H${cx + 3}`, stroke: "#e6edf3", "stroke-width": 1.2, fill: "none" }));
      }
      // the value above the bar, or above its whisker: never on it
      const text = short(b.value);
      if (textWidth(text) <= bw && n <= 4) {
        const over = b.err ? Math.min(top, y(b.err[1])) : top;
        svg.append(svgEl("text", { x: bx + bw / 2, y: over - 3, "text-anchor": "middle", class: "value" }, text));
      }
    });
    xLabel(svg, PAD.l + gi * gw + gw / 2, hgt - bottom + 14, fitted[gi], g.label);
  });
}

/**
 * Strip plot: one column per category, a dot per value, a bar at the median.
 * cats: [{label, colour, values: [number]}]
 */
export function stripChart(container, cats, { emptyText = "no data yet" } = {}) {
  const probe = Math.max(160, container.clientWidth || 300);
  const names = cats.map((c) => `${c.label} (${c.values.length})`);
  const abbrs = cats.map((c) => c.abbr && `${c.abbr} (${c.values.length})`);
  const { fitted, lines } = fitAll(names, (probe - PAD.l - PAD.r) / Math.max(1, cats.length) - 4, abbrs);
  const { svg, w, hgt, b: bottom, iw, ih } = frame(container, lines);
  const all = cats.flatMap((c) => c.values);
  if (!all.length) return empty(svg, w, hgt, emptyText);
  const ticks = niceTicks(Math.max(...all, 0.1));
  const ym = ticks[ticks.length - 1];
  const y = (v) => PAD.t + ih - (v / ym) * ih;
  yAxis(svg, ticks, y, w);
  const cw = iw / cats.length;
  cats.forEach((c, i) => {
    const cx = PAD.l + i * cw + cw / 2;
    const spread = Math.min(cw * 0.35, 30);
    c.values.forEach((v, j) => {
      const jitter = (((j * 7919) % 97) / 97 - 0.5) * 2 * spread; // deterministic jitter
      svg.append(svgEl("circle", { cx: cx + jitter, cy: y(v), r: 2.4, fill: c.colour, opacity: 0.75 }));
    });
    if (c.values.length) {
      const sorted = [...c.values].sort((a, b) => a - b);
      const mid = sorted.length >> 1;
      const med = sorted.length % 2 ? sorted[mid] : (sorted[mid - 1] + sorted[mid]) / 2;
      svg.append(svgEl("line", { x1: cx - spread - 4, x2: cx + spread + 4, y1: y(med), y2: y(med), stroke: "#e6edf3", "stroke-width": 2 }));
    }
    xLabel(svg, cx, hgt - bottom + 14, fitted[i], names[i]);
  });
}
