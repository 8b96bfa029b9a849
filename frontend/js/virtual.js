// A virtualized list: of many rows of equal height only those in (or near) the scroll
// viewport are in the DOM, between two spacers that keep the scrollbar true. Used by the
// robot table and the auction feed once they hold more rows than are cheap to keep.

const OVERSCAN = 12; // rows rendered beyond each edge of the viewport

export class VirtualRows {
  /**
   * scroller: the element that scrolls; body: the element that holds the rows; spacer(h):
   * an element of height h px that fits in `body` (a <tr> or an <li>); rowHeight: px per
   * row, gap included; render(i) -> the element of row i.
   */
  constructor({ scroller, body, spacer, rowHeight, render, offset = () => 0 }) {
    this.scroller = scroller;
    this.body = body;
    this.spacer = spacer;
    this.rowHeight = rowHeight;
    this.render = render;
    this.offset = offset; // px above `body` inside the scroller (a table's header)
    this.count = 0;
    this.range = [0, 0];
    this.top = spacer(0);
    this.bottom = spacer(0);
    this.top.dataset.spacer = "top";
    this.bottom.dataset.spacer = "bottom";
    this.pending = false;
    // read the scroller's geometry when it changes, never while rows are being written
    this.scrollTop = scroller.scrollTop;
    this.height = scroller.clientHeight;
    scroller.addEventListener(
      "scroll",
      () => {
        this.scrollTop = scroller.scrollTop;
        this.schedule();
      },
      { passive: true },
    );
    new ResizeObserver(() => {
      this.height = scroller.clientHeight;
      this.schedule();
    }).observe(scroller);
  }

  /** Rows now in the DOM: [first, last) */
  visible() {
    const h = this.rowHeight;
    const from = Math.max(0, this.scrollTop - this.offset());
    const first = Math.max(0, Math.floor(from / h) - OVERSCAN);
    const last = Math.min(this.count, Math.ceil((from + this.height) / h) + OVERSCAN);
    return [first, Math.max(first, last)];
  }

  /** Show `count` rows (rendering the visible ones now). */
  update(count) {
    this.count = count;
    const [first, last] = (this.range = this.visible());
    const rows = [];
    for (let i = first; i < last; i++) rows.push(this.render(i));
    this._height(this.top, first * this.rowHeight);
    this._height(this.bottom, (count - last) * this.rowHeight);
    const kids = this.body.children;
    const same = kids.length === rows.length + 2 && rows.every((el, i) => kids[i + 1] === el);
    if (!same) this.body.replaceChildren(this.top, ...rows, this.bottom);
  }

  schedule() {
    if (this.pending) return;
    this.pending = true;
    requestAnimationFrame(() => {
      this.pending = false;
      this.update(this.count);
    });
  }

  _height(el, px) {
    const v = `${px}px`;
    if (el.style.height !== v) el.style.height = v;
    el.hidden = px === 0;
  }
}
