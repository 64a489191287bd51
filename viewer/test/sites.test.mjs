// (f) The sites view lists the uploaded sites and a site's 3-D preview renders.
import assert from 'node:assert/strict';
import { after, before, test } from 'node:test';
import * as h from './harness.mjs';

let daemon, browser, page, site;

before(async () => {
  daemon = await h.startDaemon();
  browser = await h.launchBrowser();
  site = await daemon.uploadSite(h.minimalScenario().site);
  page = await h.openPage(browser, { viewport: { width: 1400, height: 900 } });
  await h.login(page, daemon);
  page.diag.consoleErrors.length = 0;
});

after(async () => {
  await h.finish({ page, browser, daemon });
});

test('sites view lists the site', { timeout: 30000 }, async () => {
  await page.click('a#nav-sites');
  await page.waitForFunction(() => location.hash.startsWith('#/sites'));
  await page.getByText(site.site_id).first().waitFor({ state: 'visible', timeout: 10000 });
  const text = await page.locator('body').innerText();
  assert.ok(text.includes(String(site.terrain_triangles)) || text.includes(site.terrain_triangles.toLocaleString('en-US')),
    `terrain triangle count ${site.terrain_triangles} not shown in the sites view`);
  await h.screenshot(page, 'sites-1-list', { fullPage: true });
});

test('site view: 3-D preview renders', { timeout: 30000 }, async () => {
  const link = page.locator(`a[href="#/sites/${site.site_id}"]`).first();
  if (await link.count()) await link.click();
  else await page.evaluate((id) => { location.hash = `#/sites/${id}`; }, site.site_id);
  await h.waitReady(page, 'site');
  await h.nextFrames(page);
  const canvas = await h.visibleCanvas(page, ['#scene-canvas', '#site-canvas']);
  const st = await h.canvasStats(page, canvas, 'sites-2-preview-canvas');
  assert.ok(st.distinct >= 8 && st.dominantFraction < 0.98,
    `site preview looks blank: ${st.distinct} colours, dominant ${(100 * st.dominantFraction).toFixed(1)} %`);
  await h.screenshot(page, 'sites-3-view', { fullPage: true });
  const tri = await page.evaluate(() => window.fragsimViewer?.triangles);
  assert.ok(tri >= site.terrain_triangles, `fragsimViewer.triangles = ${tri}`);
  assert.deepEqual(page.diag.pageErrors, [], 'page errors');
  assert.deepEqual(page.diag.consoleErrors, [], `console errors\n${h.fmtDiag(page)}`);
});
