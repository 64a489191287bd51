// Roles (docs/operations.md, "Roles"): the jobs page offers only what the token's role may do.
// A read token sees no submission form and no Cancel, Retry or Delete button; a submit token
// the form and Cancel on the jobs it submitted only; an admin token Cancel on every active job
// and Delete on finished ones. The daemon refuses the rest anyway (403, tests/server).
import assert from 'node:assert/strict';
import { after, before, test } from 'node:test';
import * as h from './harness.mjs';

let daemon, browser, finished, blocker, queuedBySubmit, queuedByAdmin;

before(async () => {
  // One thread: the blocker (the demo x30, ~20 s) keeps the two small jobs queued behind it.
  daemon = await h.startDaemon({ threads: 1, roles: ['read', 'submit'] });
  browser = await h.launchBrowser();
  const { site, job } = h.splitScenario(h.minimalScenario());
  job.site_id = (await daemon.uploadSite(site)).site_id;
  finished = (await daemon.submitJob(job)).job_id;
  await daemon.waitForState(finished, 'done');
  const demo = h.splitScenario(h.demoScenario(30));
  demo.job.site_id = (await daemon.uploadSite(demo.site)).site_id;
  blocker = (await daemon.submitJob(demo.job, { priority: 10 })).job_id;
  await daemon.waitForState(blocker, 'running');
  const asSubmit = { method: 'POST', body: { ...job, priority: -5 }, token: daemon.tokens.submit };
  queuedBySubmit = (await daemon.expectOk('/v1/jobs', asSubmit)).job_id;
  queuedByAdmin = (await daemon.submitJob(job, { priority: -5 })).job_id;
});

after(async () => {
  for (const id of [blocker, queuedBySubmit, queuedByAdmin].filter(Boolean))
    await daemon?.request(`/v1/jobs/${id}`, { method: 'DELETE' }).catch(() => {});
  await h.finish({ browser, daemon });
});

// The buttons of each job's row, as the page shows them to `role`.
async function buttonsAs(role) {
  const page = await h.openPage(browser);
  await h.login(page, daemon, { token: daemon.tokens[role] });
  const out = {};
  for (const id of [finished, blocker, queuedBySubmit, queuedByAdmin]) {
    const row = page.locator(`#jobs-table tr[data-job-id="${id}"]`);
    await row.waitFor();
    out[id] = (await row.locator('td.actions button').allInnerTexts()).sort();
  }
  const form = await page.locator('#submit-form').isVisible();
  const note = (await page.locator('#jobs-role').isVisible()) ? await page.locator('#jobs-role').innerText() : '';
  await h.screenshot(page, `roles-${role}`, { fullPage: true });
  assert.deepEqual(page.diag.pageErrors, [], 'page errors');
  await page.context().close();
  return { buttons: out, form, note };
}

test('read: no form, no buttons', { timeout: 60000 }, async () => {
  const { buttons, form, note } = await buttonsAs('read');
  assert.equal(form, false, 'the submission form is shown to a read token');
  assert.match(note, /only read/);
  for (const [id, b] of Object.entries(buttons)) assert.deepEqual(b, [], `buttons on ${id}`);
});

test('submit: the form, Cancel on its own job only, no Delete', { timeout: 60000 }, async () => {
  const { buttons, form, note } = await buttonsAs('submit');
  assert.equal(form, true, 'no submission form for a submit token');
  assert.match(note, /role submit/);
  assert.deepEqual(buttons[queuedBySubmit], ['Cancel']);
  assert.deepEqual(buttons[queuedByAdmin], [], 'Cancel offered on a job another token submitted');
  assert.deepEqual(buttons[blocker], []);
  assert.deepEqual(buttons[finished], [], 'Delete offered to a submit token');
});

test('admin: Cancel on every active job, Delete on finished ones', { timeout: 60000 }, async () => {
  const { buttons, form, note } = await buttonsAs('admin');
  assert.equal(form, true);
  assert.equal(note, '', 'an admin token needs no note');
  for (const id of [blocker, queuedBySubmit, queuedByAdmin]) assert.deepEqual(buttons[id], ['Cancel'], id);
  assert.deepEqual(buttons[finished], ['Delete']);
});
