// The visual report of `shrm prefilter --report-html` (docs/cli.md "Visual report") in a real
// browser: Debian's headless Chromium, driven by playwright-core, opens the file from disk.
//
// Usage: node run_report.mjs REPORT.html OUT_DIR
// Checks (PASS/FAIL lines, exit 1 on any FAIL):
//   - no console message of type error or warning and no page error (a Content-Security-Policy
//     violation, e.g. a blocked request, is a console error);
//   - no network request: every request the page makes is the file itself or a data: URI;
//   - the pictures are drawn: an element screenshot of each plot and image is non-blank (enough
//     pixels away from the page's background), and the sections are all there;
//   - negative controls: a copy of the report with an external image added must fail the
//     request check, and a blank element must fail the non-blank check.
import { readFileSync, writeFileSync } from 'node:fs';
import { resolve, join } from 'node:path';
import { pathToFileURL } from 'node:url';
import { checker, launchChromium, requireChromium } from './harness.mjs';
import { decodePng } from './babylon_glb.mjs';

const [reportPath, outDir] = process.argv.slice(2).map((p) => resolve(p));
if (!outDir) {
  console.error('usage: node run_report.mjs REPORT.html OUT_DIR');
  process.exit(2);
}
requireChromium();
const { pass, fail, check, failures } = checker();

// A picture is "drawn" when at least this fraction of its pixels differ from the page's
// background (#fafafa) by more than BACKGROUND_DELTA in some channel. The sparsest picture, the
// timings' bars, covers about 5% of its box; an empty box has 0.
const MIN_INK = 0.01;
const BACKGROUND = [0xfa, 0xfa, 0xfa];
const BACKGROUND_DELTA = 24;
// The pictures the report must show (element, what it is).
const PICTURES = [
  ['img.map', 'the map thumbnail'],
  ['#lobe-plot', 'the BRDF lobe'],
  ['#accuracy-plot', 'the Fig. 5.5 curves'],
  ['#spheres ~ .row img:nth-of-type(1)', 'the SHRM spheres'],
  ['#error-map', 'the error map'],
  ['#timings-plot', 'the stage timings'],
];

function ink(png) {
  const { width, height, channels, px } = decodePng(png);
  let n = 0;
  for (let i = 0; i < width * height; ++i) {
    for (let c = 0; c < 3; ++c) {
      if (Math.abs(px[i * channels + c] - BACKGROUND[c]) > BACKGROUND_DELTA) { n++; break; }
    }
  }
  return n / (width * height);
}

// Opens `file` and returns { page, log, requests } once it has loaded.
async function open(browser, file) {
  const page = await browser.newPage({ viewport: { width: 1280, height: 900 } });
  const log = [], requests = [];
  const own = pathToFileURL(file).href;
  page.on('console', (m) => { if (m.type() === 'error' || m.type() === 'warning') log.push(`${m.type()}: ${m.text()}`); });
  page.on('pageerror', (e) => log.push(`pageerror: ${e.message}`));
  page.on('request', (r) => { if (r.url() !== own && !r.url().startsWith('data:')) requests.push(r.url()); });
  page.on('requestfailed', (r) => { if (!r.url().startsWith('data:') && r.url() !== own) requests.push(`failed ${r.url()}`); });
  await page.goto(own, { waitUntil: 'load' });
  await page.waitForTimeout(300);  // late console messages (CSP reports are asynchronous)
  return { page, log, requests };
}

const browser = await launchChromium();
try {
  const { page, log, requests } = await open(browser, reportPath);
  check(log.length === 0, `report: no console errors or warnings${log.length ? `: ${log.slice(0, 5).join(' | ')}` : ''}`);
  check(requests.length === 0, `report: no network request${requests.length ? `: ${requests.slice(0, 5).join(', ')}` : ''}`);
  for (const id of ['summary', 'inputs', 'orders', 'spheres', 'errors', 'timings']) {
    check(await page.locator(`#${id}`).count() === 1, `report: section #${id}`);
  }
  for (const [selector, what] of PICTURES) {
    const el = page.locator(selector).first();
    if (await el.count() === 0) { fail(`report: ${what} (${selector}) missing`); continue; }
    const png = await el.screenshot();
    const name = selector.replace(/[^a-z0-9]+/gi, '_').replace(/^_|_$/g, '');
    writeFileSync(join(outDir, `report-${name}.png`), png);
    const f = ink(png);
    check(f >= MIN_INK, `report: ${what} is drawn (${(100 * f).toFixed(1)}% of its pixels away from the background, >= ${100 * MIN_INK}%)`);
  }
  writeFileSync(join(outDir, 'report-page.png'), await page.screenshot({ fullPage: true }));
  // Negative control of the non-blank check: an empty box of the same page.
  await page.setContent('<div id="blank" style="width:300px;height:200px;background:#fafafa"></div>');
  const blank = ink(await page.locator('#blank').screenshot());
  check(blank < MIN_INK, `control: an empty box reads as blank (${(100 * blank).toFixed(1)}%)`);
  await page.close();

  // Negative control of the request check: the same report with one external image.
  const html = readFileSync(reportPath, 'utf8');
  const tampered = join(outDir, 'report-with-external-image.html');
  writeFileSync(tampered, html.replace('<h1>', "<img src='http://127.0.0.1:9/x.png'><h1>"));
  const t = await open(browser, tampered);
  check(t.requests.length > 0 || t.log.length > 0,
    `control: an external image is caught (${t.requests.length} requests, ${t.log.length} console messages: ${t.log[0] ?? ''})`);
  await t.page.close();
} finally {
  await browser.close();
}
if (failures() === 0) pass('visual report in Chromium');
process.exit(failures() ? 1 : 0);
