// The study report (report/; docs/report.md) as a reviewer's browser shows it: fetched from
// GET /v1/jobs/{id}/report.html and .pdf, opened from a file in headless chromium with every
// request recorded. Checks: the figures are drawn (SVG by Observable Plot) with no request to any
// network and no script error; every number that names a summary.json key equals that figure
// (SI value exactly, shown value to its digits, SI and US); markup in the scenario's text is
// shown as text; the site boundary's lower bound is stated; the PDF is a PDF.
import assert from 'node:assert/strict';
import fs from 'node:fs';
import os from 'node:os';
import path from 'node:path';
import { after, before, test } from 'node:test';
import * as h from './harness.mjs';

const HOSTILE_DESCRIPTION = '<img src=x onerror="window.__pwned=1"> & <script>window.__pwned=2</script>';
const HOSTILE_ID = '<svg onload="window.__pwned=3">';

let daemon, browser, jobId, summary, tmp;

before(async () => {
  daemon = await h.startDaemon();
  browser = await h.launchBrowser();
  tmp = fs.mkdtempSync(path.join(os.tmpdir(), 'fragsim-report-test-'));
  // The 400 m plane: the HFD is cut by the site boundary (a lower bound the report must state).
  const sc = h.smallPlaneScenario();
  sc.description = HOSTILE_DESCRIPTION;
  sc.site.buildings[0].id = HOSTILE_ID;
  const run = await daemon.runScenario(sc);
  jobId = run.job.job_id;
  summary = run.summary;
});

after(async () => {
  await browser?.close();
  await daemon?.stop();
  if (tmp) fs.rmSync(tmp, { recursive: true, force: true });
});

const FACTOR = { length: 1 / 0.3048, energy: 1 / 1.3558179483314004, mass: 1 / 0.45359237, speed: 1 / 0.3048,
  density: 600 * 0.3048 * 0.3048 };

function halfLastDigit(shown) {
  const [mantissa, exponent = '0'] = shown.split(/e/i);
  const dot = mantissa.indexOf('.');
  const decimals = dot < 0 ? 0 : mantissa.length - dot - 1;
  return 0.5 * 10 ** (Number(exponent) - decimals);
}

function pointer(obj, p) {
  return p.split('/').slice(1).reduce((o, k) => (o === undefined ? undefined : o[k.replace(/~1/g, '/').replace(/~0/g, '~')]), obj);
}

/** The report of `units` from the daemon, saved to a file and opened in a fresh page. */
async function openReport(units) {
  const r = await daemon.request(`/v1/jobs/${jobId}/report.html?units=${units}`);
  assert.equal(r.status, 200, r.text().slice(0, 300));
  assert.match(r.headers.get('content-type'), /^text\/html/);
  assert.match(r.headers.get('content-security-policy') || '', /default-src 'none'/);
  const file = path.join(tmp, `report-${units}.html`);
  fs.writeFileSync(file, r.body);
  const page = await h.openPage(browser, { viewport: { width: 1000, height: 1200 } });
  await page.goto('file://' + file);
  await page.waitForFunction(() => document.documentElement.dataset.figures === 'drawn');
  return { page, url: 'file://' + file };
}

async function checkPage(units) {
  const { page, url } = await openReport(units);
  try {
    assert.deepEqual(page.diag.requests.map((q) => q.url), [url], 'the report fetched something');
    assert.deepEqual(page.diag.pageErrors, []);
    assert.deepEqual(page.diag.consoleErrors, []);
    assert.deepEqual(page.diag.dialogs, []);
    const plots = await page.$$eval('.plot', (ns) => ns.map((n) => ({
      name: n.dataset.plot, drawn: n.dataset.drawn, svgs: n.querySelectorAll('svg').length })));
    assert.deepEqual(plots.map((p) => p.name).sort(), ['map', 'overview', 'profile', 'rose']);
    for (const p of plots) assert.ok(p.drawn === 'yes' && p.svgs > 0, `figure ${p.name} not drawn`);
    const nums = await page.$$eval('.num[data-key]:not([data-source])', (ns) => ns.map((n) => ({
      key: n.dataset.key, si: n.dataset.si, kind: n.dataset.kind, shown: n.textContent })));
    assert.ok(nums.length >= 60, `only ${nums.length} keyed numbers`);
    for (const n of nums) {
      const want = pointer(summary, n.key);
      assert.equal(typeof want, 'number', `${n.key} is not a number in summary.json`);
      assert.equal(Number(n.si), want, `${n.key}: data-si ${n.si} != summary ${want}`);
      const converted = units === 'us' && FACTOR[n.kind] ? want * FACTOR[n.kind] : want;
      assert.ok(Math.abs(Number(n.shown) - converted) <= halfLastDigit(n.shown) * (1 + 1e-9),
        `${n.key}: shown ${n.shown}, expected ${converted} (${units})`);
    }
    await h.screenshot(page, `report-${units}`, { fullPage: true });
    return page;
  } catch (e) {
    await page.close();
    throw e;
  }
}

test('the SI report draws its figures offline and every keyed number equals summary.json', async () => {
  const page = await checkPage('si');
  try {
    const warnings = await page.$eval('#warnings', (n) => n.textContent);
    assert.match(warnings, /The HFD is a lower bound/);
    assert.match(await page.$eval('#findings', (n) => n.textContent), /≥ \d+\.\d\s+m/);
  } finally {
    await page.close();
  }
});

test('the US report shows ft and densities per 600 ft², converted from the same figures', async () => {
  const page = await checkPage('us');
  try {
    assert.equal(await page.$eval('#units', (n) => n.dataset.units), 'us');
    assert.match(await page.$eval('#findings', (n) => n.textContent), /per 600 ft²/);
    assert.match(await page.$eval('#findings', (n) => n.textContent), /\d ft/);
  } finally {
    await page.close();
  }
});

test('markup in the description and in building ids is shown as text, never run', async () => {
  const { page } = await openReport('si');
  try {
    assert.equal(await page.evaluate(() => window.__pwned), undefined);
    assert.equal(await page.$eval('#description', (n) => n.textContent), HOSTILE_DESCRIPTION);
    assert.equal(await page.$$eval('main img, main script', (ns) => ns.length), 0);
    const ids = await page.$$eval('#buildings tbody tr td:first-child', (ns) => ns.map((n) => n.textContent));
    assert.ok(ids.includes(HOSTILE_ID), ids.join(', '));
  } finally {
    await page.close();
  }
});

test('the PDF is printed by chromium and kept; bad parameters get a 4xx naming them', async () => {
  const r = await daemon.request(`/v1/jobs/${jobId}/report.pdf?units=us`);
  assert.equal(r.status, 200, r.text().slice(0, 300));
  assert.equal(r.headers.get('content-type'), 'application/pdf');
  assert.equal(r.body.subarray(0, 5).toString(), '%PDF-');
  const t0 = Date.now();
  const again = await daemon.request(`/v1/jobs/${jobId}/report.pdf?units=us`);
  assert.ok(again.body.equals(r.body), 'a second request is served the kept file');
  assert.ok(Date.now() - t0 < 2000);
  const bad = await daemon.request(`/v1/jobs/${jobId}/report.html?units=imperial`);
  assert.equal(bad.status, 400);
  assert.equal(bad.json.field, 'units');
  // A byte that is not UTF-8 in the value: still a 400 naming the field, its JSON body valid.
  const notUtf8 = await daemon.request(`/v1/jobs/${jobId}/report.pdf?units=%FF%FE`);
  assert.equal(notUtf8.status, 400);
  assert.equal(notUtf8.json?.field, 'units', notUtf8.text());
  const unknown = await daemon.request(`/v1/jobs/${jobId}/report.html?unit=us`);
  assert.equal(unknown.status, 400);
  assert.equal((await daemon.request('/v1/jobs/nope/report.html')).status, 404);
  assert.equal((await daemon.request(`/v1/jobs/${jobId}/report.html`, { token: false })).status, 401);
});
