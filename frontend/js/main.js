// Entry point: hash routing between the three pages, the operator token, the map legend.

import { $, $$, h } from "./dom.js";
import { checkToken, getToken, onTokenChange, setToken, tokenRejected } from "./api.js";
import { MissionsPage } from "./missions.js";
import { LiveView } from "./live.js";
import { ComparePage } from "./compare.js";
import { SITE_COLOUR, glyph } from "./palette.js";
import { loadPolicies } from "./policies.js";
import { BATTERY_COLOUR } from "./maprobots.js";

const missions = new MissionsPage();
const live = new LiveView();
const compare = new ComparePage();
let lastLive = null;

function route() {
  const parts = location.hash.replace(/^#\/?/, "").split("/").map(decodeURIComponent);
  const page = ["missions", "live", "compare"].includes(parts[0]) ? parts[0] : "missions";
  for (const v of $$(".view")) v.hidden = v.dataset.view !== page;
  for (const a of $$("[data-nav]")) {
    if (a.dataset.nav === page) a.setAttribute("aria-current", "page");
    else a.removeAttribute("aria-current");
  }
  if (page === "live") {
    const id = parts[1] || lastLive;
    if (id) lastLive = id;
    $("[data-nav=live]").href = id ? `#/live/${encodeURIComponent(id)}` : "#/live";
    document.title = `Regolith · ${id ? `mission ${id}` : page}`;
    live.open(id || null);
    live.applyControl();
  } else {
    live.close();
  }
  if (page === "missions") missions.show();
  else missions.hide();
  if (page === "compare") compare.show();
  if (page !== "live") document.title = `Regolith · ${page}`;
}

// operator token: asked once, kept in localStorage; without it everything is read-only
const dialog = $("#token-dialog");
$("#token-button").addEventListener("click", () => {
  dialog.querySelector("input[name=token]").value = getToken();
  dialog.showModal();
});
// Save asks the server first (GET /api/auth/check): a token it refuses is never kept
$("#token-form").addEventListener("submit", async (e) => {
  if (e.submitter?.value !== "save") return;
  e.preventDefault();
  const input = dialog.querySelector("input[name=token]");
  const error = $("#token-error");
  const token = input.value.trim();
  if (!token) {
    setToken("");
    return dialog.close("save");
  }
  error.textContent = "Checking…";
  const why = await checkToken(token);
  error.textContent = why || "";
  if (why) return input.focus();
  setToken(token);
  return dialog.close("save");
});
dialog.addEventListener("close", () => {
  if (dialog.returnValue === "clear") setToken("");
  dialog.querySelector("input[name=token]").value = "";
  $("#token-error").textContent = "";
});
onTokenChange((operator) => {
  const badge = $("#operator-status");
  const refused = operator && tokenRejected();
  badge.dataset.mode = refused ? "rejected" : operator ? "operator" : "viewer";
  badge.textContent = refused ? "Token refused" : operator ? "Operator" : "Read-only";
  badge.title = refused ? "The server refused the kept token: enter the right one" : "";
  $("#token-button").textContent = operator ? "Change token…" : "Operator token…";
  $("#readonly-banner").hidden = operator;
  missions.applyControl();
  live.applyControl();
});

// the legend under the map: shapes per type, then what the marks mean
function legend() {
  // `only`: an item shown only while it applies (the live view says when: js/live.js)
  const item = (node, text, only) => h("span", only ? { dataset: { legend: only }, hidden: true } : {}, node, text);
  const mark = (draw) => {
    const c = document.createElement("canvas");
    const dpr = window.devicePixelRatio || 1;
    c.width = c.height = 14 * dpr;
    c.style.width = c.style.height = "14px";
    const ctx = c.getContext("2d");
    ctx.scale(dpr, dpr);
    draw(ctx);
    return c;
  };
  $("#legend").replaceChildren(
    item(glyph("scout"), "scout"),
    item(glyph("excavator"), "excavator"),
    item(glyph("hauler"), "hauler"),
    item(glyph("hauler", 14, "idle"), "idle (hollow)"),
    item(glyph("hauler", 14, "load"), "carrying"),
    item(glyph("excavator", 14, "failed"), "failed"),
    item(
      mark((ctx) => {
        ctx.beginPath();
        ctx.moveTo(7, 1);
        ctx.lineTo(13, 7);
        ctx.lineTo(7, 13);
        ctx.lineTo(1, 7);
        ctx.closePath();
        ctx.fillStyle = SITE_COLOUR;
        ctx.fill();
      }),
      "site (left/total)",
    ),
    item(
      mark((ctx) => {
        ctx.fillStyle = "rgba(86,180,233,0.35)";
        ctx.fillRect(1, 1, 12, 12);
      }),
      "scanned",
    ),
    item(
      mark((ctx) => {
        ctx.strokeStyle = "rgba(240,228,66,0.8)";
        ctx.setLineDash([1, 3]);
        ctx.lineWidth = 2;
        ctx.beginPath();
        ctx.moveTo(0, 7);
        ctx.lineTo(14, 7);
        ctx.stroke();
      }),
      "Policy 2 pair",
      "pair",
    ),
    item(
      mark((ctx) => {
        ctx.fillStyle = "#0d1117";
        ctx.fillRect(0, 5, 14, 4);
        ctx.fillStyle = BATTERY_COLOUR.low;
        ctx.fillRect(0, 5, 6, 4);
      }),
      "charge",
      "charge",
    ),
  );
}

legend();
await loadPolicies(); // every policy menu and label is built from it before a page draws
window.addEventListener("hashchange", route);
route();
