// Robot colours (Okabe–Ito, colour-blind safe) and one distinct shape per robot type. Policy
// colours and labels are not here: they come with the policies from /api/policies (policies.js).

export const TYPE_COLOUR = {
  scout: "#56b4e9", // sky blue
  excavator: "#e69f00", // orange
  hauler: "#cc79a7", // reddish purple
  other: "#ffffff",
};
export const KIND_COLOUR = { scout_excavator: "#e69f00", excavator_hauler: "#cc79a7", operator: "#56b4e9" };
export const KIND_LABEL = { scout_excavator: "scout→exc", excavator_hauler: "exc→hauler", operator: "operator" };
/** Shorter names where a chart has no room for the full ones. */
export const KIND_ABBR = { scout_excavator: "S→E", excavator_hauler: "E→H", operator: "op." };
export const TYPE_ABBR = { scout: "scout", excavator: "exc.", hauler: "haul." };
export const SITE_COLOUR = "#f0e442";
export const FAILED_COLOUR = "#d55e00";
export const PLANT_COLOUR = "#e6edf3";

/** A robot's type: every robot dict the server sends (frames, snapshot, robot list) has it. */
export function robotType(robot) {
  return robot.type in TYPE_COLOUR ? robot.type : "other";
}

/**
 * Trace the type's shape centred on (0, 0), pointing along +x, of radius r:
 * scout = arrowhead, excavator = square with a blade, hauler = circle with a nose.
 */
export function traceShape(ctx, type, r) {
  ctx.beginPath();
  if (type === "scout") {
    ctx.moveTo(r * 1.25, 0);
    ctx.lineTo(-r * 0.85, r * 0.85);
    ctx.lineTo(-r * 0.4, 0);
    ctx.lineTo(-r * 0.85, -r * 0.85);
    ctx.closePath();
  } else if (type === "excavator") {
    ctx.rect(-r * 0.85, -r * 0.85, r * 1.7, r * 1.7);
    ctx.moveTo(r * 0.85, -r * 0.55);
    ctx.lineTo(r * 1.35, -r * 0.7);
    ctx.lineTo(r * 1.35, r * 0.7);
    ctx.lineTo(r * 0.85, r * 0.55);
  } else if (type === "hauler") {
    ctx.arc(0, 0, r, 0.45, 2 * Math.PI - 0.45);
    ctx.lineTo(r * 1.35, 0);
    ctx.closePath();
  } else {
    ctx.moveTo(0, -r);
    ctx.lineTo(r, 0);
    ctx.lineTo(0, r);
    ctx.lineTo(-r, 0);
    ctx.closePath();
  }
}

/**
 * Add the type's shape to `path` (a Path2D or a context), centred on (x, y), turned by
 * `heading` (world angles, anticlockwise with y up): many robots go in one path, drawn with
 * one fill and one stroke.
 */
export function addShape(path, type, r, x, y, heading) {
  const c = Math.cos(heading);
  const s = -Math.sin(heading); // sin(-heading): canvas y points down
  const X = (px, py) => x + px * c - py * s;
  const Y = (px, py) => y + px * s + py * c;
  const outline = type === "scout" ? SCOUT : type === "excavator" ? BODY : type === "hauler" ? null : OTHER;
  if (outline) {
    path.moveTo(X(outline[0] * r, outline[1] * r), Y(outline[0] * r, outline[1] * r));
    for (let i = 2; i < outline.length; i += 2) path.lineTo(X(outline[i] * r, outline[i + 1] * r), Y(outline[i] * r, outline[i + 1] * r));
    path.closePath();
  }
  if (type === "excavator") {
    path.moveTo(X(BLADE[0] * r, BLADE[1] * r), Y(BLADE[0] * r, BLADE[1] * r));
    for (let i = 2; i < BLADE.length; i += 2) path.lineTo(X(BLADE[i] * r, BLADE[i + 1] * r), Y(BLADE[i] * r, BLADE[i + 1] * r));
  } else if (type === "hauler") {
    path.moveTo(X(r * COS45, r * SIN45), Y(r * COS45, r * SIN45));
    path.arc(x, y, r, 0.45 - heading, 2 * Math.PI - 0.45 - heading);
    path.lineTo(X(r * 1.35, 0), Y(r * 1.35, 0));
    path.closePath();
  }
}
// the shapes of traceShape, as outlines of unit radius (x, y pairs)
const SCOUT = [1.25, 0, -0.85, 0.85, -0.4, 0, -0.85, -0.85];
const BODY = [-0.85, -0.85, 0.85, -0.85, 0.85, 0.85, -0.85, 0.85];
const BLADE = [0.85, -0.55, 1.35, -0.7, 1.35, 0.7, 0.85, 0.55];
const OTHER = [0, -1, 1, 0, 0, 1, -1, 0];
const COS45 = Math.cos(0.45);
const SIN45 = Math.sin(0.45);

/** A small canvas glyph for tables and the legend (same shapes as the map). */
export function glyph(type, size = 14, variant = "") {
  const c = document.createElement("canvas");
  const dpr = window.devicePixelRatio || 1;
  c.width = c.height = Math.round(size * dpr);
  const ctx = c.getContext("2d");
  ctx.scale(dpr, dpr);
  ctx.save();
  ctx.translate(size / 2, size / 2);
  ctx.rotate(-Math.PI / 2);
  ctx.translate(-size * 0.06, 0);
  traceShape(ctx, type, size * 0.34);
  const colour = TYPE_COLOUR[type] || TYPE_COLOUR.other;
  ctx.fillStyle = variant === "failed" ? "#3a3f46" : variant === "idle" ? "#11161d" : colour;
  ctx.fill();
  ctx.lineWidth = variant === "idle" ? 1.6 : 1;
  ctx.strokeStyle = variant === "idle" ? colour : "#0d1117";
  ctx.stroke();
  ctx.restore();
  if (variant === "failed") {
    ctx.strokeStyle = FAILED_COLOUR;
    ctx.lineWidth = 2;
    ctx.beginPath();
    ctx.moveTo(size * 0.2, size * 0.2);
    ctx.lineTo(size * 0.8, size * 0.8);
    ctx.moveTo(size * 0.8, size * 0.2);
    ctx.lineTo(size * 0.2, size * 0.8);
    ctx.stroke();
  }
  if (variant === "load") {
    ctx.beginPath();
    ctx.arc(size / 2, size / 2, size * 0.16, 0, 2 * Math.PI);
    ctx.fillStyle = "#f0e442";
    ctx.fill();
  }
  c.style.width = c.style.height = `${size}px`;
  c.className = "glyph";
  c.setAttribute("aria-hidden", "true");
  return c;
}
