// Map labels placed without overlap: each label tries its candidate spots in order and takes
// the first that covers no label already placed and no glyph; a label with no free spot is
// left out (its tooltip and the robot list still name it).

const FONT = "11px system-ui, 'DejaVu Sans', sans-serif";
const H = 12; // label box height (11 px text)

const overlaps = (a, b) => a[0] < b[2] && a[2] > b[0] && a[1] < b[3] && a[3] > b[1];
const CELL = 48; // spatial hash cell (CSS pixels): a box is checked only against its neighbours
const widths = new Map(); // text -> measured width (names repeat every frame)

/** Boxes in a spatial hash, so a thousand labels are placed in linear time. */
class BoxGrid {
  constructor() {
    this.cells = new Map();
  }

  *_keys(b) {
    for (let cx = Math.floor(b[0] / CELL); cx <= Math.floor(b[2] / CELL); cx++) {
      for (let cy = Math.floor(b[1] / CELL); cy <= Math.floor(b[3] / CELL); cy++) yield cx * 100003 + cy;
    }
  }

  add(b) {
    for (const k of this._keys(b)) {
      const list = this.cells.get(k);
      if (list) list.push(b);
      else this.cells.set(k, [b]);
    }
  }

  hits(b) {
    for (const k of this._keys(b)) {
      const list = this.cells.get(k);
      if (list && list.some((o) => overlaps(b, o))) return true;
    }
    return false;
  }
}

export class Labels {
  constructor(ctx) {
    this.ctx = ctx;
    this.blocked = []; // glyph boxes no label may cover
    this.items = [];
  }

  /** A glyph's box [x0, y0, x1, y1] in screen pixels. */
  block(x, y, r) {
    this.blocked.push([x - r, y - r, x + r, y + r]);
  }

  /** candidates: [[x, baselineY, align]] in order of preference. Labels are placed in the
   * order they were added: add the more important ones first. */
  add(text, candidates, colour) {
    this.items.push({ text, candidates, colour });
  }

  /** Place and draw every label; returns what was drawn: [{text, box}] (for tests). */
  draw() {
    const ctx = this.ctx;
    ctx.font = FONT;
    const grid = new BoxGrid();
    for (const b of this.blocked) grid.add(b);
    const drawn = [];
    for (const { text, candidates, colour } of this.items) {
      let w = widths.get(text);
      if (w === undefined) {
        w = ctx.measureText(text).width + 2;
        if (widths.size < 20000) widths.set(text, w);
      }
      for (const [x, y, align] of candidates) {
        const left = align === "left" ? x - 1 : align === "right" ? x - w + 1 : x - w / 2;
        const box = [left, y - H + 2, left + w, y + 2];
        if (grid.hits(box)) continue;
        grid.add(box);
        drawn.push({ text, box, x, y, align, colour });
        break;
      }
    }
    // one pass of outlines, one of fills: two canvas calls per label, no state changes between
    ctx.lineWidth = 3;
    ctx.strokeStyle = "rgba(13,17,23,0.85)";
    for (const d of drawn) {
      ctx.textAlign = d.align;
      ctx.strokeText(d.text, d.x, d.y);
    }
    for (const d of drawn) {
      ctx.textAlign = d.align;
      ctx.fillStyle = d.colour;
      ctx.fillText(d.text, d.x, d.y);
    }
    return { labels: drawn.map(({ text, box }) => ({ text, box })), glyphs: this.blocked };
  }
}

export function label(ctx, text, x, y, colour, align = "center") {
  ctx.font = FONT;
  ctx.textAlign = align;
  ctx.lineWidth = 3;
  ctx.strokeStyle = "rgba(13,17,23,0.85)";
  ctx.strokeText(text, x, y);
  ctx.fillStyle = colour;
  ctx.fillText(text, x, y);
}
