// The units selector in the header (units.js, docs/units.md): switching to US shows the job's
// figures in ft and per 600 ft² — the HFD equal to summary.json's metres / 0.3048 to the shown
// decimals, the threshold as 1 per 600 ft², the legend, the plot's axes, the residual energies in
// ft-lb, a cut HFD's banner in ft with its sectors by bearing — persists across a reload
// (localStorage), and switching back restores the SI text exactly.
import assert from 'node:assert/strict';
import fs from 'node:fs';
import { after, before, test } from 'node:test';
import * as h from './harness.mjs';

let daemon, browser, page, run, cut;

before(async () => {
  daemon = await h.startDaemon();
  browser = await h.launchBrowser();
  [run, cut] = await Promise.all([h.minimalScenario(), h.smallPlaneScenario()].map((s) => daemon.runScenario(s)));
  page = await h.openPage(browser, { viewport: { width: 1400, height: 900 } });
  await h.login(page, daemon);
  page.diag.consoleErrors.length = 0;  // the 401 before the token was given is expected
});

after(async () => {
  await h.finish({ page, browser, daemon });
});

// The site-plan boundary arrives after the view is ready (its own request) and adds legend keys:
// wait for it, so that the text compared across unit switches is whole.
async function boundaryLoaded() {
  await page.locator('#layer-plan_boundary').waitFor({ state: 'attached', timeout: 15000 });
  await h.nextFrames(page);
}

async function openJob(id) {
  await page.evaluate((j) => { delete document.body.dataset.ready; location.hash = `#/jobs/${j}`; }, id);
  await h.waitReady(page, 'job');
  await boundaryLoaded();
}

async function selectUnits(u) {
  await page.selectOption('#units-select', u);
  await h.nextFrames(page);
}

const ft = (m) => (m / 0.3048).toFixed(1);
const label = (key) => page.locator(`#summary-table tr[data-key="${key}"] th`).innerText();
const sig3 = (x) => Number(x.toPrecision(3)).toString();  // format.js sig() for 1e-3 <= |x| < 1e6

/** What a person reads that depends on the units: the summary table, legend, plot, tables. */
async function shownText() {
  return page.evaluate(() => ({
    summary: document.querySelector('#summary-table').innerText,
    legend: document.querySelector('#legend').innerText,
    plot: { ...document.querySelector('#density-plot').dataset },
    attribution: document.querySelector('#hfd-attribution-table').innerText,
    buildings: document.querySelector('#buildings-table').innerText,
  }));
}

test('the selector is in the header of every page, SI by default', async () => {
  assert.ok(await page.locator('header #units-select').isVisible(), 'no #units-select in the header of the jobs list');
  assert.equal(await page.locator('#units-select').inputValue(), 'si');
});

test('US units: the HFD in ft, the threshold 1 per 600 ft², legend, plot and tables', { timeout: 60000 }, async () => {
  const s = run.summary;
  await openJob(run.job.job_id);
  const si = await shownText();
  assert.equal(await h.summaryValue(page, 'hfd'), s.hazardous_fragment_distance_m.toFixed(1));

  await selectUnits('us');
  await h.screenshot(page, 'units-1-job-us', { fullPage: true });
  assert.equal(await h.summaryValue(page, 'hfd'), ft(s.hazardous_fragment_distance_m), 'HFD in ft');
  assert.equal(await label('hfd'), 'Hazardous fragment distance (ft)');
  const band = s.hazardous_fragment_distance_band_m.map(ft).join(' – ');
  assert.equal(await h.summaryValue(page, 'hfd_band'), band);
  assert.equal(await h.summaryValue(page, 'threshold'), '1 (1 per 600 ft²)');
  assert.equal(await label('threshold'), 'Density threshold (per 600 ft²)');
  assert.equal(await h.summaryValue(page, 'hfd_origin'), s.hfd_origin_m.map((v) => v.toFixed(1)).join(', '),
    'site coordinates stay in metres');

  const legend = await page.locator('#legend').innerText();
  assert.ok(legend.includes('threshold 1 per 600 ft²'), legend);
  assert.ok(legend.includes('PTN hazardous fragment density (per 600 ft²)'), legend);
  assert.ok(legend.includes(`HFD ${ft(s.hazardous_fragment_distance_m)} ft`), legend);
  assert.ok(legend.includes('speed (ft/s)'), legend);
  const plot = page.locator('#density-plot');
  assert.equal(await plot.getAttribute('data-hfd-label'), `HFD ${ft(s.hazardous_fragment_distance_m)} ft`);
  assert.equal(await plot.getAttribute('data-x-label'), 'distance from the HFD origin (ft)');
  assert.equal(await plot.getAttribute('data-y-label'), 'density (per 600 ft²)');

  const a = s.hfd_attribution;
  assert.equal(await page.locator('#hfd-alone-unit').innerText(), 'ft');
  const direct = await page.locator('#hfd-attribution-table tr[data-key="mechanism-direct_flight"] td').first().innerText();
  assert.equal(direct, ft(a.by_mechanism.direct_flight.hfd_m));
  assert.equal(await page.locator('#residual-ke-unit').innerText(), 'ft-lb');
  const b = s.buildings[0];
  const ke = await page.locator(`#buildings-table tr[data-building="${b.id}"] td.residual-ke`).innerText();
  assert.ok(b.residual_ke_j > 0, `building ${b.id} has no residual energy to convert`);
  assert.equal(ke.split(' ± ')[0], sig3(b.residual_ke_j / 1.3558179483314004), `residual KE cell "${ke}"`);
  assert.equal(await page.evaluate(() => localStorage.getItem('fragsim.units')), 'us');

  // Kept across a reload (a new visit).
  await page.reload();
  await h.waitReady(page, 'job');
  await boundaryLoaded();
  assert.match(await page.locator('#legend').innerText(), /sector envelope, to \d+\.\d ft/);
  assert.equal(await page.locator('#units-select').inputValue(), 'us');
  assert.equal(await h.summaryValue(page, 'hfd'), ft(s.hazardous_fragment_distance_m));

  // Back to SI: the page reads exactly as before.
  await selectUnits('si');
  assert.deepEqual(await shownText(), si);
  assert.equal(await h.summaryValue(page, 'threshold'), '0.01794 (1 per 55.74 m²)');
  assert.equal(await page.evaluate(() => localStorage.getItem('fragsim.units')), 'si');
});

test('US units of a cut HFD: the banner in ft, the cut sectors by bearing', { timeout: 30000 }, async () => {
  const s = cut.summary, sb = s.site_boundary;
  assert.equal(s.hfd_bound, 'lower', 'the 400 m plane should cut the HFD');
  await openJob(cut.job.job_id);
  await selectUnits('us');
  const banner = await page.locator('#job-warning').innerText();
  assert.ok(banner.includes(`HFD ≥ ${ft(s.hazardous_fragment_distance_m)} ft: hazardous density reaches the site boundary in ${sb.hfd_sectors_cut} of 36 sectors`), banner);
  assert.ok(!banner.includes(' m:'), banner);
  const boundary = await h.summaryValue(page, 'site_boundary');
  assert.match(boundary, new RegExp(`^hazardous in ${sb.hfd_sectors_cut} of 36 sectors, bearings \\d{3}°–\\d{3}°`), boundary);
  assert.ok(boundary.includes('per 600 ft²'), boundary);
  assert.equal(await page.locator('#density-plot').getAttribute('data-hfd-label'), `HFD ≥ ${ft(s.hazardous_fragment_distance_m)} ft`);
  await h.screenshot(page, 'units-2-cut-us', { fullPage: true });
  await selectUnits('si');
  assert.ok((await page.locator('#job-warning').innerText()).includes(sb.note));
});

test('the study report links follow the units; report.html downloads with the token in a header', { timeout: 30000 }, async () => {
  await openJob(run.job.job_id);
  const hrefs = () => page.locator('#report-list a').evaluateAll((as) => as.map((a) => a.getAttribute('href')));
  await selectUnits('si');
  assert.deepEqual(await hrefs(), [`/v1/jobs/${run.job.job_id}/report.html?units=si`, `/v1/jobs/${run.job.job_id}/report.pdf?units=si`]);
  await selectUnits('us');
  assert.deepEqual(await hrefs(), [`/v1/jobs/${run.job.job_id}/report.html?units=us`, `/v1/jobs/${run.job.job_id}/report.pdf?units=us`]);
  const [download] = await Promise.all([page.waitForEvent('download', { timeout: 15000 }),
    page.locator('#report-list a', { hasText: 'report.html' }).click()]);
  const html = fs.readFileSync(await download.path(), 'utf8');
  assert.match(html, /data-units="us"/);
  assert.ok(!download.url().includes(daemon.token), 'token in the download URL');
  await selectUnits('si');
});

test('no console errors, no page errors', () => {
  assert.deepEqual(page.diag.pageErrors, [], 'page errors');
  assert.deepEqual(page.diag.consoleErrors, [], `console errors\n${h.fmtDiag(page)}`);
});
