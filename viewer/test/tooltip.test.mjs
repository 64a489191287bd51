// Building tooltip: the demo job at 1/4 of its samples (10 buildings, impacts differ from
// penetrations), top view; the mouse on the centre of a hit building's footprint (projected with
// window.fragsimViewer.project) shows #tooltip with the building id, "impacts V ± SE" and
// "penetrations V ± SE" equal to summary.json within the displayed precision (3 significant
// digits, 2 for the standard error); the buildings-table row is highlighted; on bare ground the
// tooltip hides.
import assert from 'node:assert/strict';
import { after, before, test } from 'node:test';
import * as h from './harness.mjs';

let daemon, browser, page, run, scenario;

before(async () => {
  daemon = await h.startDaemon();
  browser = await h.launchBrowser();
  scenario = h.demoScenario(0.25);  // 20,000 histories: enough for hit buildings, quick
  scenario.settings.record_trajectories = false;
  run = await daemon.runScenario(scenario);
  page = await h.openPage(browser, { viewport: { width: 1400, height: 900 } });
  await h.login(page, daemon, { hash: `#/jobs/${run.job.job_id}`, ready: 'job' });
  page.diag.consoleErrors.length = 0; // the 401 before the token was given is expected
});

after(async () => {
  await h.finish({ page, browser, daemon });
});

/** Half a unit in the last displayed digit of format.js sig(x, digits). */
function halfUlp(x, digits) {
  if (x === 0) return 0;
  return 0.5 * 10 ** (Math.floor(Math.log10(Math.abs(x))) - (digits - 1));
}

function assertShown(text, label, value, se) {
  const re = new RegExp(`${label}\\s+(-?[0-9.]+(?:e[-+]?\\d+)?)\\s*±\\s*(-?[0-9.]+(?:e[-+]?\\d+)?)`);
  const m = re.exec(text);
  assert.ok(m, `tooltip has no "${label} V ± SE": ${JSON.stringify(text)}`);
  const [v, s] = [Number(m[1]), Number(m[2])];
  assert.ok(Math.abs(v - value) <= halfUlp(value, 3) * 1.001 + 1e-12,
    `tooltip ${label} ${m[1]} vs summary ${value} (3 significant digits)`);
  assert.ok(Math.abs(s - se) <= halfUlp(se, 2) * 1.001 + 1e-12,
    `tooltip ${label} standard error ${m[2]} vs summary ${se} (2 significant digits)`);
}

test('hovering a hit building shows its id, impacts ± se and penetrations ± se', { timeout: 60000 }, async () => {
  const sum = run.summary;
  // The most hit building whose impacts and penetrations differ (so that a swap shows).
  const hit = sum.buildings.filter((b) => b.expected_impacts > 0 && b.expected_penetrations > 0 &&
    Math.abs(b.expected_impacts - b.expected_penetrations) > 0.1 * b.expected_impacts)
    .sort((a, b) => b.expected_impacts - a.expected_impacts)[0];
  assert.ok(hit, `no building with impacts and penetrations > 0 in the demo: ${JSON.stringify(sum.buildings.map((b) => [b.id, b.expected_impacts, b.expected_penetrations]))}`);
  const def = scenario.site.buildings.find((b) => b.id === hit.id);
  const fp = def.footprint_m;
  const centre = [fp.reduce((s, p) => s + p[0], 0) / fp.length, fp.reduce((s, p) => s + p[1], 0) / fp.length, 0];

  await page.locator('#scene-canvas').scrollIntoViewIfNeeded();
  const n0 = (await h.renderState(page)).settledFrames;
  await page.click('#toggle-2d');
  await h.waitSettled(page, n0);
  // Top view (orthographic, looking down): the footprint centre's height does not move its pixel.
  let p = await h.project(page, centre);
  assert.ok(p.inside, `building ${hit.id} centre ${centre} is outside the top view`);
  // Small on screen: zoom in on it (the wheel zooms to the cursor) so that the mouse is well inside.
  const corners = await h.project(page, fp.map(([x, y]) => [x, y, 0]));
  const span = Math.min(Math.max(...corners.map((c) => c.x)) - Math.min(...corners.map((c) => c.x)),
    Math.max(...corners.map((c) => c.y)) - Math.min(...corners.map((c) => c.y)));
  if (span < 16) {
    for (let i = 0; i < 4; i++) {
      await page.mouse.move(p.clientX, p.clientY);
      await page.mouse.wheel(0, -500);
      await h.sleep(50);
      p = await h.project(page, centre);
    }
  }
  p = await h.settledProjection(page, centre);
  const onCanvas = await page.evaluate(({ x, y }) => document.elementFromPoint(x, y)?.id, { x: p.clientX, y: p.clientY });
  assert.equal(onCanvas, 'scene-canvas', `the building's centre is covered by #${onCanvas}`);

  const tip = page.locator('#tooltip');
  await page.mouse.move(p.clientX - 3, p.clientY - 3);
  await page.mouse.move(p.clientX, p.clientY, { steps: 2 });
  await tip.waitFor({ state: 'visible', timeout: 5000 });
  const text = (await tip.innerText()).replace(/\s+/g, ' ').trim();
  await h.screenshot(page, 'tooltip-1-building', { clip: { x: Math.max(0, p.clientX - 250), y: Math.max(0, p.clientY - 150), width: 500, height: 300 } });
  console.log(`# ${hit.id}: tooltip "${text}"; summary impacts ${hit.expected_impacts} ± ${hit.impacts_std_error}, penetrations ${hit.expected_penetrations} ± ${hit.penetrations_std_error}`);
  assert.ok(text.includes(hit.id), `tooltip "${text}" does not name ${hit.id}`);
  for (const other of sum.buildings) {
    if (other.id !== hit.id) assert.ok(!text.includes(other.id), `tooltip "${text}" names ${other.id} too`);
  }
  assertShown(text, 'impacts', hit.expected_impacts, hit.impacts_std_error);
  assertShown(text, 'penetrations', hit.expected_penetrations, hit.penetrations_std_error);
  const row = page.locator(`#buildings-table tr[data-building="${hit.id}"]`);
  assert.ok(await row.evaluate((tr) => tr.classList.contains('hover')), 'the buildings-table row is not highlighted');
  // The tooltip sits next to the cursor.
  const box = await tip.boundingBox();
  assert.ok(box && Math.abs(box.x - p.clientX) < 60 && Math.abs(box.y - p.clientY) < 60,
    `tooltip at ${JSON.stringify(box)}, cursor at ${p.clientX.toFixed(0)},${p.clientY.toFixed(0)}`);

  // Bare ground 40 m south of the building: no tooltip.
  const away = await h.project(page, [centre[0], centre[1] - 40 - Math.abs(fp[0][1] - centre[1]), 0]);
  await page.mouse.move(away.clientX, away.clientY, { steps: 3 });
  await tip.waitFor({ state: 'hidden', timeout: 5000 });
});

test('no console errors, no page errors', () => {
  assert.deepEqual(page.diag.pageErrors, [], 'page errors');
  assert.deepEqual(page.diag.consoleErrors, [], `console errors\n${h.fmtDiag(page)}`);
});
