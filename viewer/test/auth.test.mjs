// (a) The page asks for the token, accepts it, sends it only as an Authorization header: never in
// a request URL, never in localStorage or a cookie. A wrong token is asked for again. With
// `fragsimd --no-auth` the page does not ask at all.
import assert from 'node:assert/strict';
import { after, before, test } from 'node:test';
import * as h from './harness.mjs';

let daemon, browser, jobId;

before(async () => {
  daemon = await h.startDaemon();
  browser = await h.launchBrowser();
  const { site, job } = h.splitScenario(h.minimalScenario());
  job.site_id = (await daemon.uploadSite(site)).site_id;
  jobId = (await daemon.submitJob(job)).job_id;
  await daemon.waitForState(jobId, 'done');
});

after(async () => {
  await browser?.close();
  await daemon?.stop();
});

test('token form: asked for, wrong token refused, right token accepted, never leaked', async () => {
  const page = await h.openPage(browser);
  await page.goto(`${daemon.base}/ui/`);
  const form = page.locator('#token-form');
  await form.waitFor({ state: 'visible' });
  assert.equal(await page.locator('#token-input').getAttribute('type'), 'password', '#token-input must be type=password');
  await h.screenshot(page, 'auth-1-token-form');

  // A wrong token: the daemon answers 401, the page asks again.
  const wrong = 'vt_wrong_' + 'x'.repeat(20);
  await page.fill('#token-input', wrong);
  const answered = page.waitForResponse((r) => r.url().includes('/v1/') && r.status() === 401);
  await page.click('#token-submit');
  await answered;
  await form.waitFor({ state: 'visible' });
  assert.notEqual(await page.evaluate(() => document.body.dataset.ready), 'jobs',
    'body[data-ready] must not be "jobs" after a refused token');
  await h.screenshot(page, 'auth-2-wrong-token');

  // The right token.
  await page.fill('#token-input', daemon.token);
  await page.click('#token-submit');
  await h.waitReady(page, 'jobs');
  await form.waitFor({ state: 'hidden' });
  await page.locator(`#jobs-table tr[data-job-id="${jobId}"]`).waitFor();
  assert.equal((await page.locator(`#jobs-table tr[data-job-id="${jobId}"] td.state`).innerText()).trim(), 'done');
  await h.screenshot(page, 'auth-3-jobs-after-login', { fullPage: true });

  // The token went as a header on the API requests made after login.
  const apiRequests = page.diag.requests.filter((r) => new URL(r.url).pathname.startsWith('/v1/jobs'));
  assert.ok(apiRequests.length > 0, 'no /v1/jobs request seen');
  const withHeader = apiRequests.filter((r) => r.headers.authorization === `Bearer ${daemon.token}`);
  assert.ok(withHeader.length > 0, `no /v1/jobs request carried "Authorization: Bearer <token>" (saw ${JSON.stringify(apiRequests.map((r) => r.headers.authorization ?? null))})`);

  // A reload keeps the token for the tab (sessionStorage): no form.
  await page.reload();
  await h.waitReady(page, 'jobs');
  assert.equal(await form.isVisible(), false, 'token form shown again after a reload (token should be in sessionStorage)');

  const leaks = await h.tokenLeaks(page, daemon.token);
  assert.deepEqual(leaks, [], 'token leaked');
  const wrongLeaks = page.diag.requests.filter((r) => r.url.includes(wrong)).map((r) => r.url);
  assert.deepEqual(wrongLeaks, [], 'the wrong token appeared in a request URL');
  const inSession = await page.evaluate((t) => Object.keys(sessionStorage).some((k) => sessionStorage.getItem(k) === t), daemon.token);
  assert.ok(inSession, 'token not kept in sessionStorage');
  assert.deepEqual(page.diag.pageErrors, [], 'page errors');
  assert.deepEqual(h.unexpectedConsoleErrors(page, [401]), [], 'console errors other than the expected 401s');
  await page.context().close();
});

test('a new tab (fresh sessionStorage) asks again', async () => {
  const page = await h.openPage(browser);
  await page.goto(`${daemon.base}/ui/#/jobs`);
  await page.locator('#token-form').waitFor({ state: 'visible' });
  assert.notEqual(await page.evaluate(() => document.body.dataset.ready), 'jobs');
  await page.context().close();
});

test('--no-auth: the page shows the jobs without asking for a token', async () => {
  const open = await h.startDaemon({ auth: false });
  try {
    const { site, job } = h.splitScenario(h.minimalScenario());
    job.site_id = (await open.uploadSite(site)).site_id;
    const id = (await open.submitJob(job)).job_id;
    const page = await h.openPage(browser);
    await page.goto(`${open.base}/ui/`);
    await h.waitReady(page, 'jobs');
    await page.locator(`#jobs-table tr[data-job-id="${id}"]`).waitFor();
    assert.equal(await page.locator('#token-form').isVisible(), false, 'token form visible with --no-auth');
    await h.screenshot(page, 'auth-4-no-auth-jobs');
    assert.deepEqual(page.diag.pageErrors, []);
    assert.deepEqual(h.unexpectedConsoleErrors(page), [], 'console errors with --no-auth');
    await page.context().close();
  } finally {
    await open.stop();
  }
});
