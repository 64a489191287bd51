// A paired comparison (docs/comparison.md) in the job view: a job submitted with compare_with
// shows the card "Paired comparison" whose rows equal GET /v1/jobs/{id}/compare (HFD in the
// selected units, the moved building's impacts and penetrations ± paired se), links
// compare.json and compare.h5 for download; a job without one shows no card and requests no
// comparison (no 404 in the console).
import assert from 'node:assert/strict';
import { after, before, test } from 'node:test';
import * as h from './harness.mjs';

let daemon, browser, page, base, variant, compare;

before(async () => {
  daemon = await h.startDaemon();
  browser = await h.launchBrowser();
  base = await daemon.runScenario(h.minimalScenario());
  const moved = h.minimalScenario();
  moved.site.buildings[0].footprint_m = [[80, -10], [100, -10], [100, 10], [80, 10]];
  const { site, job } = h.splitScenario(moved, null);
  job.site_id = (await daemon.uploadSite(site)).site_id;
  job.compare_with = base.job.job_id;
  const status = await daemon.submitJob(job);
  variant = await daemon.waitForState(status.job_id, 'done', 60000);
  compare = await daemon.expectOk(`/v1/jobs/${variant.job_id}/compare`);
  page = await h.openPage(browser, { viewport: { width: 1400, height: 900 } });
  await h.login(page, daemon);
  page.diag.consoleErrors.length = 0; // the 401 before the token was given is expected
});

after(async () => {
  await h.finish({ page, browser, daemon });
});

const sig = (x, d = 3) => (x === 0 ? '0' : String(Number(x.toPrecision(d))));

test('the comparison card of a compare_with job equals compare.json', { timeout: 60000 }, async () => {
  assert.equal(variant.links.compare, `/v1/jobs/${variant.job_id}/compare`);
  await page.goto(`${daemon.base}/ui/#/jobs/${variant.job_id}`);
  await h.waitReady(page, 'job');
  await page.locator('#comparison').waitFor({ state: 'visible' });
  const rows = await page.$$eval('#comparison-table tbody tr', (trs) =>
    trs.map((tr) => [...tr.children].map((td) => td.textContent)));
  const b = compare.buildings[0];
  assert.equal(rows[0][0], 'HFD (m; se: jackknife)');
  assert.equal(rows[0][1], sig(compare.hfd.base_m));
  assert.deepEqual(rows[1], ['B1: impacts', sig(b.impacts.base), sig(b.impacts.variant),
    `${sig(b.impacts.difference)} ± ${sig(b.impacts.paired_std_error, 2)}`, sig(b.impacts.unpaired_std_error, 2)]);
  assert.equal(rows[2][0], 'B1: penetrations');
  assert.match(await page.textContent('#comparison-what'), /Changed: site_id|Changed: site/);
  const links = await page.$$eval('#comparison-downloads a', (as) => as.map((a) => a.textContent));
  assert.deepEqual(links, ['compare.json', 'compare.h5']);
  await h.screenshot(page, 'comparison-1-card', { fullPage: true });
  // US units: the HFD row in feet.
  await page.selectOption('#units-select', 'us');
  await page.waitForFunction(() => document.querySelector('#comparison-table tbody tr td').textContent.startsWith('HFD (ft'));
  const hfdUs = await page.$eval('#comparison-table tbody tr td:nth-child(2)', (td) => td.textContent);
  assert.equal(hfdUs, sig(compare.hfd.base_m / 0.3048));
  await page.selectOption('#units-select', 'si');
  assert.deepEqual(h.unexpectedConsoleErrors(page), []);
});

test('a job without compare_with shows no comparison and asks for none', { timeout: 60000 }, async () => {
  assert.equal(base.job.links.compare, undefined);
  await page.goto(`${daemon.base}/ui/#/jobs/${base.job.job_id}`);
  await h.waitReady(page, 'job');
  assert.equal(await page.isVisible('#comparison'), false);
  assert.ok(!page.diag.requests.some((q) => q.url.includes(`${base.job.job_id}/compare`)));
  assert.deepEqual(h.unexpectedConsoleErrors(page), []);
});
