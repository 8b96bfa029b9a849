// A small TOML reader for scenario files: tables, arrays of tables, dotted keys, strings,
// numbers, booleans, arrays and inline tables. Dates and multi-line strings are not needed
// by scenarios and are rejected with a clear message.

export class TomlError extends Error {}

export function parseToml(text) {
  const root = {};
  let table = root;
  const p = { s: text, i: 0, line: 1 };

  while (p.i < p.s.length) {
    skipWs(p, true);
    if (p.i >= p.s.length) break;
    const ch = p.s[p.i];
    if (ch === "[") {
      const isArray = p.s[p.i + 1] === "[";
      p.i += isArray ? 2 : 1;
      skipWs(p);
      const keys = parseKey(p);
      skipWs(p);
      expect(p, isArray ? "]]" : "]");
      table = isArray ? arrayTable(root, keys, p) : openTable(root, keys, p);
    } else {
      const keys = parseKey(p);
      skipWs(p);
      expect(p, "=");
      skipWs(p);
      const value = parseValue(p);
      assign(table, keys, value, p);
    }
    skipWs(p);
    if (p.s[p.i] === "#") skipComment(p);
    if (p.i < p.s.length && !"\r\n".includes(p.s[p.i])) fail(p, "expected a new line");
  }
  return root;
}

function fail(p, msg) {
  throw new TomlError(`TOML line ${p.line}: ${msg}`);
}

function expect(p, token) {
  if (p.s.startsWith(token, p.i)) p.i += token.length;
  else fail(p, `expected "${token}"`);
}

function skipComment(p) {
  while (p.i < p.s.length && p.s[p.i] !== "\n") p.i++;
}

/** Skip spaces and tabs (and new lines and comments when multiline). */
function skipWs(p, multiline = false) {
  while (p.i < p.s.length) {
    const c = p.s[p.i];
    if (c === " " || c === "\t") p.i++;
    else if (multiline && (c === "\n" || c === "\r")) {
      if (c === "\n") p.line++;
      p.i++;
    } else if (multiline && c === "#") skipComment(p);
    else break;
  }
}

function parseKey(p) {
  const keys = [];
  for (;;) {
    skipWs(p);
    const c = p.s[p.i];
    if (c === '"' || c === "'") keys.push(parseString(p));
    else {
      const m = /^[A-Za-z0-9_-]+/.exec(p.s.slice(p.i));
      if (!m) fail(p, "expected a key");
      keys.push(m[0]);
      p.i += m[0].length;
    }
    skipWs(p);
    if (p.s[p.i] !== ".") return keys;
    p.i++;
  }
}

function parseString(p) {
  const q = p.s[p.i];
  if (p.s.startsWith(q.repeat(3), p.i)) fail(p, "multi-line strings are not supported");
  p.i++;
  let out = "";
  while (p.i < p.s.length && p.s[p.i] !== q) {
    const c = p.s[p.i];
    if (c === "\n") fail(p, "unterminated string");
    if (q === '"' && c === "\\") {
      const e = p.s[p.i + 1];
      const map = { n: "\n", t: "\t", r: "\r", '"': '"', "\\": "\\", b: "\b", f: "\f" };
      if (e in map) {
        out += map[e];
        p.i += 2;
      } else if (e === "u" || e === "U") {
        const n = e === "u" ? 4 : 8;
        out += String.fromCodePoint(Number.parseInt(p.s.slice(p.i + 2, p.i + 2 + n), 16));
        p.i += 2 + n;
      } else fail(p, "bad escape in string");
    } else {
      out += c;
      p.i++;
    }
  }
  expect(p, q);
  return out;
}

function parseValue(p) {
  const c = p.s[p.i];
  if (c === '"' || c === "'") return parseString(p);
  if (c === "[") {
    p.i++;
    const arr = [];
    for (;;) {
      skipWs(p, true);
      if (p.s[p.i] === "]") {
        p.i++;
        return arr;
      }
      arr.push(parseValue(p));
      skipWs(p, true);
      if (p.s[p.i] === ",") p.i++;
      else if (p.s[p.i] !== "]") fail(p, 'expected "," or "]" in array');
    }
  }
  if (c === "{") {
    p.i++;
    const obj = {};
    skipWs(p);
    if (p.s[p.i] === "}") {
      p.i++;
      return obj;
    }
    for (;;) {
      const keys = parseKey(p);
      skipWs(p);
      expect(p, "=");
      skipWs(p);
      assign(obj, keys, parseValue(p), p);
      skipWs(p);
      if (p.s[p.i] === ",") {
        p.i++;
        skipWs(p);
      } else if (p.s[p.i] === "}") {
        p.i++;
        return obj;
      } else fail(p, 'expected "," or "}" in inline table');
    }
  }
  const m = /^[^\s,\]}#]+/.exec(p.s.slice(p.i));
  if (!m) fail(p, "expected a value");
  p.i += m[0].length;
  const w = m[0];
  if (w === "true") return true;
  if (w === "false") return false;
  if (w === "inf" || w === "+inf" || w === "-inf" || w.endsWith("nan")) fail(p, "inf and nan are not allowed here");
  const num = w.replaceAll("_", "");
  if (/^[+-]?(0x[0-9a-fA-F]+|0o[0-7]+|0b[01]+)$/.test(num)) return Number(num.replace(/^\+/, ""));
  if (/^[+-]?\d+(\.\d+)?([eE][+-]?\d+)?$/.test(num)) return Number(num);
  if (/^\d{4}-\d{2}-\d{2}/.test(w)) fail(p, "dates are not supported in scenarios");
  return fail(p, `cannot read value "${w}"`);
}

function assign(table, keys, value, p) {
  let t = table;
  for (const k of keys.slice(0, -1)) {
    if (!(k in t)) t[k] = {};
    if (typeof t[k] !== "object" || Array.isArray(t[k])) fail(p, `key "${k}" is not a table`);
    t = t[k];
  }
  const last = keys[keys.length - 1];
  if (last in t) fail(p, `duplicate key "${keys.join(".")}"`);
  t[last] = value;
}

function openTable(root, keys, p) {
  let t = root;
  for (const k of keys) {
    if (!(k in t)) t[k] = {};
    t = Array.isArray(t[k]) ? t[k][t[k].length - 1] : t[k];
    if (typeof t !== "object") fail(p, `key "${k}" is not a table`);
  }
  return t;
}

function arrayTable(root, keys, p) {
  const parent = openTable(root, keys.slice(0, -1), p);
  const last = keys[keys.length - 1];
  if (!(last in parent)) parent[last] = [];
  if (!Array.isArray(parent[last])) fail(p, `key "${last}" is not an array of tables`);
  const t = {};
  parent[last].push(t);
  return t;
}
