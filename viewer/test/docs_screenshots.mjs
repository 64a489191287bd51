// The screenshots of docs/viewer.md, made from the demo job in headless Chromium:
//
//   node viewer/test/docs_screenshots.mjs [--out docs/img]      (after viewer/test/run.sh once)
//
// Starts a loopback fragsimd (token auth, the page compiled in unless FRAGSIM_UI_DIR is set), runs
// examples/demo/scenario.json (which records 1,000 trajectories), keeps a longer copy of it
// running for the jobs view, and writes viewer-jobs.png, viewer-job.png, viewer-job-top.png and
// viewer-site.png at 1400 x 900; then viewer-job-hfd-lower-bound.png, the minimal example on a
// 400 m plane whose boundary cuts the HFD (top view, trajectories hidden). Not a test: it asserts
// nothing beyond the views becoming ready.
import path from 'node:path';
import * as h from './harness.mjs';

const outIndex = process.argv.indexOf('--out');
const OUT = path.resolve(outIndex > 0 ? process.argv[outIndex + 1] : path.join(h.REPO, 'docs', 'img'));

async function shoot(page, name, opts = {}) {
  await h.nextFrames(page, 3);
  await h.sleep(600);  // the full-quality frame follows the last camera change by 200 ms
  await page.screenshot({ path: path.join(OUT, `${name}.png`), ...opts });
  console.log(`docs_screenshots: ${path.join(OUT, name)}.png`);
}

async function main() {
  const daemon = await h.startDaemon({ threads: 1 });
  const browser = await h.launchBrowser();
  try {
    const site = await daemon.uploadSite(h.demoScenario().site);
    const { job } = h.splitScenario(h.demoScenario(), site.site_id);
    const done = await daemon.submitJob(job);
    await daemon.waitForState(done.job_id, ['done'], 120000);
    const slow = h.splitScenario(h.demoScenario(40), site.site_id).job;
    const running = await daemon.submitJob(slow, { priority: 5 });
    await daemon.submitJob(slow, { priority: 0 });
    await daemon.waitForState(running.job_id, ['running'], 60000);

    const page = await h.openPage(browser, { viewport: { width: 1400, height: 900 } });
    await h.login(page, daemon);
    await h.sleep(2500);  // a few progress updates
    await shoot(page, 'viewer-jobs', { clip: { x: 0, y: 0, width: 1400, height: 520 } });

    await page.goto(`${daemon.base}/ui/#/jobs/${done.job_id}`);
    await h.waitReady(page, 'job');
    await shoot(page, 'viewer-job');
    await page.click('#toggle-2d');
    await shoot(page, 'viewer-job-top');

    await page.goto(`${daemon.base}/ui/#/sites/${site.site_id}`);
    await h.waitReady(page, 'site');
    await shoot(page, 'viewer-site');

    for (const j of (await daemon.expectOk('/v1/jobs')).jobs)
      if (j.state === 'queued' || j.state === 'running')
        await daemon.request(`/v1/jobs/${j.job_id}`, { method: 'DELETE' });

    const cut = await daemon.runScenario(h.smallPlaneScenario(), 60000);
    await page.goto(`${daemon.base}/ui/#/jobs/${cut.job.job_id}`);
    await h.waitReady(page, 'job');
    await page.click('#toggle-2d');
    await page.uncheck('#layer-trajectories');
    await shoot(page, 'viewer-job-hfd-lower-bound');
  } finally {
    await browser.close();
    await daemon.stop();
  }
}

main().catch((e) => {
  console.error(e);
  process.exit(1);
});
