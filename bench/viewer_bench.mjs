#!/usr/bin/env node
// Browser benchmark of the fragsimd web viewer: scene download, load time to first frame and
// rotation frame times, for a job view and a site view, on the demo site (80,000 terrain
// triangles) and on a ~1,000,000-triangle grid version of it.
//
//   (cd viewer/test && npm ci --no-audit --no-fund)      # once (or run viewer/test/run.sh once)
//   node bench/viewer_bench.mjs [--out out/viewer-bench.json] [--runs 3] [--frames 120]
//                               [--cases demo,large] [--nx 707]
//                               [--demo-samples-scale 1] [--large-samples-scale 8]
//
// Uses viewer/test's node_modules (playwright-core, driving Debian's /usr/bin/chromium, headless,
// software WebGL through SwiftShader: the figures are CPU-rendering figures, not GPU ones) and
// viewer/test/harness.mjs. Environment: FRAGSIMD, CHROMIUM, FRAGSIM_UI_DIR as for the tests.
// Window 1400 x 900. Prints a table and writes JSON (default <repo>/out/viewer-bench.json);
// screenshots of each view go to <repo>/out/viewer-bench/.
//
// Per case: the scenario's site is uploaded (POST /v1/sites), the job submitted with its site_id
// and run to completion; then
//   - scene bytes and download time from node (GET /v1/{jobs,sites}/{id}/scene, median of runs),
//   - in the page, per run (a page reload after one unmeasured warm-up load): loadMs =
//     window.fragsimViewer.loadMs (route start to first frame: fetch + parse + build), the wall
//     time from reload to body[data-ready] (includes loading the page's modules: "to ready"),
//     when the last /ui/ asset arrived, and the browser's resource timing of the scene request,
//   - rotation: window.fragsimViewer.measureRotation(frames) -> mean and p95 frame time (ms).

import fs from 'node:fs';
import os from 'node:os';
import path from 'node:path';
import { fileURLToPath } from 'node:url';
import { parseArgs } from 'node:util';

const here = path.dirname(fileURLToPath(import.meta.url));
const repo = path.resolve(here, '..');
let h;
try {
  h = await import(path.join(repo, 'viewer', 'test', 'harness.mjs'));
} catch (e) {
  console.error(`viewer_bench: cannot load viewer/test/harness.mjs (${e.message}).\n` +
    'Install its dependencies first: (cd viewer/test && npm ci --no-audit --no-fund)');
  process.exit(1);
}

const { values: opt } = parseArgs({
  options: {
    out: { type: 'string', default: path.join(repo, 'out', 'viewer-bench.json') },
    runs: { type: 'string', default: '3' },
    frames: { type: 'string', default: '120' },
    cases: { type: 'string', default: 'demo,large' },
    nx: { type: 'string', default: '707' },
    'demo-samples-scale': { type: 'string', default: '1' },
    'large-samples-scale': { type: 'string', default: '8' },
  },
});
const RUNS = Math.max(1, Number(opt.runs));
const FRAMES = Math.max(10, Number(opt.frames));
const NX = Number(opt.nx); // cells per side of the large grid
const DEMO_SCALE = Number(opt['demo-samples-scale']);
const LARGE_SCALE = Number(opt['large-samples-scale']);
const VIEWPORT = { width: 1400, height: 900 };
const SHOT_DIR = path.join(repo, 'out', 'viewer-bench');

const median = (a) => { const s = [...a].sort((x, y) => x - y); const n = s.length; return n ? (n % 2 ? s[(n - 1) / 2] : (s[n / 2 - 1] + s[n / 2]) / 2) : null; };
const round = (x, d = 1) => (x == null ? null : Math.round(x * 10 ** d) / 10 ** d);

/** The demo scenario with its 201 x 201 (10 m) grid resampled bilinearly onto (nx+1)^2 vertices
 *  over the same 2 km x 2 km: 2 nx^2 triangles, same hill, berm and buildings. */
function largeScenario(nx) {
  const s = h.demoScenario(LARGE_SCALE);
  const g = s.site.terrain.grid;
  const n = nx + 1;
  const ext = (g.nx - 1) * g.spacing_m;
  const spacing = ext / nx;
  const z = new Array(n * n);
  for (let j = 0; j < n; j++) {
    const fy = Math.min((j * spacing) / g.spacing_m, g.ny - 1 - 1e-9);
    const j0 = Math.floor(fy), ty = fy - j0;
    for (let i = 0; i < n; i++) {
      const fx = Math.min((i * spacing) / g.spacing_m, g.nx - 1 - 1e-9);
      const i0 = Math.floor(fx), tx = fx - i0;
      const e = (ii, jj) => g.elevation_m[jj * g.nx + ii];
      const v = (1 - tx) * (1 - ty) * e(i0, j0) + tx * (1 - ty) * e(i0 + 1, j0) +
        (1 - tx) * ty * e(i0, j0 + 1) + tx * ty * e(i0 + 1, j0 + 1);
      z[j * n + i] = Math.round(v * 1000) / 1000;
    }
  }
  s.site.terrain.grid = { origin_m: g.origin_m, spacing_m: spacing, nx: n, ny: n, elevation_m: z };
  s.description = `viewer benchmark: the demo site resampled to ${n} x ${n} vertices (${2 * nx * nx} triangles)`;
  return s;
}

async function nodeFetch(daemon, p) {
  const times = [];
  let bytes = 0;
  for (let r = 0; r < RUNS; r++) {
    const t0 = performance.now();
    const res = await daemon.request(p);
    times.push(performance.now() - t0);
    if (res.status !== 200) throw new Error(`GET ${p} -> ${res.status} ${res.text().slice(0, 300)}`);
    bytes = res.body.length;
  }
  return { bytes, ms_median: round(median(times)), ms_runs: times.map((t) => round(t)) };
}

async function measureView(page, daemon, hash, ready, label) {
  const url = `${daemon.base}/ui/${hash}`;
  // Warm-up: open the view once (token form if asked), not measured.
  await page.goto(url);
  if (await page.locator('#token-form').isVisible().catch(() => false)) {
    await page.fill('#token-input', daemon.token);
    await page.click('#token-submit');
  }
  await h.waitReady(page, ready, 300000);
  const runs = [];
  for (let r = 0; r < RUNS; r++) {
    const t0 = Date.now();
    await page.reload({ waitUntil: 'commit' });
    await h.waitReady(page, ready, 300000);
    const wall = Date.now() - t0;
    const v = await page.evaluate(() => {
      const fv = window.fragsimViewer || {};
      const entries = performance.getEntriesByType('resource');
      const res = entries.filter((e) => /\/scene(\?|$)/.test(e.name)).at(-1);
      const assets = entries.filter((e) => /\/ui\//.test(e.name));
      return {
        loadMs: fv.loadMs, triangles: fv.triangles,
        scene: res ? { url: res.name.replace(location.origin, ''), transferSize: res.transferSize, encodedBodySize: res.encodedBodySize, ms: res.responseEnd - res.startTime, ttfbMs: res.responseStart - res.startTime } : null,
        assetsDoneMs: assets.length ? Math.max(...assets.map((e) => e.responseEnd)) : null,
        heapMB: performance.memory ? performance.memory.usedJSHeapSize / 2 ** 20 : null,
      };
    });
    runs.push({ wallToReadyMs: wall, ...v });
  }
  await h.nextFrames(page);
  fs.mkdirSync(SHOT_DIR, { recursive: true });
  await page.screenshot({ path: path.join(SHOT_DIR, `${label}.png`) });
  const rot = await page.evaluate((n) => window.fragsimViewer.measureRotation(n), FRAMES);
  const last = runs.at(-1);
  return {
    triangles: last.triangles,
    load_ms_median: round(median(runs.map((x) => x.loadMs))),
    wall_to_ready_ms_median: round(median(runs.map((x) => x.wallToReadyMs))),
    page_assets_loaded_ms_median: round(median(runs.map((x) => x.assetsDoneMs))),
    scene_browser: last.scene ? { ...last.scene, ms: round(last.scene.ms), ttfbMs: round(last.scene.ttfbMs) } : null,
    js_heap_mb: round(last.heapMB),
    rotation: {
      frames: rot.frames, mean_ms: round(rot.meanMs, 2), p95_ms: round(rot.p95Ms, 2), fps: round(1000 / rot.meanMs, 1),
      // what the page reports besides (the viewer draws a decimated terrain at a lower pixel ratio
      // while the camera moves, then one full-quality frame: settle_ms)
      settle_ms: round(rot.settleMs), interactive_triangles: rot.interactiveTriangles ?? null,
      full_triangles: rot.fullTriangles ?? null, interactive_pixel_ratio: rot.interactivePixelRatio ?? null,
      full_pixel_ratio: rot.fullPixelRatio ?? null,
    },
    runs: runs.map((x) => ({ load_ms: round(x.loadMs), wall_to_ready_ms: x.wallToReadyMs, page_assets_loaded_ms: round(x.assetsDoneMs), scene_ms: round(x.scene?.ms) })),
  };
}

async function main() {
  const cases = opt.cases.split(',').map((c) => c.trim()).filter(Boolean);
  const daemon = await h.startDaemon();
  const browser = await h.launchBrowser();
  const out = {
    bench: 'viewer_bench', date_utc: new Date().toISOString(),
    machine: { cpus: os.cpus().length, cpu_model: os.cpus()[0]?.model, mem_gb: round(os.totalmem() / 2 ** 30), node: process.version },
    chromium: browser.version(), chromium_args: h.CHROMIUM_ARGS, viewport: VIEWPORT, runs: RUNS, frames: FRAMES,
    fragsimd: h.FRAGSIMD, ui_dir: h.UI_DIR || '(embedded)',
    cases: {},
  };
  try {
    const page = await h.openPage(browser, { viewport: VIEWPORT });
    await h.login(page, daemon);
    out.webgl = await page.evaluate(() => {
      const c = document.createElement('canvas');
      const gl = c.getContext('webgl2') || c.getContext('webgl');
      if (!gl) return null;
      const e = gl.getExtension('WEBGL_debug_renderer_info');
      return {
        version: gl.getParameter(gl.VERSION),
        vendor: e ? gl.getParameter(e.UNMASKED_VENDOR_WEBGL) : gl.getParameter(gl.VENDOR),
        renderer: e ? gl.getParameter(e.UNMASKED_RENDERER_WEBGL) : gl.getParameter(gl.RENDERER),
      };
    });
    console.error(`viewer_bench: chromium ${out.chromium}, WebGL renderer: ${out.webgl?.renderer}`);

    for (const name of cases) {
      let scen;
      if (name === 'demo') scen = h.demoScenario(DEMO_SCALE);
      else if (name === 'large') scen = largeScenario(NX);
      else throw new Error(`unknown case ${name} (demo, large)`);
      scen.settings.record_trajectories = true;
      const { site, job } = h.splitScenario(scen);
      const body = JSON.stringify(site);
      console.error(`viewer_bench: ${name}: uploading the site (${(body.length / 2 ** 20).toFixed(1)} MiB JSON)`);
      let t0 = performance.now();
      const siteSummary = await daemon.uploadSite(body);
      const uploadMs = performance.now() - t0;
      job.site_id = siteSummary.site_id;
      t0 = performance.now();
      const st = await daemon.submitJob(job);
      await daemon.waitForState(st.job_id, 'done', 600000, 250);
      const jobMs = performance.now() - t0;
      const summary = await daemon.expectOk(`/v1/jobs/${st.job_id}/summary`);
      console.error(`viewer_bench: ${name}: ${siteSummary.terrain_triangles} terrain triangles; job ${st.job_id} done in ${(jobMs / 1000).toFixed(1)} s`);

      const c = {
        terrain_triangles: siteSummary.terrain_triangles, building_triangles: siteSummary.building_triangles,
        site_upload_ms: round(uploadMs), job_wall_s: round(summary.timing.wall_s, 2), samples: summary.samples,
        job_id: st.job_id, site_id: siteSummary.site_id,
        scene_download: {
          job: await nodeFetch(daemon, `/v1/jobs/${st.job_id}/scene`),
          site: await nodeFetch(daemon, `/v1/sites/${siteSummary.site_id}/scene`),
        },
      };
      console.error(`viewer_bench: ${name}: job view`);
      c.job_view = await measureView(page, daemon, `#/jobs/${st.job_id}`, 'job', `${name}-job`);
      console.error(`viewer_bench: ${name}: site view`);
      c.site_view = await measureView(page, daemon, `#/sites/${siteSummary.site_id}`, 'site', `${name}-site`);
      out.cases[name] = c;
    }
    out.page_errors = page.diag.pageErrors;
    out.console_errors = h.unexpectedConsoleErrors(page, [401]);
  } finally {
    await browser.close();
    await daemon.stop();
  }

  fs.mkdirSync(path.dirname(path.resolve(opt.out)), { recursive: true });
  fs.writeFileSync(opt.out, JSON.stringify(out, null, 2) + '\n');

  const rows = [['case', 'view', 'triangles', 'scene MiB', 'download ms', 'loadMs', 'assets ms', 'to ready ms', 'rot mean ms', 'rot p95 ms', 'fps', 'moving tris', 'settled ms']];
  for (const [name, c] of Object.entries(out.cases)) {
    for (const v of ['job', 'site']) {
      const m = c[`${v}_view`], d = c.scene_download[v];
      rows.push([name, v, String(m.triangles ?? c.terrain_triangles), (d.bytes / 2 ** 20).toFixed(2), String(d.ms_median),
        String(m.load_ms_median), String(m.page_assets_loaded_ms_median), String(m.wall_to_ready_ms_median), String(m.rotation.mean_ms), String(m.rotation.p95_ms), String(m.rotation.fps),
        String(m.rotation.interactive_triangles ?? '-'), String(m.rotation.settle_ms ?? '-')]);
    }
  }
  const w = rows[0].map((_, i) => Math.max(...rows.map((r) => r[i].length)));
  console.log(`viewer bench: ${out.machine.cpus} CPU (${out.machine.cpu_model}), chromium ${out.chromium}, ${VIEWPORT.width}x${VIEWPORT.height}`);
  console.log(`WebGL renderer: ${out.webgl?.renderer} (software rendering)`);
  for (const r of rows) console.log(r.map((x, i) => (i < 2 ? x.padEnd(w[i]) : x.padStart(w[i]))).join('  '));
  console.log(`(download: node fetch of the scene, median of ${RUNS}; loadMs: window.fragsimViewer.loadMs (route start -> first frame), assets ms: reload -> last /ui/ file, to ready ms: reload -> body[data-ready], medians of ${RUNS} reloads; rotation: measureRotation(${FRAMES}); moving tris: triangles drawn while rotating (the page's LOD), settled ms: the full-quality frame after)`);
  if (out.page_errors.length || out.console_errors.length) {
    console.log(`page errors: ${JSON.stringify(out.page_errors)}\nconsole errors: ${JSON.stringify(out.console_errors)}`);
  }
  console.log(`written ${opt.out}`);
}

main().catch((e) => { console.error(`viewer_bench: ${e.stack || e}`); process.exit(1); });
