// Terrain coloured by material (issue 24). The minimal scenario with its plane's west half
// (x < 0) a zone of "gravel" and the rest "soil":
// - the site page opens coloured by material (two terrain materials): the legend lists gravel
//   and soil (index order of material_names, not the walls' and roofs' materials) with the
//   palette's first two colours, and the top view shows those colours on each half;
// - the job page opens coloured by PTN density; "Material" brings the same legend and colours,
//   the contour and HFD toggles stay; "PTN density" brings the density legend back.
import assert from 'node:assert/strict';
import { after, before, test } from 'node:test';
import * as h from './harness.mjs';

let daemon, browser, page, run, palette;

const TOL = 8;  // per channel: settled frame (MSAA resolve, 8-bit), shading 1 on flat ground
// Well inside each half, away from the building; inside the job's top view (framed on the HFD).
const GRAVEL_AT = [-300, 200, 0], SOIL_AT = [300, -250, 0];

function zonedScenario() {
  const s = h.minimalScenario();
  s.site.materials.gravel = { friction: 0.6, restitution: 0.1, illustrative: true };
  s.site.terrain.zones = [{ material: 'gravel', polygon_m: [[-1500, -1500], [0, -1500], [0, 1500], [-1500, 1500]] }];
  return s;
}

before(async () => {
  daemon = await h.startDaemon();
  browser = await h.launchBrowser();
  run = await daemon.runScenario(zonedScenario());
  page = await h.openPage(browser, { viewport: { width: 1400, height: 900 } });
  await h.login(page, daemon, { hash: `#/sites/${run.site.site_id}`, ready: 'site' });
  page.diag.consoleErrors.length = 0;  // the 401 before the token was given is expected
  palette = await page.evaluate(async () =>
    (await import(new URL('src/materials.js', document.baseURI).href)).MATERIAL_PALETTE);
});

after(async () => {
  await h.finish({ page, browser, daemon });
});

const fmt = (c) => `rgb(${c.join(', ')})`;
function near(got, want, what) {
  const d = Math.max(...got.map((v, i) => Math.abs(v - want[i])));
  assert.ok(d <= TOL, `${what}: canvas pixel ${fmt(got)}, expected ≈ ${fmt(want)} (± ${TOL}; off by ${d})`);
}

// [{name, color: [r, g, b]}] of the material legend in `legend`.
// Query and read in one synchronous evaluation: the job page renders its legend again when the
// site-plan boundary arrives (job_view.js), and a legend replaced between a query and the read
// leaves detached swatches whose computed colour is empty (seen once under load).
async function materialLegend(legend) {
  return page.evaluate((sel) => [...document.querySelectorAll(`${sel} .key-item.material`)].map((it) => ({
    name: it.dataset.material,
    color: getComputedStyle(it.querySelector('.swatch')).backgroundColor.match(/\d+/g).map(Number),
  })), legend);
}

// The canvas pixels at the two zones' points, in the settled top view.
async function zonePixels(canvas, toggle) {
  const st = await h.renderState(page);
  if (!st.topView) {
    await page.click(toggle);
    await h.waitSettled(page, st.settledFrames);
  }
  const [g, s] = await h.settledProjection(page, [GRAVEL_AT, SOIL_AT]);
  assert.ok(g.inside && s.inside, 'zone points outside the top view');
  await h.nextFrames(page);
  const img = await h.canvasImage(page, canvas);
  const at = (p) => h.pixelAt(img, p.x * img.width / img.cssWidth, p.y * img.height / img.cssHeight);
  return { gravel: at(g), soil: at(s) };
}

test('site page: coloured by material, legend gravel and soil with the palette colours', { timeout: 60000 }, async () => {
  assert.equal(await page.inputValue('#site-colour-select'), 'material');
  const legend = await materialLegend('#site-legend');
  assert.deepEqual(legend.map((e) => e.name), ['gravel', 'soil']);
  assert.deepEqual(legend.map((e) => e.color), [palette[0], palette[1]]);
  const px = await zonePixels('#site-canvas', '#site-toggle-2d');
  await h.screenshot(page.locator('#site-canvas'), 'materials-1-site-top-view');
  near(px.gravel, palette[0], 'gravel half');
  near(px.soil, palette[1], 'soil half');

  const n0 = (await h.renderState(page)).settledFrames;
  await page.selectOption('#site-colour-select', 'elevation');
  await h.waitSettled(page, n0);
  assert.equal(await page.locator('#site-legend .key-item.material').count(), 0);
  assert.match(await page.locator('#site-legend').innerText(), /terrain elevation/);
  const flat = await zonePixels('#site-canvas', '#site-toggle-2d');
  assert.deepEqual(flat.gravel, flat.soil, 'a flat plane by elevation is one colour');
});

test('job page: PTN density by default, Material on request, overlays kept', { timeout: 60000 }, async () => {
  await page.evaluate((id) => { location.hash = `#/jobs/${id}`; }, run.job.job_id);
  await h.waitReady(page, 'job');
  assert.equal(await page.inputValue('#colour-select'), 'density');
  assert.match(await page.locator('#legend').innerText(), /PTN hazardous fragment density/);
  assert.equal(await page.locator('#legend .key-item.material').count(), 0);

  const n0 = (await h.renderState(page)).settledFrames;
  await page.selectOption('#colour-select', 'material');
  await h.waitSettled(page, n0);
  const legend = await materialLegend('#legend');
  assert.deepEqual(legend.map((e) => e.name), ['gravel', 'soil']);
  assert.deepEqual(legend.map((e) => e.color), [palette[0], palette[1]]);
  const text = await page.locator('#legend').innerText();
  assert.match(text, /hazardous area/);
  assert.match(text, /HFD/);
  for (const layer of ['contour', 'hfd']) assert.equal(await page.locator(`#layer-${layer}`).isChecked(), true, layer);
  await h.screenshot(page.locator('#scene-canvas'), 'materials-2-job-by-material');
  // The pixels without the lines over them.
  for (const layer of ['trajectories', 'contour', 'hfd', 'sectors']) {
    const box = page.locator(`#layer-${layer}`);
    if (await box.count()) await box.uncheck();
  }
  const px = await zonePixels('#scene-canvas', '#toggle-2d');
  await h.screenshot(page.locator('#scene-canvas'), 'materials-3-job-top-view');
  near(px.gravel, palette[0], 'gravel half (job)');
  near(px.soil, palette[1], 'soil half (job)');

  await page.selectOption('#colour-select', 'density');
  await page.locator('#legend .legend-title', { hasText: 'PTN hazardous fragment density' }).waitFor();
  assert.equal(await page.locator('#legend .key-item.material').count(), 0);
});

test('no console errors, no page errors', () => {
  assert.deepEqual(page.diag.pageErrors, [], 'page errors');
  assert.deepEqual(page.diag.consoleErrors, [], `console errors\n${h.fmtDiag(page)}`);
});
