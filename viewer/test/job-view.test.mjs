// (c) The job view of a finished job: WebGL canvas rendered (non-blank), summary table equal to
// GET /v1/jobs/{id}/summary (HFD to 1 decimal, building count), buildings table, density plot,
// legend, downloads (summary.json fetched with the header, saved from a Blob), 3-D <-> top view;
// no console errors, no page errors. The HFD as a lower bound (issue 22): the minimal example's is
// not cut (no banner, no "≥", solid lines); the same on a 400 m plane is (banner with the note,
// "≥" in the table, the legend and the plot, the HFD circle and the cut sectors dashed); on a
// 200 m plane with a precision target, the target is UNMEETABLE and the run stops for it. The
// site-plan boundary (GET /v1/jobs/{id}/plan_boundary): its three lines drawn, toggled, keyed.
import assert from 'node:assert/strict';
import fs from 'node:fs';
import { after, before, test } from 'node:test';
import * as h from './harness.mjs';

let daemon, browser, page, run, cut, unmeetable;

/** The 200 m plane with an HFD precision target: the band's lower end is cut, so the target is
 *  unmeetable and the run stops at the first check (800 histories). */
function unmeetableScenario() {
  const s = h.smallPlaneScenario();
  s.site.terrain.plane.extent_m = [-100, -100, 100, 100];
  s.fragment_groups[0].samples = 200;
  s.settings.record_trajectories = false;
  s.settings.precision = { hfd_half_band_m: 1, max_batches: 5 };
  return s;
}

before(async () => {
  daemon = await h.startDaemon();
  browser = await h.launchBrowser();
  [run, cut, unmeetable] = await Promise.all(
    [h.minimalScenario(), h.smallPlaneScenario(), unmeetableScenario()].map((s) => daemon.runScenario(s)));
  page = await h.openPage(browser, { viewport: { width: 1400, height: 900 } });
  await h.login(page, daemon);
  page.diag.consoleErrors.length = 0; // the 401 before the token was given is expected
});

after(async () => {
  await h.finish({ page, browser, daemon });
});

const MIN_COLOURS = 16;

function assertRendered(stats, what) {
  assert.ok(stats.distinct >= MIN_COLOURS && stats.dominantFraction < 0.98,
    `${what} looks blank: ${stats.distinct} distinct colours, dominant colour ${(100 * stats.dominantFraction).toFixed(1)} % of ${stats.width}x${stats.height}`);
}

test('open the done job from the jobs table; the scene renders', { timeout: 60000 }, async () => {
  const id = run.job.job_id;
  const open = page.locator(`#jobs-table tr[data-job-id="${id}"] a.open`);
  await open.click();
  await h.waitReady(page, 'job');
  assert.ok(page.url().endsWith(`#/jobs/${id}`), `URL after a.open: ${page.url()}`);
  await page.locator('#view-job').waitFor({ state: 'visible' });
  await h.nextFrames(page);
  await h.screenshot(page, 'job-1-view', { fullPage: true });

  const s3d = await h.canvasStats(page, '#scene-canvas', 'job-2-canvas-3d');
  assertRendered(s3d, '#scene-canvas (compositor)');
  const buf = await h.canvasDataUrlStats(page, '#scene-canvas');
  assertRendered(buf, '#scene-canvas toDataURL() (preserveDrawingBuffer: true?)');

  const fv = await page.evaluate(() => {
    const v = window.fragsimViewer;
    return v ? { loadMs: v.loadMs, triangles: v.triangles, hasMeasure: typeof v.measureRotation === 'function' } : null;
  });
  assert.ok(fv, 'window.fragsimViewer missing');
  assert.ok(fv.loadMs > 0, `fragsimViewer.loadMs = ${fv.loadMs}`);
  assert.ok(fv.triangles >= run.site.terrain_triangles, `fragsimViewer.triangles = ${fv.triangles}, site has ${run.site.terrain_triangles} terrain triangles`);
  assert.ok(fv.hasMeasure, 'fragsimViewer.measureRotation missing');

  const gl = await page.$eval('#scene-canvas', (c) => {
    const ctx = c.getContext('webgl2') || c.getContext('webgl');
    return ctx ? { preserve: ctx.getContextAttributes().preserveDrawingBuffer } : null;
  });
  assert.ok(gl, '#scene-canvas has no WebGL context');
  assert.equal(gl.preserve, true, 'WebGL context without preserveDrawingBuffer');
});

test('summary table matches GET /v1/jobs/{id}/summary', async () => {
  const sum = run.summary;
  const hfd = (await h.summaryValue(page, 'hfd')).replace(/\s*m$/, '');
  assert.equal(hfd, sum.hazardous_fragment_distance_m.toFixed(1), 'HFD cell');
  const nb = await h.summaryValue(page, 'buildings');
  assert.equal(Number(nb), sum.buildings.length, `buildings cell "${nb}"`);
  const keys = await page.$$eval('#summary-table tr[data-key]', (rows) => rows.map((r) => r.dataset.key));
  for (const k of ['hfd', 'buildings']) assert.ok(keys.includes(k), `summary-table has no data-key=${k} (has ${keys})`);
  assert.ok(keys.length >= 8, `summary-table has only ${keys.length} rows: ${keys}`);
  for (const b of sum.buildings) {
    const row = page.locator(`#buildings-table tr[data-building="${b.id}"]`);
    assert.equal(await row.count(), 1, `buildings-table row for ${b.id}`);
  }
  assert.equal(await page.locator('#buildings-table tr[data-building]').count(), sum.buildings.length);
});

test('what sets the HFD: a row per mechanism and group, as in the summary', async () => {
  const a = run.summary.hfd_attribution;
  assert.ok(a, 'summary has no hfd_attribution');
  assert.ok(await page.locator('#hfd-attribution').isVisible(), '#hfd-attribution hidden');
  const rows = await page.$$eval('#hfd-attribution-table tbody tr', (trs) =>
    trs.map((tr) => [tr.dataset.key, ...[...tr.cells].map((c) => c.textContent)]));
  assert.equal(rows.length, a.mechanisms.length + a.by_group.length, JSON.stringify(rows));
  for (const m of a.mechanisms) {
    const row = rows.find((r) => r[0] === `mechanism-${m}`);
    assert.ok(row, `no row for ${m}: ${JSON.stringify(rows)}`);
    assert.equal(row[2], a.by_mechanism[m].hfd_m.toFixed(1), `HFD alone of ${m}`);
    assert.equal(row[3], `${Math.round(100 * a.at_hfd.share_by_mechanism[m])} %`, `share of ${m}`);
  }
  // The minimal example: one group, no bounce: all direct flight, the group's HFD the HFD.
  assert.equal(rows.find((r) => r[0] === 'mechanism-direct_flight')[3], '100 %');
  assert.equal(rows.find((r) => r[0] === 'group-0')[2], run.summary.hazardous_fragment_distance_m.toFixed(1));
  await h.screenshot(page.locator('#hfd-attribution'), 'job-4b-hfd-attribution');
});

test('density plot, legend and downloads', { timeout: 30000 }, async () => {
  await page.locator('#density-plot').scrollIntoViewIfNeeded();
  assert.ok(await page.locator('#density-plot').isVisible(), '#density-plot not visible');
  const plot = await h.canvasStats(page, '#density-plot', 'job-4-density-plot');
  assert.ok(plot.distinct >= 3 && plot.dominantFraction < 0.995,
    `#density-plot looks empty: ${plot.distinct} colours, dominant ${(100 * plot.dominantFraction).toFixed(2)} %`);
  assert.ok(await page.locator('#legend').isVisible(), '#legend not visible');
  await h.screenshot(page.locator('#legend'), 'job-5-legend');

  const links = page.locator('#downloads a');
  assert.ok(await links.count() >= 2, `#downloads has ${await links.count()} links`);
  const texts = await links.evaluateAll((as) => as.map((a) => `${a.textContent} ${a.getAttribute('download') || ''} ${a.getAttribute('href') || ''}`));
  assert.ok(texts.some((t) => /results\.h5/.test(t)), `no results.h5 link: ${JSON.stringify(texts)}`);
  const summaryLink = links.filter({ hasText: /summary/ }).first();
  assert.ok(await summaryLink.count(), `no summary.json link: ${JSON.stringify(texts)}`);
  const [download] = await Promise.all([page.waitForEvent('download', { timeout: 15000 }), summaryLink.click()]);
  const file = await download.path();
  const got = JSON.parse(fs.readFileSync(file, 'utf8'));
  assert.equal(got.hazardous_fragment_distance_m, run.summary.hazardous_fragment_distance_m, 'downloaded summary.json differs');
  assert.ok(!download.url().includes(daemon.token), 'token in the download URL');
});

test('3-D <-> top view toggle', { timeout: 30000 }, async () => {
  await page.locator('#scene-canvas').scrollIntoViewIfNeeded();
  await h.nextFrames(page);
  const before3d = await h.canvasStats(page, '#scene-canvas');
  await page.click('#toggle-2d');
  await h.nextFrames(page, 3);
  await h.sleep(300);
  await h.nextFrames(page, 2);
  const top = await h.canvasStats(page, '#scene-canvas', 'job-3-canvas-top');
  assertRendered(top, 'top view');
  assert.ok(!top.png.equals(before3d.png), 'the canvas did not change after #toggle-2d');
  await h.screenshot(page, 'job-6-view-top', { fullPage: true });
  await page.click('#toggle-2d');
  await h.nextFrames(page, 3);
  await h.sleep(300);
  const back = await h.canvasStats(page, '#scene-canvas');
  assertRendered(back, '3-D view after toggling back');
  assert.ok(!back.png.equals(top.png), 'toggling back did not change the canvas');
});

test('reloading the job URL (deep link) renders the job again', { timeout: 30000 }, async () => {
  await page.reload();
  await h.waitReady(page, 'job');
  await h.nextFrames(page);
  assertRendered(await h.canvasStats(page, '#scene-canvas'), 'after reload');
  assert.equal(await h.summaryValue(page, 'hfd').then((t) => t.replace(/\s*m$/, '')), run.summary.hazardous_fragment_distance_m.toFixed(1));
});

/** The 3-D view's named line overlays by name: {hfd: material type, ...} (fragsimViewer.lines()). */
async function overlayLines() {
  const lines = await page.evaluate(() => window.fragsimViewer.lines());
  return Object.fromEntries(lines.map((l) => [l.name, l]));
}

/** Open job `id` in this page (hash route) and wait for its view. */
async function openJob(id) {
  await page.evaluate((j) => { delete document.body.dataset.ready; location.hash = `#/jobs/${j}`; }, id);
  await h.waitReady(page, 'job');
  await h.nextFrames(page);
}

test('an HFD the site boundary does not cut reads as before: no banner, no "≥", solid lines', async () => {
  const sum = run.summary;
  assert.equal(sum.hfd_bound, 'none', 'the minimal example (3 km plane) should not be cut');
  assert.ok(page.url().endsWith(`#/jobs/${run.job.job_id}`), page.url());
  assert.ok(await page.locator('#job-warning').isHidden(), '#job-warning shown for an HFD that is not cut');
  const table = await page.locator('#summary-table').innerText();
  assert.ok(!table.includes('≥'), `"≥" in the summary table of an uncut HFD:\n${table}`);
  assert.match(await h.summaryValue(page, 'site_boundary'), /^not reached/);
  assert.equal(await h.summaryValue(page, 'stop_reason'), 'all samples run');
  const lines = await overlayLines();
  assert.equal(lines.hfd?.material, 'LineBasicMaterial', JSON.stringify(lines));
  assert.equal(lines.sectors?.material, 'LineBasicMaterial', JSON.stringify(lines));
  assert.equal(lines['sectors-lower-bound'], undefined, JSON.stringify(lines));
  const legend = await page.locator('#legend').innerText();
  assert.ok(legend.includes(`HFD ${sum.hazardous_fragment_distance_m.toFixed(1)} m`) && !/lower bound/.test(legend), legend);
  assert.equal(await page.locator('#density-plot').getAttribute('data-hfd-label'), `HFD ${sum.hazardous_fragment_distance_m.toFixed(1)} m`);
});

test('the site-plan boundary: the route answers, its three lines are drawn, toggled and keyed', { timeout: 30000 }, async () => {
  const id = run.job.job_id, sum = run.summary;
  const b = await daemon.expectOk(`/v1/jobs/${id}/plan_boundary`);
  assert.equal(b.job_id, id);
  assert.equal(b.exact_hfd_m, sum.hazardous_fragment_distance_m);
  assert.equal(b.envelope.radius_m.length, 36);
  assert.ok(b.envelope.max_radius_m >= b.exact_hfd_m && b.envelope_upper.max_radius_m >= b.envelope.max_radius_m, JSON.stringify(b.envelope.radius_m));
  assert.ok(b.smoothed_hfd_m >= b.exact_hfd_m, `smoothed ${b.smoothed_hfd_m} < HFD ${b.exact_hfd_m}`);
  assert.deepEqual(b.origin_m, sum.hfd_origin_m.slice(0, 2), 'input coordinates');
  await page.locator('#layer-plan_boundary').waitFor({ state: 'attached', timeout: 15000 });
  const lines = await overlayLines();
  const edges = (polygons) => polygons.flat().reduce((n, ring) => n + ring.length, 0);
  for (const [name, polygons] of [['plan-envelope', b.envelope.polygons], ['plan-envelope-upper', b.envelope_upper.polygons], ['plan-smoothed', b.smoothed.polygons]]) {
    assert.ok(polygons.length > 0, `${name}: no polygon`);
    assert.equal(lines[name]?.material, 'LineBasicMaterial', `${name}: ${JSON.stringify(lines)}`);
    assert.equal(lines[name].segments, edges(polygons), `${name}: a segment per ring edge`);
    assert.equal(lines[name].visible, true, name);
  }
  const legend = await page.locator('#legend').innerText();
  assert.ok(legend.includes(`sector envelope, to ${b.envelope.max_radius_m.toFixed(1)} m`), legend);
  assert.ok(legend.includes(`smoothed boundary (closing ${b.smoothing_m.toFixed(1)} m`), legend);
  await h.nextFrames(page);
  await h.screenshot(page, 'job-6b-plan-boundary', { fullPage: true });
  await page.click('#layer-plan_boundary');
  assert.equal((await overlayLines())['plan-smoothed'].visible, false, 'the toggle did not hide the boundary');
  await page.click('#layer-plan_boundary');
  assert.equal((await overlayLines())['plan-smoothed'].visible, true);
});

test('an HFD the site boundary cuts: banner, "≥" in the table, legend and plot, dashed lines', { timeout: 30000 }, async () => {
  const sum = cut.summary, sb = sum.site_boundary;
  assert.equal(sum.hfd_bound, 'lower', 'the 400 m plane should cut the HFD');
  assert.ok(typeof sb.note === 'string' && sb.hfd_sectors_cut > 0, JSON.stringify(sb));
  await openJob(cut.job.job_id);
  await h.screenshot(page, 'job-7-hfd-lower-bound', { fullPage: true });

  const banner = page.locator('#job-warning');
  assert.ok(await banner.isVisible(), '#job-warning not shown');
  assert.ok((await banner.innerText()).includes(sb.note), `banner: ${await banner.innerText()}`);
  const hfd = sum.hazardous_fragment_distance_m.toFixed(1);
  const cell = await h.summaryValue(page, 'hfd');
  assert.ok(cell.startsWith(`≥ ${hfd}`) && cell.includes('lower bound: the hazardous density reaches the site boundary'), cell);
  const band = sum.hazardous_fragment_distance_band_m.map((v, i) => `${sum.hfd_band_bound[i] === 'lower' ? '≥ ' : ''}${v.toFixed(1)}`);
  assert.equal(await h.summaryValue(page, 'hfd_band'), band.join(' – '));
  assert.match(await h.summaryValue(page, 'site_boundary'), new RegExp(`^hazardous in ${sb.hfd_sectors_cut} of 36 sectors`));
  const left = await h.summaryValue(page, 'left_site_hazardous');
  assert.ok(left.includes(`(${sb.left_site_hazardous.histories.toLocaleString('en-US')} histories)`), left);

  const lower = sum.hfd_by_sector_bound.map((b, k) => b === 'lower' && sum.hfd_by_sector_m[k] > 0);
  const nCut = lower.filter(Boolean).length, nDrawn = sum.hfd_by_sector_m.filter((r) => r > 0).length;
  const lines = await overlayLines();
  assert.equal(lines.hfd?.material, 'LineDashedMaterial', JSON.stringify(lines));
  assert.equal(lines['sectors-lower-bound']?.material, 'LineDashedMaterial', JSON.stringify(lines));
  assert.equal(lines['sectors-lower-bound'].segments, 5 * nCut, 'a radial segment and 4 arc pieces per cut sector');
  assert.equal(lines.sectors?.material, 'LineBasicMaterial', JSON.stringify(lines));
  assert.equal(lines.sectors.segments, 5 * (nDrawn - nCut));
  const legend = await page.locator('#legend').innerText();
  assert.ok(legend.includes(`HFD ≥ ${hfd} m (lower bound: site boundary)`), legend);
  assert.ok(legend.includes('sector HFD ≥ (lower bound: site boundary)'), legend);
  assert.equal(await page.locator('#density-plot').getAttribute('data-hfd-label'), `HFD ≥ ${hfd} m`);
  const s3d = await h.canvasStats(page, '#scene-canvas', 'job-8-canvas-hfd-lower-bound');
  assertRendered(s3d, '#scene-canvas of the cut HFD');
});

test('an unmeetable precision target and its stop reason are said in words', { timeout: 30000 }, async () => {
  const sum = unmeetable.summary;
  assert.equal(sum.stop_reason, 'targets_unmeetable', JSON.stringify(sum.precision));
  const t = sum.precision.targets[0];
  await openJob(unmeetable.job.job_id);
  assert.equal(await h.summaryValue(page, 'stop_reason'), 'stopped: a precision target cannot be met by more histories');
  assert.equal(await h.summaryValue(page, 'precision'), 'not all can be met');
  const row = await h.summaryValue(page, `target-${t.figure}`);
  assert.ok(row.includes('UNMEETABLE') && row.includes(t.note) && !/not met/.test(row), row);
  await h.screenshot(page.locator('#summary-table'), 'job-9-unmeetable-target');
});

test('no console errors, no page errors in the job view', () => {
  assert.deepEqual(page.diag.pageErrors, [], 'page errors');
  assert.deepEqual(page.diag.consoleErrors, [], `console errors\n${h.fmtDiag(page)}`);
});
