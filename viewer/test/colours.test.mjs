// Density colours are right, not just "many colours". Minimal scenario (flat plane: the shading
// factor is exactly 1 on level ground, so a triangle's pixels show its colour as it is), top view,
// overlays off (trajectories, contour, HFD, sectors). Pixels read with toDataURL() at the projected
// centroids (window.fragsimViewer.project) once the settled full-quality frame is drawn:
// - the triangle of the largest density (summary.max_ptn_triangle) = the top colour of the legend's
//   scale: viridis(1) of the page's own colormap module and the legend bar's top end;
// - a zero-density triangle far from any non-zero one = ZERO_GREY (neutral grey);
// - a mid-scale triangle = the page's viridis LUT at its log-scale position.
import assert from 'node:assert/strict';
import { after, before, test } from 'node:test';
import * as h from './harness.mjs';

let daemon, browser, page, run, scene, cmap;

const TOL = 8;  // per channel: settled frame (MSAA resolve, 8-bit), shading 1 on flat ground

before(async () => {
  daemon = await h.startDaemon();
  browser = await h.launchBrowser();
  run = await daemon.runScenario(h.minimalScenario());
  scene = await h.jobScene(daemon, run.job.job_id);
  page = await h.openPage(browser, { viewport: { width: 1400, height: 900 } });
  await h.login(page, daemon, { hash: `#/jobs/${run.job.job_id}`, ready: 'job' });
  page.diag.consoleErrors.length = 0; // the 401 before the token was given is expected
  // The page's own colour map (the same module instance as the page's: same URL).
  cmap = await page.evaluate(async () => {
    const m = await import(new URL('src/colormap.js', document.baseURI).href);
    return { top: m.viridis(1).map(Math.round), bottom: m.viridis(0).map(Math.round), grey: m.ZERO_GREY, lut: Array.from(m.lut(m.viridis)) };
  });
});

after(async () => {
  await h.finish({ page, browser, daemon });
});

const fmt = (c) => `rgb(${c.join(', ')})`;
function near(got, want, tol, what) {
  const d = Math.max(...got.map((v, i) => Math.abs(v - want[i])));
  assert.ok(d <= tol, `${what}: canvas pixel ${fmt(got)}, expected ≈ ${fmt(want)} (± ${tol}; off by ${d})`);
}

/** Top view, overlays off, settled frame drawn. */
async function topViewSettled() {
  const n0 = (await h.renderState(page)).settledFrames;
  await page.click('#toggle-2d');
  for (const layer of ['trajectories', 'contour', 'hfd', 'sectors']) {
    const box = page.locator(`#layer-${layer}`);
    if (await box.count()) await box.uncheck();
  }
  await h.waitSettled(page, n0);
  const st = await h.renderState(page);
  assert.equal(st.topView, true, 'not in the top view after #toggle-2d');
}

function pixelOf(img, p) {
  const sx = img.width / img.cssWidth, sy = img.height / img.cssHeight;
  return h.pixelAt(img, p.x * sx, p.y * sy);
}

test('zero density is neutral grey, mid density is the LUT colour (top view, settled frame)', { timeout: 60000 }, async () => {
  await page.locator('#scene-canvas').scrollIntoViewIfNeeded();
  await topViewSettled();
  const D = scene.arrays.density_per_m2;
  const m = D.length;
  const cent = Array.from({ length: m }, (_, t) => h.terrainCentroid(scene, t));
  const nonzero = [];
  for (let t = 0; t < m; t++) if (D[t] > 0) nonzero.push(t);
  assert.ok(nonzero.length > 0 && nonzero.length < m, `need zero and non-zero triangles (${nonzero.length} of ${m} non-zero)`);

  // Zero-density triangles, farthest from any non-zero triangle and from the building first.
  const fp = h.minimalScenario().site.buildings[0].footprint_m;
  const bx = fp.reduce((s, p) => s + p[0], 0) / fp.length, by = fp.reduce((s, p) => s + p[1], 0) / fp.length;
  const zeros = [];
  for (let t = 0; t < m; t++) {
    if (D[t] > 0) continue;
    const c = cent[t];
    let dmin = Math.hypot(c[0] - bx, c[1] - by) - 20;
    for (const u of nonzero) dmin = Math.min(dmin, Math.hypot(c[0] - cent[u][0], c[1] - cent[u][1]));
    zeros.push({ t, dmin });
  }
  zeros.sort((a, b) => b.dmin - a.dmin);
  // The farthest lie outside the top view (minimal's 3 km plane reaches far beyond the HFD the
  // view is framed on): the farthest of those inside.
  const candidates = zeros;
  const proj = await h.project(page, candidates.map((z) => cent[z.t]));
  const k = proj.findIndex((p) => p.inside && p.x > 20 && p.y > 20 && p.x < 1e9);
  assert.ok(k >= 0, 'no far zero-density triangle inside the top view');
  const zero = { ...candidates[k], p: proj[k] };
  assert.ok(zero.dmin >= 12, `the zero-density triangle chosen is only ${zero.dmin.toFixed(1)} m from a non-zero one`);

  // A mid-scale triangle (log position 0.35..0.65), the one nearest 0.5.
  const thr = run.summary.hfd_threshold_per_m2, dmax = run.summary.max_ptn_density_per_m2;
  const l0 = Math.log10(thr / 100), l1 = Math.log10(dmax);
  const tOf = (d) => Math.min(Math.max((Math.log10(d) - l0) / (l1 - l0), 0), 1);
  const mids = nonzero.filter((t) => Math.abs(tOf(D[t]) - 0.5) < 0.15).sort((a, b) => Math.abs(tOf(D[a]) - 0.5) - Math.abs(tOf(D[b]) - 0.5));
  assert.ok(mids.length > 0, 'no triangle in the middle of the colour scale');
  const midProj = await h.project(page, mids.slice(0, 20).map((t) => cent[t]));
  const j = midProj.findIndex((p) => p.inside);
  assert.ok(j >= 0, 'no mid-scale triangle inside the view');
  const mid = { t: mids[j], p: midProj[j] };

  const img = await h.canvasImage(page, '#scene-canvas');
  await h.screenshot(page.locator('#scene-canvas'), 'colours-1-top-view');
  const zpx = pixelOf(img, zero.p);
  console.log(`# zero-density triangle ${zero.t} at ${cent[zero.t].map((v) => v.toFixed(1))} (${zero.dmin.toFixed(1)} m from non-zero) -> px (${zero.p.x.toFixed(1)}, ${zero.p.y.toFixed(1)}) ${fmt(zpx)}`);
  assert.ok(Math.max(...zpx) - Math.min(...zpx) <= 6, `zero-density pixel ${fmt(zpx)} is not a neutral grey`);
  near(zpx, cmap.grey, TOL, 'zero-density triangle');
  // viridis has no grey: the zero colour must not be a viridis colour either.
  assert.ok(Math.max(...cmap.top) - Math.min(...cmap.top) > 100, 'viridis top is not saturated (colormap changed?)');

  const li = 3 * Math.round(tOf(D[mid.t]) * 255);
  const want = cmap.lut.slice(li, li + 3);
  const mpx = pixelOf(img, mid.p);
  console.log(`# mid triangle ${mid.t} density ${D[mid.t].toExponential(3)} t=${tOf(D[mid.t]).toFixed(3)} -> px (${mid.p.x.toFixed(1)}, ${mid.p.y.toFixed(1)}) ${fmt(mpx)}, LUT ${fmt(want)}`);
  near(mpx, want, TOL, `mid-scale triangle (density ${D[mid.t].toExponential(3)} per m², scale position ${tOf(D[mid.t]).toFixed(3)})`);
});

test('the largest density is the top colour of the legend scale (viridis yellow)', { timeout: 60000 }, async () => {
  const tmax = run.summary.max_ptn_triangle;
  assert.ok(Number.isInteger(tmax), `summary.max_ptn_triangle = ${tmax}`);
  const D = scene.arrays.density_per_m2;
  let am = 0;
  for (let t = 0; t < D.length; t++) if (D[t] > D[am]) am = t;
  assert.equal(tmax, am, 'summary.max_ptn_triangle is not the scene\'s densest triangle');
  const c = h.terrainCentroid(scene, tmax);
  const loc = run.summary.max_ptn_location_m;
  if (loc) assert.ok(Math.hypot(c[0] - loc[0], c[1] - loc[1]) < 0.01, `centroid ${c} vs max_ptn_location_m ${loc}`);

  // The launch marker sits next to it (its triangles touch the HFD origin): zoom in on the
  // triangle with the mouse wheel (zoom to cursor) until it is large on screen.
  const origin = run.summary.hfd_origin_m;
  let p = await h.project(page, c);
  for (let i = 0; i < 12; i++) {
    const o = await h.project(page, origin);
    if (Math.hypot(p.x - o.x, p.y - o.y) >= 40) break;
    await page.mouse.move(p.clientX, p.clientY);
    await page.mouse.wheel(0, -400);
    await h.sleep(60);
    p = await h.project(page, c);
  }
  p = await h.settledProjection(page, c);
  const o = await h.project(page, origin);
  assert.ok(p.inside, 'densest triangle not in the view after zooming');
  assert.ok(Math.hypot(p.x - o.x, p.y - o.y) >= 40, `zoom did not separate the triangle from the launch point (${Math.hypot(p.x - o.x, p.y - o.y).toFixed(1)} px)`);

  const img = await h.canvasImage(page, '#scene-canvas');
  await h.screenshot(page.locator('#scene-canvas'), 'colours-2-max-density');
  const px = pixelOf(img, p);
  console.log(`# densest triangle ${tmax} (${D[tmax].toFixed(3)} per m²) at ${c.map((v) => v.toFixed(2))} -> px (${p.x.toFixed(1)}, ${p.y.toFixed(1)}) ${fmt(px)}; viridis(1) ${fmt(cmap.top)}`);
  near(px, cmap.top, TOL, 'densest triangle vs viridis(1)');
  // Viridis yellow whatever the module says: high red and green, low blue.
  assert.ok(px[0] > 200 && px[1] > 190 && px[2] < 90, `densest triangle ${fmt(px)} is not viridis yellow`);

  // The legend's colour bar ends with the same colour: the rightmost saturated pixel of the bar row.
  const bar = await page.$eval('#legend canvas', (cv) => {
    const ctx = cv.getContext('2d');
    const d = ctx.getImageData(0, 0, cv.width, cv.height).data;
    let best = { count: -1, y: 0, right: null };
    for (let y = 0; y < cv.height; y++) {
      let count = 0, right = null;
      for (let x = 0; x < cv.width; x++) {
        const i = 4 * (y * cv.width + x);
        const r = d[i], g = d[i + 1], b = d[i + 2];
        if (d[i + 3] === 255 && Math.max(r, g, b) - Math.min(r, g, b) > 60) { count++; right = [r, g, b]; }
      }
      if (count > best.count) best = { count, y, right };
    }
    return best;
  });
  assert.ok(bar.count > 100 && bar.right, `legend colour bar not found (${JSON.stringify(bar)})`);
  near(bar.right, cmap.top, 4, 'legend bar top end vs viridis(1)');
  near(px, bar.right, TOL, 'densest triangle vs the legend bar\'s top colour');
});

test('no console errors, no page errors', () => {
  assert.deepEqual(page.diag.pageErrors, [], 'page errors');
  assert.deepEqual(page.diag.consoleErrors, [], `console errors\n${h.fmtDiag(page)}`);
});
