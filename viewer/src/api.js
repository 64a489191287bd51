// fetch wrapper for the fragsimd HTTP API.
// The bearer token lives in sessionStorage only and is sent as the Authorization header, never in
// a URL. The page first tries without a token; a 401 shows the token form and the request is
// retried once a token has been entered.

const TOKEN_KEY = 'fragsim.token';

export class ApiError extends Error {
  constructor(status, code, message, field) {
    super(message);
    this.status = status;
    this.code = code;
    this.field = field ?? null;
  }
  // "<field>: <message>" as the daemon reports it, or just the message.
  get display() {
    return this.field ? `${this.field}: ${this.message}` : this.message;
  }
}

export function errorText(err) {
  if (err instanceof ApiError) return err.display;
  return err && err.message ? err.message : String(err);
}

export function getToken() {
  return sessionStorage.getItem(TOKEN_KEY);
}

// ---- token form -------------------------------------------------------------------------------

let pendingToken = null;  // one promise shared by every request waiting for a token

function askToken(rejected) {
  if (pendingToken) return pendingToken;
  const form = document.getElementById('token-form');
  const input = document.getElementById('token-input');
  const msg = document.getElementById('token-message');
  msg.hidden = !rejected;
  msg.textContent = rejected ? 'The daemon did not accept that token; enter another.' : '';
  form.hidden = false;
  input.value = '';
  input.focus();
  pendingToken = new Promise((resolve) => {
    const onSubmit = (ev) => {
      ev.preventDefault();
      const token = input.value.trim();
      if (!token) return;
      sessionStorage.setItem(TOKEN_KEY, token);
      form.removeEventListener('submit', onSubmit);
      form.hidden = true;
      input.value = '';
      pendingToken = null;
      resolve(token);
    };
    form.addEventListener('submit', onSubmit);
  });
  return pendingToken;
}

// ---- requests ---------------------------------------------------------------------------------

async function toApiError(res) {
  let body = null;
  try {
    body = await res.json();
  } catch {
    // not JSON: fall through
  }
  if (body && typeof body.message === 'string')
    return new ApiError(res.status, body.code, body.message, body.field);
  return new ApiError(res.status, 'http_' + res.status, `HTTP ${res.status} ${res.statusText}`);
}

// request(path, {method, body, headers, as}) -> parsed body ('json' | 'blob' | 'arraybuffer' |
// 'text' | 'response'). Throws ApiError for a 4xx/5xx answer.
export async function request(path, opts = {}) {
  const { method = 'GET', body, headers = {}, as = 'json' } = opts;
  let rejected = false;
  for (;;) {
    const h = new Headers(headers);
    const token = getToken();
    if (token) h.set('Authorization', 'Bearer ' + token);
    const res = await fetch(path, { method, body, headers: h, cache: 'no-store' });
    if (res.status === 401) {
      if (token && getToken() === token) {
        sessionStorage.removeItem(TOKEN_KEY);
        rejected = true;
      }
      if (!getToken()) await askToken(rejected);
      continue;
    }
    if (!res.ok) throw await toApiError(res);
    if (as === 'response') return res;
    if (as === 'blob') return res.blob();
    if (as === 'arraybuffer') return res.arrayBuffer();
    if (as === 'text') return res.text();
    return res.json();
  }
}

// ---- routes -----------------------------------------------------------------------------------

const enc = encodeURIComponent;

export const api = {
  health: () => fetch('/v1/health', { cache: 'no-store' }).then((r) => r.json()),
  jobs: (limit = 200) => request(`/v1/jobs?limit=${limit}`),
  job: (id) => request(`/v1/jobs/${enc(id)}`),
  submitJob: (text) =>
    request('/v1/jobs', { method: 'POST', body: text, headers: { 'Content-Type': 'application/json' } }),
  cancelJob: (id) => request(`/v1/jobs/${enc(id)}`, { method: 'DELETE' }),
  // A finished job and all its files (docs/operations.md); 409 while it still runs.
  purgeJob: (id) => request(`/v1/jobs/${enc(id)}?purge=true`, { method: 'DELETE' }),
  // A failed job queued again (docs/operations.md, "Disk space").
  retryJob: (id) => request(`/v1/jobs/${enc(id)}/retry`, { method: 'POST' }),
  // The token's role and owner name (docs/operations.md, "Roles").
  whoami: () => request('/v1/whoami'),
  summary: (id) => request(`/v1/jobs/${enc(id)}/summary`),
  maps: (id) => request(`/v1/jobs/${enc(id)}/maps`),
  comparison: (id) => request(`/v1/jobs/${enc(id)}/compare`),
  jobScene: (id, maxTrajectories = 200) =>
    request(`/v1/jobs/${enc(id)}/scene?max_trajectories=${maxTrajectories}`, { as: 'arraybuffer' }),
  sites: () => request('/v1/sites'),
  site: (id) => request(`/v1/sites/${enc(id)}`),
  siteScene: (id) => request(`/v1/sites/${enc(id)}/scene`, { as: 'arraybuffer' }),
};

// ---- downloads --------------------------------------------------------------------------------

function filenameFrom(res, fallback) {
  const cd = res.headers.get('Content-Disposition') || '';
  const m = cd.match(/filename\*?=(?:UTF-8'')?"?([^";]+)"?/i);
  return m ? decodeURIComponent(m[1]) : fallback;
}

// Fetches `path` with the auth header into a Blob and saves it via an object URL.
export async function download(path, fallbackName) {
  const res = await request(path, { as: 'response' });
  const blob = await res.blob();
  const url = URL.createObjectURL(blob);
  const a = document.createElement('a');
  a.href = url;
  a.download = filenameFrom(res, fallbackName);
  document.body.appendChild(a);
  a.click();
  a.remove();
  setTimeout(() => URL.revokeObjectURL(url), 60000);
}
