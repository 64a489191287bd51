// Harness of the fragsimd web-viewer browser tests (and of bench/viewer_bench.mjs).
//
// - startDaemon(): fragsimd on 127.0.0.1:0 with a port file, a temporary data directory and a
//   generated token file (auth on unless asked otherwise); stop() sends SIGTERM, then SIGKILL.
// - Daemon#request()/uploadSite()/submitJob()/waitForState(): the HTTP API from node, with the token.
// - launchBrowser(): Debian's chromium (env CHROMIUM, default /usr/bin/chromium) driven by
//   playwright-core, headless, software WebGL (SwiftShader), fresh profile; never a downloaded browser.
// - openPage(): a page that records console errors, page errors, every request URL and dialogs.
// - screenshot(), pngStats(), canvasStats(): screenshots into SCREENSHOT_DIR and pixel statistics
//   (distinct colours) read from the PNG, to tell a rendered canvas from a blank one.
//
// Environment: FRAGSIMD (daemon binary), FRAGSIM_UI_DIR (pass `--ui-dir DIR`: serve the page
// from disk instead of the copy embedded in the binary), CHROMIUM, SCREENSHOT_DIR,
// VIEWER_TEST_KEEP=1 (keep the daemon's data directory and log).

import { spawn } from 'node:child_process';
import { randomBytes } from 'node:crypto';
import fs from 'node:fs';
import os from 'node:os';
import path from 'node:path';
import { fileURLToPath } from 'node:url';
import zlib from 'node:zlib';
import { chromium } from 'playwright-core';

const here = path.dirname(fileURLToPath(import.meta.url));
export const REPO = path.resolve(here, '..', '..');
export const FRAGSIMD = process.env.FRAGSIMD || path.join(REPO, 'build', 'server', 'fragsimd');
export const FRAGSIM_CLI = process.env.FRAGSIM_CLI || path.join(REPO, 'build', 'cli', 'fragsim');
export const CHROMIUM = process.env.CHROMIUM || '/usr/bin/chromium';
export const SCREENSHOT_DIR = process.env.SCREENSHOT_DIR || path.join(REPO, 'out', 'viewer-test');
export const UI_DIR = process.env.FRAGSIM_UI_DIR || '';

export const sleep = (ms) => new Promise((r) => setTimeout(r, ms));

// ---------------------------------------------------------------- scenarios

export function readJson(file) {
  return JSON.parse(fs.readFileSync(file, 'utf8'));
}

/** examples/minimal/scenario.json with settings.record_trajectories on (a copy). */
export function minimalScenario() {
  const s = readJson(path.join(REPO, 'examples', 'minimal', 'scenario.json'));
  s.settings.record_trajectories = true;
  return s;
}

/** minimalScenario() on a 400 m x 400 m plane in 10 m cells: its fragments fly beyond the terrain
 *  while hazardous, so its HFD (~266 m) is a lower bound cut by the site boundary (issue 22; ~19
 *  of 36 sectors), and its submission answers with a warning. Same 2000 samples (~0.1 s). */
export function smallPlaneScenario() {
  const s = minimalScenario();
  s.site.terrain.plane.extent_m = [-200, -200, 200, 200];
  s.site.terrain.plane.cell_m = 10;
  return s;
}

/** examples/demo/scenario.json with every group's samples multiplied by `factor`. */
export function demoScenario(factor = 1) {
  const s = readJson(path.join(REPO, 'examples', 'demo', 'scenario.json'));
  for (const g of s.fragment_groups) g.samples = Math.max(1, Math.round(g.samples * factor));
  return s;
}

/** Scenario -> {site, job}: the site object and the scenario with site_id in place of site. */
export function splitScenario(scenario, siteId) {
  const { site, ...rest } = scenario;
  return { site, job: { ...rest, site_id: siteId } };
}

// ---------------------------------------------------------------- daemon

function waitForFile(file, ms, proc) {
  const t0 = Date.now();
  return new Promise((resolve, reject) => {
    const tick = () => {
      if (proc.exitCode !== null || proc.signalCode !== null) {
        reject(new Error(`fragsimd exited (${proc.exitCode ?? proc.signalCode}) before writing its port file`));
        return;
      }
      try {
        const txt = fs.readFileSync(file, 'utf8').trim();
        if (/^\d+$/.test(txt)) { resolve(Number(txt)); return; }
      } catch { /* not yet */ }
      if (Date.now() - t0 > ms) { reject(new Error(`no port file ${file} after ${ms} ms`)); return; }
      setTimeout(tick, 50);
    };
    tick();
  });
}

const liveDaemons = new Set();
process.on('exit', () => { for (const d of liveDaemons) { try { d.proc.kill('SIGKILL'); } catch { /* gone */ } } });

/** SIGTERM, then SIGKILL after 5 s; resolves when the process has exited. */
async function terminate(p) {
  if (p.exitCode !== null || p.signalCode !== null) return;
  const exited = new Promise((r) => p.once('exit', r));
  p.kill('SIGTERM');
  const t = setTimeout(() => { try { p.kill('SIGKILL'); } catch { /* gone */ } }, 5000);
  await exited;
  clearTimeout(t);
}

export class Daemon {
  constructor(proc, base, token, dir, logFile) {
    this.proc = proc; this.base = base; this.token = token; this.dir = dir; this.logFile = logFile;
  }

  /** fetch() against the daemon. opts: {method, body (object -> JSON), token (false = none;
   *  default the daemon's), headers, raw (return the Response too)}. */
  async request(p, opts = {}) {
    const headers = { ...(opts.headers || {}) };
    const token = opts.token === undefined ? this.token : opts.token;
    if (token) headers.Authorization = `Bearer ${token}`;
    let body = opts.body;
    if (body !== undefined && !(body instanceof Uint8Array)) {
      if (typeof body !== 'string') body = JSON.stringify(body);
      headers['Content-Type'] = headers['Content-Type'] || 'application/json';
    }
    const res = await fetch(this.base + p, { method: opts.method || 'GET', headers, body, redirect: 'manual' });
    const buf = Buffer.from(await res.arrayBuffer());
    let json = null;
    if ((res.headers.get('content-type') || '').includes('json')) {
      try { json = JSON.parse(buf.toString('utf8')); } catch { /* not json */ }
    }
    return { status: res.status, headers: res.headers, body: buf, json, text: () => buf.toString('utf8') };
  }

  async expectOk(p, opts, okStatuses = [200, 201, 202]) {
    const r = await this.request(p, opts);
    if (!okStatuses.includes(r.status)) {
      throw new Error(`${opts?.method || 'GET'} ${p} -> ${r.status} ${r.text().slice(0, 500)}`);
    }
    return r.json;
  }

  /** POST /v1/sites; returns SiteSummary. */
  uploadSite(site) { return this.expectOk('/v1/sites', { method: 'POST', body: site }); }

  /** POST /v1/jobs with a scenario (inline site or site_id); returns JobStatus. */
  submitJob(scenario, extra = {}) {
    return this.expectOk('/v1/jobs', { method: 'POST', body: { ...scenario, ...extra } });
  }

  getJob(id) { return this.expectOk(`/v1/jobs/${id}`); }

  /** Poll GET /v1/jobs/{id} until its state is one of `states`; returns the JobStatus. */
  async waitForState(id, states, timeoutMs = 60000, pollMs = 100) {
    const want = Array.isArray(states) ? states : [states];
    const t0 = Date.now();
    let last;
    while (Date.now() - t0 < timeoutMs) {
      last = await this.getJob(id);
      if (want.includes(last.state)) return last;
      if (['done', 'failed', 'cancelled'].includes(last.state)) {
        throw new Error(`job ${id} ended ${last.state} (${JSON.stringify(last.error)}), wanted ${want}`);
      }
      await sleep(pollMs);
    }
    throw new Error(`job ${id} not ${want} after ${timeoutMs} ms (last state ${last?.state}, progress ${last?.progress})`);
  }

  /** Upload the scenario's site, submit the job with its site_id, wait until done. */
  async runScenario(scenario, timeoutMs = 60000) {
    const { site, job } = splitScenario(scenario, null);
    const siteSummary = await this.uploadSite(site);
    job.site_id = siteSummary.site_id;
    const status = await this.submitJob(job);
    const done = await this.waitForState(status.job_id, 'done', timeoutMs);
    const summary = await this.expectOk(`/v1/jobs/${status.job_id}/summary`);
    return { site: siteSummary, job: done, summary };
  }

  /** Stop the daemon (SIGTERM) and start it again on the same port and data directory; with
   *  `token`, the token file holds only that token afterwards (the old token is revoked). */
  async restart({ token } = {}) {
    await terminate(this.proc);
    if (token !== undefined) {
      if (!this.tokenFile) throw new Error('restart({token}): the daemon runs without a token file');
      fs.writeFileSync(this.tokenFile, `# rewritten by viewer/test/harness.mjs\n${token}\n`, { mode: 0o600 });
      this.token = token;
    }
    const port = new URL(this.base).port;
    const args = this.args.map((a, i) => (this.args[i - 1] === '--listen' ? `127.0.0.1:${port}` : a));
    fs.rmSync(this.portFile, { force: true });
    const log = fs.openSync(this.logFile, 'a');
    const proc = spawn(FRAGSIMD, args, { stdio: ['ignore', log, log] });
    proc.unref();
    fs.closeSync(log);
    this.proc = proc;
    await waitForFile(this.portFile, 15000, proc);
    await this.expectOk('/v1/health', { token: false });
  }

  logTail(lines = 40) {
    try { return fs.readFileSync(this.logFile, 'utf8').split('\n').slice(-lines).join('\n'); } catch { return ''; }
  }

  async stop() {
    liveDaemons.delete(this);
    await terminate(this.proc);
    if (!process.env.VIEWER_TEST_KEEP) fs.rmSync(this.dir, { recursive: true, force: true });
  }
}

/** Does this fragsimd know --ui-dir (i.e. serve the viewer)? */
export async function daemonHelp() {
  return new Promise((resolve) => {
    const p = spawn(FRAGSIMD, ['--help'], { stdio: ['ignore', 'pipe', 'pipe'] });
    let out = '';
    p.stdout.on('data', (d) => { out += d; });
    p.stderr.on('data', (d) => { out += d; });
    p.on('error', () => resolve(''));
    p.on('exit', () => resolve(out));
  });
}

/** Start fragsimd. opts: {auth (default true), threads, uiDir (default env FRAGSIM_UI_DIR),
 *  args (extra flags), roles (e.g. ['read', 'submit']: one more token per role, in
 *  daemon.tokens[role]; daemon.token is an admin token)}. */
export async function startDaemon(opts = {}) {
  if (!fs.existsSync(FRAGSIMD)) {
    throw new Error(`fragsimd not found at ${FRAGSIMD}: build it (cmake --build build -j) or set FRAGSIMD`);
  }
  const dir = fs.mkdtempSync(path.join(os.tmpdir(), 'fragsim-viewer-test-'));
  const portFile = path.join(dir, 'port');
  const logFile = path.join(dir, 'fragsimd.log');
  const args = ['--listen', '127.0.0.1:0', '--port-file', portFile, '--data-dir', path.join(dir, 'data')];
  let token = null;
  const tokens = {};
  if (opts.auth === false) {
    args.push('--no-auth');
  } else {
    token = 'vt_' + randomBytes(24).toString('hex');
    tokens.admin = token;
    for (const role of opts.roles || []) tokens[role] = 'vt_' + randomBytes(24).toString('hex');
    const lines = Object.entries(tokens).map(([role, t]) => `${t} ${role}\n`).join('');
    const tokenFile = path.join(dir, 'tokens');
    fs.writeFileSync(tokenFile, `# generated by viewer/test/harness.mjs\n${lines}`, { mode: 0o600 });
    args.push('--token-file', tokenFile);
  }
  if (opts.threads) args.push('--threads', String(opts.threads));
  const uiDir = opts.uiDir === undefined ? UI_DIR : opts.uiDir;
  if (uiDir) args.push('--ui-dir', path.resolve(uiDir));
  if (opts.args) args.push(...opts.args);
  const log = fs.openSync(logFile, 'a');
  const proc = spawn(FRAGSIMD, args, { stdio: ['ignore', log, log] });
  proc.unref(); // a daemon left behind by a failed test must not keep node alive (killed at exit)
  fs.closeSync(log);
  const d = new Daemon(proc, null, token, dir, logFile);
  Object.assign(d, { args, portFile, tokens, tokenFile: token ? path.join(dir, 'tokens') : null });
  liveDaemons.add(d);
  try {
    const port = await waitForFile(portFile, 15000, proc);
    d.base = `http://127.0.0.1:${port}`;
    await d.expectOk('/v1/health', { token: false });
  } catch (e) {
    const tail = d.logTail();
    await d.stop();
    throw new Error(`${e.message}\nfragsimd ${args.join(' ')}\n${tail}`);
  }
  return d;
}

// ---------------------------------------------------------------- browser

export const CHROMIUM_ARGS = [
  '--no-sandbox',
  '--use-angle=swiftshader', '--enable-unsafe-swiftshader', '--ignore-gpu-blocklist',
  '--disable-background-networking', '--disable-component-update', '--no-first-run',
  '--disable-sync', '--disable-quic', '--disable-default-apps', '--disable-extensions',
  '--no-default-browser-check', '--mute-audio',
];

export async function launchBrowser() {
  if (!fs.existsSync(CHROMIUM)) {
    throw new Error(`chromium not found at ${CHROMIUM}: apt-get install chromium (or set CHROMIUM)`);
  }
  // playwright's launch() uses a fresh temporary profile (user-data-dir) and removes it at close.
  return chromium.launch({ executablePath: CHROMIUM, headless: true, args: CHROMIUM_ARGS, timeout: 60000 });
}

/** A new context + page at `viewport`, recording diagnostics:
 *  page.diag = {consoleErrors: [], pageErrors: [], requests: [{url, method, headers}], dialogs: []}.
 *  Dialogs (confirm/alert) are accepted. */
export async function openPage(browser, { viewport = { width: 1280, height: 800 } } = {}) {
  const context = await browser.newContext({ viewport, deviceScaleFactor: 1 });
  const page = await context.newPage();
  const diag = { consoleErrors: [], pageErrors: [], requests: [], dialogs: [], console: [] };
  page.on('console', (m) => {
    const rec = `${m.type()}: ${m.text()}`;
    diag.console.push(rec);
    if (m.type() === 'error') diag.consoleErrors.push(m.text());
  });
  page.on('pageerror', (e) => diag.pageErrors.push(String(e && e.stack || e)));
  page.on('request', (r) => diag.requests.push({ url: r.url(), method: r.method(), headers: r.headers() }));
  page.on('dialog', async (dlg) => { diag.dialogs.push(`${dlg.type()}: ${dlg.message()}`); await dlg.accept(); });
  page.diag = diag;
  page.setDefaultTimeout(20000);
  return page;
}

/** Console errors other than the browser's own "Failed to load resource: ... status of NNN"
 *  for the listed statuses (expected answers such as the first 401 or a 422 under test). */
export function unexpectedConsoleErrors(page, allowedStatuses = []) {
  return page.diag.consoleErrors.filter((t) => {
    const m = /Failed to load resource: the server responded with a status of (\d+)/.exec(t);
    return !(m && allowedStatuses.includes(Number(m[1])));
  });
}

/** Log in through the token form: go to /ui/ (or `hash`), wait for the form, submit the token,
 *  wait until body[data-ready] equals `ready`. */
export async function login(page, daemon, { hash = '#/jobs', ready = 'jobs', token = daemon.token } = {}) {
  await page.goto(`${daemon.base}/ui/${hash}`);
  await page.locator('#token-form').waitFor({ state: 'visible' });
  await page.fill('#token-input', token);
  await page.click('#token-submit');
  if (ready) await waitReady(page, ready);
}

/** Wait for document.body.dataset.ready === value (fail early on body[data-error]). */
export async function waitReady(page, value, timeout = 30000) {
  const handle = await page.waitForFunction((v) => {
    const b = document.body;
    if (b.dataset.error) return { error: b.dataset.error };
    return b.dataset.ready === v ? { ok: true } : null;
  }, value, { timeout, polling: 100 });
  const r = await handle.jsonValue();
  if (r.error) throw new Error(`page reported an error while waiting for data-ready=${value}: ${r.error}`);
}

/** Wait for two animation frames (so that a render requested by the last action is on screen). */
export function nextFrames(page, n = 2) {
  return page.evaluate((k) => new Promise((res) => {
    let i = 0; const f = () => (++i >= k ? res() : requestAnimationFrame(f)); requestAnimationFrame(f);
  }), n);
}

/** The 3-D canvas's render state (window.fragsimViewer.renderState()):
 *  {settled, settledFrames, topView, moving}, or null without a 3-D view. */
export function renderState(page) {
  return page.evaluate(() => (window.fragsimViewer && window.fragsimViewer.renderState ? window.fragsimViewer.renderState() : null));
}

/** Wait until the canvas shows a full-quality (settled) frame drawn after `sinceFrames` settled
 *  frames (take renderState().settledFrames before the action that changes the view). */
export async function waitSettled(page, sinceFrames = 0, timeout = 15000) {
  await page.waitForFunction((n) => {
    const s = window.fragsimViewer && window.fragsimViewer.renderState && window.fragsimViewer.renderState();
    return s && s.settled && s.settledFrames > n;
  }, sinceFrames, { timeout, polling: 50 });
}

/** Input coordinates [x, y, z] -> canvas CSS pixels {x, y, clientX, clientY, inside}, with the
 *  page's own camera (window.fragsimViewer.project). `points` may be one point or an array. */
/** Waits for the full-quality frame that follows the last camera motion (or takes the one drawn
 *  already), then projects `point` with the settled camera. */
export async function settledProjection(page, point) {
  const st = await renderState(page);
  await waitSettled(page, st.moving ? st.settledFrames : st.settledFrames - 1);
  return project(page, point);
}

export function project(page, points) {
  return page.evaluate((ps) => (Array.isArray(ps[0]) ? ps.map((p) => window.fragsimViewer.project(p))
    : window.fragsimViewer.project(ps)), points);
}

let shotCounter = 0;
/** Screenshot the page (or a locator) into SCREENSHOT_DIR/<name>.png; returns the PNG buffer. */
export async function screenshot(target, name, opts = {}) {
  fs.mkdirSync(SCREENSHOT_DIR, { recursive: true });
  const file = path.join(SCREENSHOT_DIR, `${name}.png`);
  shotCounter++;
  return target.screenshot({ path: file, ...opts });
}

// ---------------------------------------------------------------- PNG pixel statistics

/** Decode an 8-bit non-interlaced PNG (greyscale, RGB, RGBA, grey+alpha):
 *  {width, height, channels, data (Buffer, rows of width*channels bytes)}. */
export function decodePng(buf) {
  if (buf.readUInt32BE(0) !== 0x89504e47) throw new Error('not a PNG');
  let pos = 8, width = 0, height = 0, bitDepth = 0, colorType = 0, interlace = 0;
  const idat = [];
  while (pos < buf.length) {
    const len = buf.readUInt32BE(pos); const type = buf.toString('latin1', pos + 4, pos + 8);
    const data = buf.subarray(pos + 8, pos + 8 + len);
    if (type === 'IHDR') {
      width = data.readUInt32BE(0); height = data.readUInt32BE(4);
      bitDepth = data[8]; colorType = data[9]; interlace = data[12];
    } else if (type === 'IDAT') idat.push(data);
    else if (type === 'IEND') break;
    pos += 12 + len;
  }
  const channels = { 0: 1, 2: 3, 4: 2, 6: 4 }[colorType];
  if (bitDepth !== 8 || !channels || interlace) {
    throw new Error(`unsupported PNG (depth ${bitDepth}, colour type ${colorType}, interlace ${interlace})`);
  }
  const raw = zlib.inflateSync(Buffer.concat(idat));
  const stride = width * channels;
  const img = Buffer.alloc(stride * height);
  let prev = Buffer.alloc(stride);
  for (let y = 0; y < height; y++) {
    const f = raw[y * (stride + 1)];
    const line = raw.subarray(y * (stride + 1) + 1, (y + 1) * (stride + 1));
    const out = img.subarray(y * stride, (y + 1) * stride);
    for (let i = 0; i < stride; i++) {
      const a = i >= channels ? out[i - channels] : 0, b = prev[i], c = i >= channels ? prev[i - channels] : 0;
      let v = line[i];
      if (f === 1) v += a;
      else if (f === 2) v += b;
      else if (f === 3) v += (a + b) >> 1;
      else if (f === 4) { const p = a + b - c, pa = Math.abs(p - a), pb = Math.abs(p - b), pc = Math.abs(p - c); v += pa <= pb && pa <= pc ? a : pb <= pc ? b : c; }
      out[i] = v & 255;
    }
    prev = out;
  }
  return { width, height, channels, data: img };
}

/** [r, g, b] of pixel (x, y) of a decodePng() image (integers, clamped to the image). */
export function pixelAt(image, x, y) {
  const xi = Math.min(Math.max(Math.floor(x), 0), image.width - 1);
  const yi = Math.min(Math.max(Math.floor(y), 0), image.height - 1);
  const i = (yi * image.width + xi) * image.channels;
  const d = image.data;
  return image.channels >= 3 ? [d[i], d[i + 1], d[i + 2]] : [d[i], d[i], d[i]];
}

/** PNG statistics: {width, height, distinct, dominantFraction, opaqueFraction}. */
export function pngStats(buf) {
  const { width, height, channels, data: img } = decodePng(buf);
  const counts = new Map();
  let opaque = 0;
  for (let i = 0; i < img.length; i += channels) {
    let key;
    if (channels >= 3) key = (img[i] << 16) | (img[i + 1] << 8) | img[i + 2];
    else key = img[i];
    const alpha = channels === 4 ? img[i + 3] : channels === 2 ? img[i + 1] : 255;
    if (alpha > 0) opaque++;
    counts.set(key, (counts.get(key) || 0) + 1);
  }
  const n = width * height;
  let dominant = 0;
  for (const c of counts.values()) dominant = Math.max(dominant, c);
  return { width, height, distinct: counts.size, dominantFraction: n ? dominant / n : 1, opaqueFraction: n ? opaque / n : 0 };
}

/** Pixel statistics of a canvas, from the compositor (element screenshot; saved as `name`). */
export async function canvasStats(page, selector, name) {
  const loc = page.locator(selector);
  const png = name ? await screenshot(loc, name) : await loc.screenshot();
  return { png, ...pngStats(png) };
}

/** A canvas's own buffer via toDataURL() (needs preserveDrawingBuffer for WebGL), decoded:
 *  decodePng()'s result plus cssWidth/cssHeight (the element's CSS size) and png. */
export async function canvasImage(page, selector) {
  const r = await page.$eval(selector, (c) => {
    const b = c.getBoundingClientRect();
    return { url: c.toDataURL('image/png'), cssWidth: b.width, cssHeight: b.height };
  });
  const png = Buffer.from(r.url.slice(r.url.indexOf(',') + 1), 'base64');
  return { ...decodePng(png), cssWidth: r.cssWidth, cssHeight: r.cssHeight, png };
}

/** Pixel statistics of a canvas's own buffer via toDataURL() (needs preserveDrawingBuffer for WebGL). */
export async function canvasDataUrlStats(page, selector) {
  const url = await page.$eval(selector, (c) => c.toDataURL('image/png'));
  return pngStats(Buffer.from(url.slice(url.indexOf(',') + 1), 'base64'));
}

/** The first visible <canvas> among `selectors` (then any visible canvas); returns a selector. */
export async function visibleCanvas(page, selectors = ['#scene-canvas']) {
  for (const s of selectors) {
    if (await page.locator(s).first().isVisible().catch(() => false)) return s;
  }
  const idx = await page.$$eval('canvas', (cs) => cs.findIndex((c) => c.offsetParent !== null && c.width > 0));
  if (idx < 0) throw new Error('no visible canvas');
  return `canvas >> nth=${idx}`;
}

/** The token must not leak: not in any request URL, not in localStorage, not in cookies. */
export async function tokenLeaks(page, token) {
  const leaks = [];
  for (const r of page.diag.requests) {
    if (r.url.includes(token) || r.url.includes(encodeURIComponent(token))) leaks.push(`request URL ${r.url}`);
  }
  const storage = await page.evaluate(() => {
    const out = { local: [], cookie: document.cookie };
    for (let i = 0; i < localStorage.length; i++) {
      const k = localStorage.key(i); out.local.push(`${k}=${localStorage.getItem(k)}`);
    }
    return out;
  });
  for (const e of storage.local) if (e.includes(token)) leaks.push(`localStorage entry ${e.split('=')[0]}`);
  if (storage.cookie.includes(token)) leaks.push('document.cookie');
  if (page.url().includes(token)) leaks.push(`page URL ${page.url()}`);
  return leaks;
}

/** End of a test file: collect the token leaks of `page`, close the browser, stop the daemon
 *  (always), then fail if the token leaked. */
export async function finish({ page, browser, daemon }) {
  let leaks = [];
  try {
    if (page && daemon?.token) leaks = await tokenLeaks(page, daemon.token);
  } catch { /* page already gone */ } finally {
    try { await browser?.close(); } finally { await daemon?.stop(); }
  }
  if (leaks.length) throw new Error(`token leaked: ${leaks.join('; ')}`);
}

// ---------------------------------------------------------------- scene (FSSCENE1)

/** Parse a binary scene (CONTRACT.md "NEW binary route") without checks:
 *  {header, offset: offset_m, buildingIds, arrays: {name: TypedArray}}. */
export function parseSceneBuffer(buf) {
  if (buf.toString('latin1', 0, 8) !== 'FSSCENE1') throw new Error('not a FSSCENE1 buffer');
  const H = buf.readUInt32LE(8);
  const header = JSON.parse(buf.toString('utf8', 12, 12 + H));
  const start = 12 + H;
  const arrays = {};
  for (const [name, a] of Object.entries(header.arrays)) {
    const ab = buf.buffer.slice(buf.byteOffset + start + a.offset, buf.byteOffset + start + a.offset + a.bytes);
    const Type = { f32: Float32Array, u32: Uint32Array, u16: Uint16Array }[a.type] || Uint8Array;
    arrays[name] = new Type(ab);
  }
  return { header, offset: header.offset_m || [0, 0, 0], buildingIds: header.building_ids || [], arrays };
}

/** GET /v1/jobs/{id}/scene (no trajectories), parsed. */
export async function jobScene(daemon, id) {
  const r = await daemon.request(`/v1/jobs/${id}/scene?max_trajectories=0`);
  if (r.status !== 200) throw new Error(`GET /v1/jobs/${id}/scene -> ${r.status} ${r.text().slice(0, 300)}`);
  return parseSceneBuffer(r.body);
}

/** Centroid of terrain triangle t in input coordinates (scene position + offset_m). */
export function terrainCentroid(scene, t) {
  const V = scene.arrays.terrain_vertices, T = scene.arrays.terrain_triangles, o = scene.offset;
  const c = [0, 0, 0];
  for (let k = 0; k < 3; k++) for (let j = 0; j < 3; j++) c[j] += V[3 * T[3 * t + k] + j] / 3;
  return c.map((v, j) => v + o[j]);
}

/** Text of a summary-table value cell. */
export async function summaryValue(page, key) {
  return (await page.locator(`#summary-table tr[data-key="${key}"] td.value`).innerText()).trim();
}

export function fmtDiag(page) {
  const d = page.diag;
  return `console errors: ${JSON.stringify(d.consoleErrors)}\npage errors: ${JSON.stringify(d.pageErrors)}\n` +
    `last console: ${JSON.stringify(d.console.slice(-15))}`;
}
