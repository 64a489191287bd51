// The pictures of docs/report.md, made from a report page in headless Chromium as it prints
// (print media, A4 width):
//
//   build/cli/fragsim run examples/demo/scenario.json --out /tmp/demo
//   build/cli/fragsim report /tmp/demo/results.h5 --out /tmp/demo/report.html --pdf docs/img/report-demo.pdf
//   node viewer/test/report_pages.mjs /tmp/demo/report.html [--out docs/img]
//
// Writes report-first-page.png (title, identity, findings), report-map.png (the close-up of the
// hazardous area and the site-plan boundary) and report-rose-profile.png. Not a test.
import path from 'node:path';
import * as h from './harness.mjs';

const file = path.resolve(process.argv[2] || '');
const outIndex = process.argv.indexOf('--out');
const OUT = path.resolve(outIndex > 0 ? process.argv[outIndex + 1] : path.join(h.REPO, 'docs', 'img'));

async function main() {
  const browser = await h.launchBrowser();
  try {
    const page = await h.openPage(browser, { viewport: { width: 794, height: 1123 } });
    await page.emulateMedia({ media: 'print' });
    await page.goto('file://' + file);
    await page.waitForFunction(() => document.documentElement.dataset.figures === 'drawn');
    const box = async (sel) => page.$eval(sel, (n) => {
      const r = n.getBoundingClientRect();
      return { x: r.x + window.scrollX, y: r.y + window.scrollY, width: r.width, height: r.height };
    });
    const shots = [
      ['report-first-page', { x: 0, y: 0, width: 794, height: 1123 }],
      ['report-map', await box('#fig-map')],
    ];
    const rose = await box('#fig-rose'), profile = await box('#fig-profile');
    shots.push(['report-rose-profile', { x: 0, y: rose.y, width: 794, height: profile.y + profile.height - rose.y }]);
    for (const [name, clip] of shots) {
      const target = path.join(OUT, `${name}.png`);
      await page.screenshot({ path: target, clip, fullPage: true });
      console.log(`report_pages: ${target}`);
    }
  } finally {
    await browser.close();
  }
}

main().catch((e) => { console.error(e); process.exit(1); });
