// (g) Static routes and HTTP policy, from node (no browser): /ui/ is public and carries the
// Content-Security-Policy; /v1/* needs the token; no CORS headers by default; only index.html,
// src/ and vendor/ are served. Plus the binary scene format of GET /v1/{sites,jobs}/{id}/scene.
import assert from 'node:assert/strict';
import http from 'node:http';
import { after, before, test } from 'node:test';
import * as h from './harness.mjs';

let daemon, run;

before(async () => {
  daemon = await h.startDaemon();
  run = await daemon.runScenario(h.minimalScenario());
});

after(async () => { await daemon?.stop(); });

/** A request with a raw (unnormalised) path. */
function rawGet(base, rawPath, headers = {}) {
  const u = new URL(base);
  return new Promise((resolve, reject) => {
    const req = http.request({ host: u.hostname, port: u.port, path: rawPath, method: 'GET', headers }, (res) => {
      const chunks = [];
      res.on('data', (c) => chunks.push(c));
      res.on('end', () => resolve({ status: res.statusCode, headers: res.headers, body: Buffer.concat(chunks) }));
    });
    req.on('error', reject);
    req.end();
  });
}

test('/ui/ is served without a token, with the Content-Security-Policy', async () => {
  const r = await daemon.request('/ui/', { token: false });
  assert.equal(r.status, 200);
  assert.match(r.headers.get('content-type') || '', /^text\/html/);
  assert.match(r.text(), /<html/i);
  const csp = r.headers.get('content-security-policy');
  assert.ok(csp, 'no Content-Security-Policy header on /ui/');
  for (const d of ["default-src 'self'", "script-src 'self'", "connect-src 'self'", "object-src 'none'",
    "base-uri 'none'", "frame-ancestors 'none'", "style-src 'self'"]) {
    assert.ok(csp.includes(d), `CSP lacks ${d}: ${csp}`);
  }
  assert.ok(!/unsafe-inline|unsafe-eval/.test(csp), `CSP allows unsafe-*: ${csp}`);
  // No inline script in the page (the CSP would block it).
  assert.ok(!/<script(?![^>]*\bsrc=)[^>]*>\s*\S/i.test(r.text()), 'index.html has an inline <script>');
});

test('GET / redirects to /ui/', async () => {
  const r = await daemon.request('/', { token: false });
  assert.ok([301, 302, 303, 307, 308].includes(r.status), `GET / -> ${r.status}`);
  assert.match(r.headers.get('location') || '', /\/ui\/$/);
});

test('the page\'s modules are served with a JavaScript type and the CSP', async () => {
  const html = (await daemon.request('/ui/', { token: false })).text();
  const srcs = [...html.matchAll(/<script[^>]*\bsrc="([^"]+)"/gi)].map((m) => m[1]);
  assert.ok(srcs.length > 0, 'index.html loads no script');
  for (const s of srcs) {
    const u = new URL(s, `${daemon.base}/ui/`);
    const r = await daemon.request(u.pathname, { token: false });
    assert.equal(r.status, 200, `${u.pathname} -> ${r.status}`);
    assert.match(r.headers.get('content-type') || '', /javascript/, `${u.pathname} content-type`);
  }
  const v = await daemon.request('/ui/vendor/three.module.js', { token: false });
  assert.equal(v.status, 200, '/ui/vendor/three.module.js');
  assert.match(v.headers.get('content-type') || '', /javascript/);
});

test('the largest asset is served promptly to a browser (Accept-Encoding of chromium)', async () => {
  // three.core.js (~1.5 MB): on loopback it should take well under a second, compressed or not.
  const headers = { 'Accept-Encoding': 'gzip, deflate, br, zstd' };
  const t0 = performance.now();
  const r = await rawGet(daemon.base, '/ui/vendor/three.core.js', headers);
  const ms = performance.now() - t0;
  assert.equal(r.status, 200);
  const enc = r.headers['content-encoding'] || 'identity';
  console.log(`# three.core.js: ${r.body.length} bytes (${enc}) in ${ms.toFixed(0)} ms`);
  assert.ok(ms < 3000, `GET /ui/vendor/three.core.js with "Accept-Encoding: ${headers['Accept-Encoding']}" took ${ms.toFixed(0)} ms ` +
    `(${enc}, ${r.body.length} bytes): every page load waits for it`);
});

test('only index.html, src/ and vendor/ are served', async () => {
  for (const p of ['/ui/test/harness.mjs', '/ui/test/package.json', '/ui/vendor.sh', '/ui/../CMakeLists.txt',
    '/ui/%2e%2e/CMakeLists.txt', '/ui/src/%2e%2e/%2e%2e/CMakeLists.txt', '/ui/..%2fREADME.md', '/ui/src/../../README.md']) {
    const r = await rawGet(daemon.base, p);
    assert.ok(r.status === 404 || r.status === 400, `${p} -> ${r.status} (expected 404)`);
    assert.ok(!r.body.toString().includes('cmake_minimum_required') && !r.body.toString().includes('# fragsim'), `${p} leaked a repository file`);
  }
});

test('/v1/jobs without a token -> 401; /v1/health stays public', async () => {
  const r = await daemon.request('/v1/jobs', { token: false });
  assert.equal(r.status, 401);
  assert.equal(r.json?.code, 'unauthorized', `401 body: ${r.text()}`);
  assert.match(r.headers.get('www-authenticate') || '', /^Bearer/);
  assert.equal((await daemon.request('/v1/jobs', { token: 'nope' })).status, 401);
  assert.equal((await daemon.request('/v1/health', { token: false })).status, 200);
  assert.equal((await daemon.request(`/v1/jobs/${run.job.job_id}/scene`, { token: false })).status, 401);
  assert.equal((await daemon.request(`/v1/sites/${run.site.site_id}/scene`, { token: false })).status, 401);
});

test('no CORS headers by default', async () => {
  const origin = 'http://evil.example';
  const r = await daemon.request('/v1/jobs', { headers: { Origin: origin } });
  assert.equal(r.status, 200);
  assert.equal(r.headers.get('access-control-allow-origin'), null, 'Access-Control-Allow-Origin on /v1/jobs');
  assert.equal(r.headers.get('access-control-allow-credentials'), null);
  const ui = await daemon.request('/ui/', { token: false, headers: { Origin: origin } });
  assert.equal(ui.headers.get('access-control-allow-origin'), null, 'Access-Control-Allow-Origin on /ui/');
  const pre = await daemon.request('/v1/jobs', {
    method: 'OPTIONS', token: false,
    headers: { Origin: origin, 'Access-Control-Request-Method': 'DELETE', 'Access-Control-Request-Headers': 'authorization' },
  });
  assert.equal(pre.headers.get('access-control-allow-origin'), null, `preflight answered ${pre.status} with Access-Control-Allow-Origin`);
});

// ---- binary scene format (CONTRACT.md "NEW binary route: the scene")

function parseScene(buf) {
  assert.equal(buf.toString('latin1', 0, 8), 'FSSCENE1', 'magic');
  const H = buf.readUInt32LE(8);
  assert.equal((12 + H) % 8, 0, 'header not padded to a multiple of 8');
  const header = JSON.parse(buf.toString('utf8', 12, 12 + H));
  assert.equal(header.format, 'fragsim.scene/1');
  const start = 12 + H;
  const arrays = {};
  const size = { f32: 4, u32: 4, u8: 1 };
  for (const [name, a] of Object.entries(header.arrays)) {
    assert.equal(a.offset % 8, 0, `${name} offset not a multiple of 8`);
    const n = a.shape.reduce((x, y) => x * y, 1);
    assert.equal(a.bytes, n * size[a.type], `${name}: bytes vs shape`);
    assert.ok(start + a.offset + a.bytes <= buf.length, `${name} beyond the end`);
    const ab = buf.buffer.slice(buf.byteOffset + start + a.offset, buf.byteOffset + start + a.offset + a.bytes);
    arrays[name] = { ...a, data: a.type === 'f32' ? new Float32Array(ab) : a.type === 'u32' ? new Uint32Array(ab) : new Uint8Array(ab) };
  }
  return { header, arrays };
}

test('GET /v1/jobs/{id}/scene follows the binary layout', async () => {
  const r = await daemon.request(`/v1/jobs/${run.job.job_id}/scene?max_trajectories=50`);
  assert.equal(r.status, 200, r.text().slice(0, 300));
  assert.match(r.headers.get('content-type') || '', /application\/vnd\.fragsim\.scene/);
  const { header, arrays } = parseScene(r.body);
  const m = run.site.terrain_triangles;
  assert.deepEqual(arrays.terrain_triangles.shape, [m, 3]);
  assert.deepEqual(arrays.density_per_m2.shape, [m]);
  assert.deepEqual(arrays.std_error_per_m2.shape, [m]);
  const nv = arrays.terrain_vertices.shape[0];
  assert.ok(arrays.terrain_triangles.data.every((i) => i < nv), 'terrain index out of range');
  let maxD = 0;
  for (const d of arrays.density_per_m2.data) maxD = Math.max(maxD, d);
  assert.ok(Math.abs(maxD - run.summary.max_ptn_density_per_m2) <= 1e-5 * run.summary.max_ptn_density_per_m2,
    `max density ${maxD} vs summary ${run.summary.max_ptn_density_per_m2}`);
  assert.deepEqual(header.building_ids, run.site.building_ids);
  assert.equal(arrays.building_triangles.shape[0], run.site.building_triangles);
  assert.ok(header.trajectories.recorded > 0, 'record_trajectories was on but none recorded');
  assert.equal(header.trajectories.sent, Math.min(50, header.trajectories.recorded));
  assert.equal(arrays.trajectory_offsets.shape[0], header.trajectories.sent + 1);
  assert.equal(arrays.trajectory_offsets.data.at(-1), arrays.trajectory_points.shape[0]);
  // Input coordinates of the building's footprint corner (60,-10) appear among the vertices.
  const [ox, oy] = header.offset_m;
  const bv = arrays.building_vertices.data;
  let found = false;
  for (let i = 0; i < bv.length; i += 3) if (Math.abs(bv[i] + ox - 60) < 1e-3 && Math.abs(bv[i + 1] + oy + 10) < 1e-3) found = true;
  assert.ok(found, 'building corner (60, -10) not among building_vertices + offset_m');

  const site = await daemon.request(`/v1/sites/${run.site.site_id}/scene`);
  assert.equal(site.status, 200);
  const s = parseScene(site.body);
  assert.deepEqual(s.arrays.terrain_triangles.shape, [m, 3]);
  assert.equal(s.arrays.density_per_m2, undefined, 'a site scene has no densities');
});
