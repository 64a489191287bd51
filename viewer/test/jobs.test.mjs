// (b) The jobs table follows a submitted job: its progress cell moves while it runs and its state
// becomes "done" (with an a.open link). (d) A running job is cancelled from the page's
// button.cancel (confirm() accepted) and the daemon reports it cancelled; then its button.purge
// (confirm() accepted) deletes it: the row goes and the daemon answers 404 for it.
import assert from 'node:assert/strict';
import { after, before, test } from 'node:test';
import * as h from './harness.mjs';

let daemon, browser, page, demoSiteId;

before(async () => {
  // 2 worker threads whatever the machine, so that the jobs below last long enough to be watched.
  daemon = await h.startDaemon({ threads: 2 });
  browser = await h.launchBrowser();
  demoSiteId = (await daemon.uploadSite(h.demoScenario().site)).site_id;
  page = await h.openPage(browser, { viewport: { width: 1280, height: 800 } });
  await h.login(page, daemon);
});

after(async () => {
  await h.finish({ page, browser, daemon });
});

function rowOf(id) { return page.locator(`#jobs-table tr[data-job-id="${id}"]`); }

async function rowState(id) {
  const row = rowOf(id);
  if (!(await row.count())) return null;
  const [state, progress] = await Promise.all([
    row.locator('td.state').innerText().catch(() => ''),
    row.locator('td.progress').innerText().catch(() => ''),
  ]);
  const m = /(\d+(?:\.\d+)?)\s*%/.exec(progress);
  return { state: state.trim(), progress: progress.trim(), pct: m ? Number(m[1]) : null };
}

test('progress while running, then done', { timeout: 90000 }, async () => {
  // demo x6 = 480,000 histories: ~3 s at 85,000 histories/s per thread, ~8 s on the 2-core CI box.
  const { job } = h.splitScenario(h.demoScenario(6), demoSiteId);
  const id = (await daemon.submitJob(job, { priority: 3 })).job_id;
  await rowOf(id).waitFor({ timeout: 10000 });

  const seen = [];
  let shotRunning = false;
  const t0 = Date.now();
  for (;;) {
    const s = await rowState(id);
    if (s) seen.push(s);
    if (s?.state === 'running' && s.pct > 0 && !shotRunning) {
      assert.equal(await rowOf(id).locator('td.eta').count(), 1, 'running row has no td.eta');
      await h.screenshot(page, 'jobs-1-running', { fullPage: true });
      shotRunning = true;
    }
    if (s?.state === 'done' || s?.state === 'failed' || s?.state === 'cancelled') break;
    assert.ok(Date.now() - t0 < 60000, `job row not done after 60 s; seen ${JSON.stringify(seen.slice(-5))}`);
    await h.sleep(150);
  }
  const summary = `seen: ${JSON.stringify([...new Map(seen.map((s) => [s.state + s.progress, s])).values()])}`;
  assert.equal(seen.at(-1).state, 'done', summary);
  const running = seen.filter((s) => s.state === 'running' && s.pct !== null && s.pct > 0 && s.pct < 100);
  assert.ok(running.length > 0, `no progress strictly between 0 and 100 % shown while running; ${summary}`);
  assert.ok(new Set(running.map((s) => s.pct)).size >= 2, `progress cell did not change while running; ${summary}`);
  const pcts = seen.filter((s) => s.pct !== null).map((s) => s.pct);
  for (let i = 1; i < pcts.length; i++) assert.ok(pcts[i] >= pcts[i - 1], `progress went backwards; ${summary}`);

  // Done: an a.open link to the job view, no cancel button; priority shown.
  const row = rowOf(id);
  await row.locator('a.open').waitFor();
  assert.equal(await row.locator('a.open').getAttribute('href'), `#/jobs/${id}`);
  assert.equal(await row.locator('button.cancel').count(), 0, 'done job still has a cancel button');
  assert.equal((await row.locator('td.priority').innerText()).trim(), '3');
  await h.screenshot(page, 'jobs-2-done', { fullPage: true });
  const api = await daemon.getJob(id);
  assert.equal(api.state, 'done');
});

test('cancel a running job from the page', { timeout: 60000 }, async () => {
  // demo x20 = 1.6 M histories: 10-30 s on 2 threads, cancelled long before.
  const { job } = h.splitScenario(h.demoScenario(20), demoSiteId);
  const id = (await daemon.submitJob(job)).job_id;
  await daemon.waitForState(id, 'running', 15000);
  const row = rowOf(id);
  await row.locator('td.state', { hasText: 'running' }).waitFor({ timeout: 10000 });
  const cancel = row.locator('button.cancel');
  await cancel.waitFor();
  await h.screenshot(page, 'jobs-3-before-cancel', { fullPage: true });
  const dialogsBefore = page.diag.dialogs.length;
  await cancel.click();

  const st = await daemon.waitForState(id, 'cancelled', 10000);
  assert.equal(st.state, 'cancelled');
  assert.ok(page.diag.requests.some((r) => r.method === 'DELETE' && r.url.endsWith(`/v1/jobs/${id}`)),
    'no DELETE /v1/jobs/{id} request from the page');
  await row.locator('td.state', { hasText: 'cancelled' }).waitFor({ timeout: 5000 });
  assert.equal(await row.locator('button.cancel').count(), 0, 'cancelled job still has a cancel button');
  await h.screenshot(page, 'jobs-4-cancelled', { fullPage: true });
  console.log(`# dialogs accepted: ${JSON.stringify(page.diag.dialogs.slice(dialogsBefore))}`);

  // Finished, it can be deleted (purged) after a confirmation; its row goes, the daemon forgets it.
  const purge = row.locator('button.purge');
  await purge.waitFor();
  const confirmsBefore = page.diag.dialogs.length;
  // The cancel's 200 came once the worker had let go of the run (Scheduler::cancel waits for
  // it), so the purge is not refused as "still letting go".
  await purge.click();
  await row.waitFor({ state: 'detached', timeout: 10000 });
  const confirms = page.diag.dialogs.slice(confirmsBefore);
  assert.ok(confirms.length === 1 && confirms[0].startsWith('confirm: ') && confirms[0].includes(id),
    `no confirm() naming the job before the delete: ${JSON.stringify(confirms)}`);
  assert.ok(page.diag.requests.some((r) => r.method === 'DELETE' && r.url.endsWith(`/v1/jobs/${id}?purge=true`)),
    'no DELETE /v1/jobs/{id}?purge=true request from the page');
  const gone = await daemon.request(`/v1/jobs/${id}`);
  assert.equal(gone.status, 404, 'the purged job is still known to the daemon');
  await h.screenshot(page, 'jobs-4b-deleted', { fullPage: true });

  assert.deepEqual(page.diag.pageErrors, [], 'page errors');
  assert.deepEqual(h.unexpectedConsoleErrors(page, [401]), [], 'console errors');
});

test('cancel a queued job from the page; the running one keeps running', { timeout: 60000 }, async () => {
  // Two long jobs (demo x20 each, 10-30 s on 2 threads); the daemon runs one job at a time.
  const { job } = h.splitScenario(h.demoScenario(20), demoSiteId);
  const running = (await daemon.submitJob(job)).job_id;
  let queued = null;
  try {
    await daemon.waitForState(running, 'running', 15000);
    queued = (await daemon.submitJob(job)).job_id;
    assert.equal((await daemon.getJob(queued)).state, 'queued', 'the second job is not queued behind the first');

    const qrow = rowOf(queued);
    await qrow.locator('td.state', { hasText: 'queued' }).waitFor({ timeout: 10000 });
    await rowOf(running).locator('td.state', { hasText: 'running' }).waitFor({ timeout: 10000 });
    const cancel = qrow.locator('button.cancel');
    await cancel.waitFor();
    await h.screenshot(page, 'jobs-5-queued-before-cancel', { fullPage: true });
    const before = await daemon.getJob(running);
    await cancel.click();

    const st = await daemon.waitForState(queued, 'cancelled', 10000);
    assert.equal(st.state, 'cancelled');
    assert.equal(st.started_utc ?? null, null, 'the cancelled queued job was started');
    assert.ok(page.diag.requests.some((r) => r.method === 'DELETE' && r.url.endsWith(`/v1/jobs/${queued}`)),
      'no DELETE /v1/jobs/{queued id} request from the page');
    assert.ok(!page.diag.requests.some((r) => r.method === 'DELETE' && r.url.endsWith(`/v1/jobs/${running}`)),
      'the page sent a DELETE for the running job');
    await qrow.locator('td.state', { hasText: 'cancelled' }).waitFor({ timeout: 5000 });
    assert.equal(await qrow.locator('button.cancel').count(), 0, 'cancelled job still has a cancel button');

    // The running job goes on: still running, progress moving, its row still has its cancel button.
    await h.sleep(1200);
    const now = await daemon.getJob(running);
    assert.equal(now.state, 'running', `the running job is ${now.state} after the queued one was cancelled`);
    assert.ok(now.histories_done > before.histories_done,
      `the running job made no progress (${before.histories_done} -> ${now.histories_done} histories)`);
    const rrow = rowOf(running);
    assert.equal((await rrow.locator('td.state').innerText()).trim(), 'running');
    assert.equal(await rrow.locator('button.cancel').count(), 1, 'the running job lost its cancel button');
    await h.screenshot(page, 'jobs-6-queued-cancelled', { fullPage: true });

    // Clean up: cancel the running one from the page too.
    await rrow.locator('button.cancel').click();
    assert.equal((await daemon.waitForState(running, 'cancelled', 10000)).state, 'cancelled');
    await rrow.locator('td.state', { hasText: 'cancelled' }).waitFor({ timeout: 5000 });
  } finally {
    for (const id of [running, queued]) {
      if (id) await daemon.request(`/v1/jobs/${id}`, { method: 'DELETE' }).catch(() => {});
    }
  }
  assert.deepEqual(page.diag.pageErrors, [], 'page errors');
  assert.deepEqual(h.unexpectedConsoleErrors(page, [401]), [], 'console errors');
});
