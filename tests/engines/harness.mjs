// What the browser tests share (run_browser.mjs, run_filament.mjs): the loopback HTTP server
// (/engines/ = this folder, /node_modules/ = the npm ci folder, /set/<k>/ = the k-th set folder),
// Debian's headless Chromium with WebGL2 on SwiftShader (no network use: the background
// services are off), and PASS/FAIL counting.
import { createServer } from 'node:http';
import { readFileSync, existsSync, statSync } from 'node:fs';
import { join, extname, dirname } from 'node:path';
import { fileURLToPath } from 'node:url';
import { chromium } from 'playwright-core';

export const HERE = dirname(fileURLToPath(import.meta.url));
export const CHROMIUM = process.env.CHROMIUM ?? '/usr/bin/chromium';

const MIME = {
  '.html': 'text/html', '.mjs': 'text/javascript', '.js': 'text/javascript',
  '.json': 'application/json', '.wasm': 'application/wasm',
};

// Serves `sets` (folders) on 127.0.0.1; resolves to { base, close }.
export async function serve(sets) {
  const server = createServer((req, res) => {
    const url = decodeURIComponent(new URL(req.url, 'http://x').pathname);
    let file = null;
    let m;
    if ((m = url.match(/^\/engines\/([\w.-]+)$/))) file = join(HERE, m[1]);
    else if (url.startsWith('/node_modules/') && !url.includes('..')) file = join(HERE, url);
    else if ((m = url.match(/^\/set\/(\d+)\/([\w.-]+)$/)) && sets[+m[1]]) file = join(sets[+m[1]], m[2]);
    if (!file || !existsSync(file) || !statSync(file).isFile()) {
      res.writeHead(404).end();
      return;
    }
    res.writeHead(200, { 'Content-Type': MIME[extname(file)] ?? 'application/octet-stream' });
    res.end(readFileSync(file));
  });
  await new Promise((ok) => server.listen(0, '127.0.0.1', ok));
  return { base: `http://127.0.0.1:${server.address().port}`, close: () => server.close() };
}

// `extraArgs`: e.g. ['--enable-unsafe-webgpu'] for WebGPU on SwiftShader (run_shaders.mjs).
export function launchChromium(extraArgs = []) {
  return chromium.launch({
    executablePath: CHROMIUM,
    headless: true,
    timeout: 120000,
    args: [
      '--no-sandbox', '--use-angle=swiftshader', '--enable-unsafe-swiftshader', '--ignore-gpu-blocklist',
      '--disable-background-networking', '--disable-component-update', '--disable-sync',
      '--no-first-run', '--disable-quic', ...extraArgs,
    ],
  });
}

// PASS/FAIL lines; `failures()` counts the FAILs.
export function checker() {
  let failures = 0;
  const pass = (m) => console.log(`PASS: ${m}`);
  const fail = (m) => { console.log(`FAIL: ${m}`); failures++; };
  return { pass, fail, check: (ok, m) => (ok ? pass(m) : fail(m)), failures: () => failures };
}

// Exits with a FAIL line when Debian's chromium is missing (an install error, never a skip).
export function requireChromium() {
  if (existsSync(CHROMIUM)) return;
  console.log(`FAIL: ${CHROMIUM} missing: run scripts/install-deps.sh (Debian package chromium)`);
  process.exit(1);
}

// A page of `browser` at `url` (viewport width x height) that has set window.shrmReady; its
// console and page errors collect in the returned log.
export async function openPage(browser, url, width, height) {
  const log = [];
  const page = await browser.newPage({ viewport: { width, height } });
  page.setDefaultTimeout(300000);
  page.on('console', (msg) => log.push(`${msg.type()}: ${msg.text()}`));
  page.on('pageerror', (e) => log.push(`pageerror: ${e.message}`));
  await page.goto(url);
  await page.waitForFunction(() => window.shrmReady === true);
  return { page, log };
}
