// A token revoked mid-session. After login the daemon restarts (same port, same data directory)
// with a token file holding a different token: the page's next refresh gets a 401, it shows
// #token-form again with a message, and once the new token is entered the jobs table goes on
// refreshing (a job submitted afterwards appears). Also: a wrong token held in sessionStorage
// when a job view is opened. Neither token ever appears in a URL, localStorage or a cookie.
import assert from 'node:assert/strict';
import { randomBytes } from 'node:crypto';
import { after, before, test } from 'node:test';
import * as h from './harness.mjs';

let daemon, browser, page, firstJob, siteId;
const oldTokens = [];

before(async () => {
  daemon = await h.startDaemon();
  browser = await h.launchBrowser();
  const { site, job } = h.splitScenario(h.minimalScenario());
  siteId = (await daemon.uploadSite(site)).site_id;
  job.site_id = siteId;
  firstJob = (await daemon.submitJob(job)).job_id;
  await daemon.waitForState(firstJob, 'done');
  page = await h.openPage(browser, { viewport: { width: 1280, height: 800 } });
});

after(async () => {
  let leaks = [];
  try {
    if (page) for (const t of oldTokens) leaks.push(...(await h.tokenLeaks(page, t)));
  } finally {
    await h.finish({ page, browser, daemon });  // checks the current token
  }
  assert.deepEqual(leaks, [], 'a revoked token leaked');
});

const row = (id) => page.locator(`#jobs-table tr[data-job-id="${id}"]`);

test('the daemon restarts with another token: the form comes back with a message, then the jobs go on', { timeout: 60000 }, async () => {
  await h.login(page, daemon);
  await row(firstJob).waitFor();
  const form = page.locator('#token-form');
  assert.equal(await form.isVisible(), false);

  const old = daemon.token;
  oldTokens.push(old);
  const fresh = 'vt_' + randomBytes(24).toString('hex');
  await daemon.restart({ token: fresh });
  // The daemon now refuses the old token.
  assert.equal((await daemon.request('/v1/jobs', { token: old })).status, 401, 'old token still accepted after the restart');

  // The page's next refresh (every second) gets the 401.
  await form.waitFor({ state: 'visible', timeout: 10000 });
  const msg = page.locator('#token-form .error, #token-message');
  await msg.first().waitFor({ state: 'visible', timeout: 2000 });
  const text = (await msg.first().innerText()).trim();
  assert.ok(text.length > 5, `no message with the token form (got ${JSON.stringify(text)})`);
  await h.screenshot(page, 'session-1-token-revoked', { fullPage: true });
  const stored = await page.evaluate(() => Object.keys(sessionStorage).map((k) => sessionStorage.getItem(k)));
  assert.ok(!stored.includes(old), 'the refused token is still kept in sessionStorage');
  const oldRefused = page.diag.requests.filter((r) => new URL(r.url).pathname.startsWith('/v1/jobs') && r.headers.authorization === `Bearer ${old}`);
  assert.ok(oldRefused.length > 0, 'the page never sent the old token');

  // The new token: the table refreshes again, with the new token in the header.
  const okAgain = page.waitForResponse((r) => new URL(r.url()).pathname === '/v1/jobs' && r.status() === 200 &&
    r.request().headers().authorization === `Bearer ${fresh}`, { timeout: 10000 });
  await page.fill('#token-input', fresh);
  await page.click('#token-submit');
  await okAgain;
  await form.waitFor({ state: 'hidden' });
  await row(firstJob).waitFor();
  assert.equal((await row(firstJob).locator('td.state').innerText()).trim(), 'done');
  // Still refreshing: a job submitted now appears and gets to done in the table.
  const { job } = h.splitScenario(h.minimalScenario(), siteId);
  const second = (await daemon.submitJob(job)).job_id;
  await row(second).locator('td.state', { hasText: 'done' }).waitFor({ timeout: 20000 });
  await h.screenshot(page, 'session-2-after-new-token', { fullPage: true });
  const stored2 = await page.evaluate(() => Object.keys(sessionStorage).map((k) => sessionStorage.getItem(k)));
  assert.ok(stored2.includes(fresh), 'the new token is not kept in sessionStorage');
  assert.deepEqual(page.diag.pageErrors, [], 'page errors');
});

test('a wrong token held in sessionStorage: opening a job asks again, then shows the job', { timeout: 60000 }, async () => {
  await page.goto(`${daemon.base}/ui/#/jobs/${firstJob}`);
  await h.waitReady(page, 'job');
  const wrong = 'vt_wrong_' + randomBytes(12).toString('hex');
  oldTokens.push(wrong);
  await page.evaluate((w) => { for (const k of Object.keys(sessionStorage)) sessionStorage.setItem(k, w); }, wrong);
  const keys = await page.evaluate(() => Object.keys(sessionStorage));
  assert.ok(keys.length > 0, 'the page keeps no token in sessionStorage');
  await page.reload();
  const form = page.locator('#token-form');
  await form.waitFor({ state: 'visible', timeout: 10000 });
  await page.locator('#token-form .error, #token-message').first().waitFor({ state: 'visible', timeout: 2000 });
  assert.notEqual(await page.evaluate(() => document.body.dataset.ready), 'job');
  await page.fill('#token-input', daemon.token);
  await page.click('#token-submit');
  await h.waitReady(page, 'job');
  assert.equal(await form.isVisible(), false);
  const hfd = (await h.summaryValue(page, 'hfd')).replace(/\s*m$/, '');
  const sum = await daemon.expectOk(`/v1/jobs/${firstJob}/summary`);
  assert.equal(hfd, sum.hazardous_fragment_distance_m.toFixed(1));
  assert.deepEqual(page.diag.pageErrors, [], 'page errors');
  // Only refused requests (401) and the restart's refused connections may have logged errors.
  const other = h.unexpectedConsoleErrors(page, [401]).filter((t) => !/ERR_CONNECTION_REFUSED|ERR_CONNECTION_RESET|ERR_EMPTY_RESPONSE|Failed to fetch/.test(t));
  assert.deepEqual(other, [], `console errors\n${h.fmtDiag(page)}`);
});
