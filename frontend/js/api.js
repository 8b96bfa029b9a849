// The REST client: JSON in and out, the operator token on mutating calls.

const TOKEN_KEY = "regolith.token";
const listeners = new Set();

export function getToken() {
  try {
    return localStorage.getItem(TOKEN_KEY) || "";
  } catch {
    return "";
  }
}

let rejected = false; // the server refused the kept token (403) since it was saved

export function setToken(token) {
  if (token) localStorage.setItem(TOKEN_KEY, token);
  else localStorage.removeItem(TOKEN_KEY);
  rejected = false;
  for (const fn of listeners) fn(Boolean(token));
}

/** Has the server refused the kept token? (cleared when a token is saved or forgotten) */
export const tokenRejected = () => rejected;

function markRejected() {
  if (rejected || !getToken()) return;
  rejected = true;
  for (const fn of listeners) fn(isOperator());
}

/**
 * Ask the server whether `token` is the operator's (GET /api/auth/check) before keeping it:
 * null when it is, else why not.
 */
export async function checkToken(token) {
  let res;
  try {
    res = await fetch("/api/auth/check", { headers: { Accept: "application/json", Authorization: `Bearer ${token}` } });
  } catch {
    return "The server could not be reached; the token was not saved.";
  }
  if (res.ok) return null;
  if (res.status === 403) return "The server did not accept this token.";
  if (res.status === 429) return "Too many attempts; wait a moment and try again.";
  return `The server answered ${res.status}; the token was not saved.`;
}

export const isOperator = () => Boolean(getToken());

/** Call fn(isOperator) now and whenever the token changes. */
export function onTokenChange(fn) {
  listeners.add(fn);
  fn(isOperator());
}

export class ApiError extends Error {
  constructor(status, detail) {
    super(typeof detail === "string" ? detail : describe(detail));
    this.status = status;
    this.detail = detail;
  }
}

function describe(detail) {
  if (Array.isArray(detail)) {
    return detail.map((d) => `${(d.loc || []).filter((p) => p !== "body").join(".")}: ${d.msg}`).join("; ");
  }
  return detail ? JSON.stringify(detail) : "request failed";
}

export async function api(method, path, body) {
  const headers = { Accept: "application/json" };
  if (body !== undefined) headers["Content-Type"] = "application/json";
  if (getToken()) headers.Authorization = `Bearer ${getToken()}`; // reads may need it too (configurable)
  const res = await fetch(`/api${path}`, {
    method,
    headers,
    body: body === undefined ? undefined : JSON.stringify(body),
  });
  const text = await res.text();
  let data = null;
  try {
    data = text ? JSON.parse(text) : null;
  } catch {
    data = text;
  }
  if (!res.ok) {
    let detail = data && typeof data === "object" && "detail" in data ? data.detail : data;
    if (data && typeof data === "object" && typeof data.message === "string") detail = data.message; // 422s name the field
    if (res.status === 401) detail = "An operator token is needed for this.";
    if (res.status === 403) {
      detail = "The operator token was not accepted.";
      markRejected();
    }
    throw new ApiError(res.status, detail || res.statusText);
  }
  return data;
}

export const get = (path) => api("GET", path);
export const post = (path, body) => api("POST", path, body ?? {});
export const put = (path, body) => api("PUT", path, body);

/** Query string from an object, skipping empty values. */
export function qs(params) {
  const q = new URLSearchParams();
  for (const [k, v] of Object.entries(params)) if (v !== "" && v !== null && v !== undefined) q.set(k, v);
  const s = q.toString();
  return s ? `?${s}` : "";
}
