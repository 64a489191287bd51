// (e) Submitting a scenario file from the page: a bad one shows the daemon's "field: message" in
// #submit-error; a good one (with #submit-priority) becomes a job, with no warning; one whose
// fragments can land beyond its terrain while hazardous shows the answer's warnings under the form.
import assert from 'node:assert/strict';
import fs from 'node:fs';
import os from 'node:os';
import path from 'node:path';
import { after, before, test } from 'node:test';
import * as h from './harness.mjs';

let daemon, browser, page, dir;

before(async () => {
  daemon = await h.startDaemon();
  browser = await h.launchBrowser();
  dir = fs.mkdtempSync(path.join(os.tmpdir(), 'fragsim-viewer-submit-'));
  page = await h.openPage(browser);
  await h.login(page, daemon);
});

after(async () => {
  if (dir) fs.rmSync(dir, { recursive: true, force: true });
  await h.finish({ page, browser, daemon });
});

test('a bad scenario shows the daemon\'s field path and message', { timeout: 30000 }, async () => {
  const bad = h.minimalScenario();
  bad.fragment_groups[0].samples = 0;
  const file = path.join(dir, 'bad-samples.json');
  fs.writeFileSync(file, JSON.stringify(bad, null, 1));
  // What the daemon says about it.
  const r = await daemon.request('/v1/jobs', { method: 'POST', body: bad });
  assert.equal(r.status, 422, `daemon answered ${r.status} ${r.text()}`);
  assert.equal(r.json?.field, 'fragment_groups[0].samples', `daemon answered ${r.status} ${r.text()}`);
  const expected = `${r.json.field}: ${r.json.message}`;

  const jobsBefore = (await daemon.expectOk('/v1/jobs')).jobs.length;
  await page.setInputFiles('#submit-file', file);
  await page.click('#submit-button');
  const err = page.locator('#submit-error');
  await page.waitForFunction(() => /fragment_groups\[0\]\.samples/.test(document.querySelector('#submit-error')?.textContent || ''), null, { timeout: 10000 });
  assert.ok(await err.isVisible(), '#submit-error not visible');
  const text = (await err.innerText()).trim();
  assert.ok(text.includes(expected), `#submit-error is "${text}", expected it to contain "${expected}"`);
  assert.ok(await err.evaluate((e) => e.classList.contains('error') || !!e.closest('.error')), '#submit-error has no class "error"');
  await h.screenshot(page, 'submit-1-field-error', { fullPage: true });
  assert.equal((await daemon.expectOk('/v1/jobs')).jobs.length, jobsBefore, 'a job was created from a bad scenario');
});

test('malformed JSON file is reported, not thrown', { timeout: 20000 }, async () => {
  const file = path.join(dir, 'not-json.json');
  fs.writeFileSync(file, '{"schema": "fragsim.scenario/1", ');
  await page.setInputFiles('#submit-file', file);
  await page.click('#submit-button');
  const err = page.locator('#submit-error');
  await page.waitForFunction(() => {
    const t = document.querySelector('#submit-error')?.textContent || '';
    return t.trim().length > 0 && !/fragment_groups\[0\]\.samples/.test(t);
  }, null, { timeout: 10000 });
  assert.ok(await err.isVisible());
  await h.screenshot(page, 'submit-2-malformed');
  assert.deepEqual(page.diag.pageErrors, [], 'page errors');
});

test('a good scenario with a priority becomes a job', { timeout: 40000 }, async () => {
  const file = path.join(dir, 'minimal.json');
  fs.writeFileSync(file, JSON.stringify(h.minimalScenario()));
  const before = new Set((await daemon.expectOk('/v1/jobs')).jobs.map((j) => j.job_id));
  await page.fill('#submit-priority', '7');
  await page.setInputFiles('#submit-file', file);
  await page.click('#submit-button');
  let created;
  for (let i = 0; i < 100 && !created; i++) {
    created = (await daemon.expectOk('/v1/jobs')).jobs.find((j) => !before.has(j.job_id));
    if (!created) await h.sleep(100);
  }
  assert.ok(created, 'no job created by the page');
  assert.equal(created.priority, 7, 'priority from #submit-priority not sent');
  await daemon.waitForState(created.job_id, 'done');
  const row = page.locator(`#jobs-table tr[data-job-id="${created.job_id}"]`);
  await row.locator('td.state', { hasText: 'done' }).waitFor({ timeout: 10000 });
  assert.equal((await row.locator('td.priority').innerText()).trim(), '7');
  assert.ok(await page.locator('#submit-warnings').isHidden(), '#submit-warnings shown for a scenario without warnings');
  const errText = (await page.locator('#submit-error').innerText().catch(() => '')).trim();
  assert.ok(!(await page.locator('#submit-error').isVisible()) || errText === '', `#submit-error still shows "${errText}" after a good submit`);
  await h.screenshot(page, 'submit-3-good', { fullPage: true });
  assert.deepEqual(page.diag.pageErrors, [], 'page errors');
  assert.deepEqual(h.unexpectedConsoleErrors(page, [401, 400, 422]), [], 'console errors');
});

test('a scenario whose fragments land beyond the terrain shows the answer\'s warnings', { timeout: 30000 }, async () => {
  const file = path.join(dir, 'small-plane.json');
  fs.writeFileSync(file, JSON.stringify(h.smallPlaneScenario()));
  await page.setInputFiles('#submit-file', file);
  const [res] = await Promise.all([
    page.waitForResponse((r) => r.request().method() === 'POST' && new URL(r.url()).pathname === '/v1/jobs'),
    page.click('#submit-button'),
  ]);
  const answer = await res.json();
  assert.ok(answer.warnings?.length > 0, `POST /v1/jobs answered no warnings: ${JSON.stringify(answer)}`);
  const items = page.locator('#submit-warnings li');
  await items.first().waitFor({ timeout: 10000 });
  assert.equal(await items.count(), answer.warnings.length);
  for (const [i, w] of answer.warnings.entries()) {
    const text = (await items.nth(i).innerText()).replace(/\s+/g, ' ').trim();
    assert.equal(text, `${w.severity}: ${w.message}`.replace(/\s+/g, ' '));
    assert.equal(await items.nth(i).getAttribute('data-field'), w.field);
  }
  assert.match(answer.warnings[0].message, /beyond the terrain/);
  await h.screenshot(page, 'submit-4-warnings', { fullPage: true });
  assert.deepEqual(page.diag.pageErrors, [], 'page errors');
});
