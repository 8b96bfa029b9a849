// The registered policies, fetched once from GET /api/policies (the engine's registry): every
// menu, label and policy colour on the page comes from here, so a new policy needs no edit.

import { $$, h } from "./dom.js";
import { get, onTokenChange } from "./api.js";

const FALLBACK_COLOUR = "#a3b1c2"; // a policy the server no longer lists (old records)
let list = [];
let byName = new Map();

/** The policies in registration order: [{number, name, label, colour, description, decentralized}]. */
export const policies = () => list;

/** "2 · Coalitions" for a registered policy; the bare name otherwise. */
export function policyLabel(name) {
  const p = byName.get(name);
  return p ? `${p.number} · ${p.label}` : String(name ?? "");
}

/** Just the short name ("Coalitions"), for tight chart axes. */
export const policyShort = (name) => byName.get(name)?.label ?? String(name ?? "");

export const policyColour = (name) => byName.get(name)?.colour ?? FALLBACK_COLOUR;

/** Registration order, for sorting; unknown policies go last. */
export function policyRank(name) {
  const i = list.findIndex((p) => p.name === name);
  return i < 0 ? list.length : i;
}

/** Refill every `select[data-policies]`, keeping its leading "any" option (value "") and its value. */
function fillSelects() {
  for (const sel of $$("select[data-policies]")) {
    const keep = [...sel.options].filter((o) => o.value === "");
    const value = sel.value;
    sel.replaceChildren(
      ...keep,
      ...list.map((p) => h("option", { value: p.name, title: p.description }, policyLabel(p.name))),
    );
    if (value && byName.has(value)) sel.value = value;
  }
}

async function load() {
  try {
    const data = await get("/policies");
    list = Array.isArray(data) ? data : [];
  } catch {
    list = []; // e.g. reads need a token: tried again when one is entered
  }
  byName = new Map(list.map((p) => [p.name, p]));
  fillSelects();
}

/** Fetch the list once at start (before the pages draw); again after a token if it failed. */
export async function loadPolicies() {
  await load();
  let first = true;
  onTokenChange(() => {
    if (!first && !list.length) load();
    first = false;
  });
}
