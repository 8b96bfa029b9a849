// What the compare page may pool: runs of one scenario and one mode (simulated or field: a
// field run is real agent processes, not the engine, docs/field.md), grouped by the policy
// they ran under.
// A run whose policy was switched live belongs to no single policy: it is left out unless
// asked for, and then forms a group of its own (its policies in order, e.g. "FCFS→Coalitions").

import { policyColour, policyLabel, policyRank, policyShort } from "./policies.js";

const MIXED_COLOUR = "#8b949e";

/** What may be pooled: a scenario's name and content hash (two files named alike can differ),
 * and the mode (field runs are never pooled with simulated ones). */
export const scenarioKey = (m) => `${m.scenario_name}#${m.scenario_hash}${m.mode === "field" ? "#field" : ""}`;

/** The scenarios (per mode) among `missions`, most runs first: [{key, name, hash, field, count}]. */
export function scenarios(missions) {
  const by = new Map();
  for (const m of missions) {
    const k = scenarioKey(m);
    if (!by.has(k)) by.set(k, { key: k, name: m.scenario_name, hash: m.scenario_hash, field: m.mode === "field", count: 0 });
    by.get(k).count += 1;
  }
  return [...by.values()].sort((a, b) => b.count - a.count || a.name.localeCompare(b.name));
}

/** The group a mission's figures count under: its one policy, or its sequence when mixed. */
export const groupOf = (m) => (m.mixed_policy ? m.policies.join("→") : m.initial_policy);

export const isMixedGroup = (g) => String(g).includes("→");

export function groupLabel(g) {
  return isMixedGroup(g) ? `${g.split("→").map(policyShort).join("→")} (mixed)` : policyLabel(g);
}

export function groupShort(g) {
  return isMixedGroup(g) ? g.split("→").map(policyShort).join("→") : policyShort(g);
}

export const groupColour = (g) => (isMixedGroup(g) ? MIXED_COLOUR : policyColour(g));

/** Single policies by their registry rank, then the mixed groups. */
export function groupOrder(a, b) {
  const ma = isMixedGroup(a);
  const mb = isMixedGroup(b);
  if (ma !== mb) return ma ? 1 : -1;
  return (ma ? 0 : policyRank(a) - policyRank(b)) || a.localeCompare(b);
}

/** A mission's policy as the list shows it: "1 · FCFS", or "1 · FCFS → 2 · Coalitions". */
export const policyText = (m) => m.policies.map(policyLabel).join(" → ");

/** Mean and a 95% confidence interval of the mean (normal approximation; t for small n). */
export function meanCi(values) {
  const n = values.length;
  if (!n) return null;
  const mean = values.reduce((a, b) => a + b, 0) / n;
  if (n < 2) return { mean, lo: mean, hi: mean, n };
  const sd = Math.sqrt(values.reduce((a, b) => a + (b - mean) ** 2, 0) / (n - 1));
  const t = [12.71, 4.3, 3.18, 2.78, 2.57, 2.45, 2.36, 2.31, 2.26][n - 2] ?? 1.96;
  const half = (t * sd) / Math.sqrt(n);
  return { mean, lo: mean - half, hi: mean + half, n };
}
