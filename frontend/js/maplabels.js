// Map labels placed without overlap: each label tries its candidate spots in order and takes
// the first that covers no label already placed and no glyph; a label with no free spot is
// left out (its tooltip and the robot list still name it).

const FONT = "11px system-ui, 'DejaVu Sans', sans-serif";
const H = 12; // label box height (11 px text)

const overlaps = (a, b) => a[0] < b[2] && a[2] > b[0] && a[1] < b[3] && a[3] > b[1];

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
    const placed = [];
    const drawn = [];
    for (const { text, candidates, colour } of this.items) {
      const w = ctx.measureText(text).width + 2;
      for (const [x, y, align] of candidates) {
        const left = align === "left" ? x - 1 : align === "right" ? x - w + 1 : x - w / 2;
        const box = [left, y - H + 2, left + w, y + 2];
        if (placed.some((b) => overlaps(box, b)) || this.blocked.some((b) => overlaps(box, b))) continue;
        placed.push(box);
        drawn.push({ text, box });
        label(ctx, text, x, y, colour, align);
        break;
      }
    }
    return { labels: drawn, glyphs: this.blocked };
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
