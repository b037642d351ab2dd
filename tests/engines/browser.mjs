// What the browser-driven checks (run_browser.mjs, babylon_run.mjs) share: the loopback HTTP
// server (/engines/ = this folder, /node_modules/ = the npm ci folder, plus the caller's routes)
// and Debian's chromium launched headless with WebGL2 on SwiftShader (playwright-core).
import { createServer } from 'node:http';
import { readFileSync, existsSync, statSync } from 'node:fs';
import { join, extname, dirname } from 'node:path';
import { fileURLToPath } from 'node:url';
import { chromium } from 'playwright-core';

const HERE = dirname(fileURLToPath(import.meta.url));
const MIME = { '.html': 'text/html', '.mjs': 'text/javascript', '.js': 'text/javascript', '.json': 'application/json' };

// route(url) -> a file path, a Buffer to send, or null (404) for the caller's URLs.
export async function serveEngines(route = () => null) {
  const server = createServer((req, res) => {
    const url = decodeURIComponent(new URL(req.url, 'http://x').pathname);
    let file = route(url);
    if (Buffer.isBuffer(file)) {
      res.writeHead(200, { 'Content-Type': 'application/octet-stream' }).end(file);
      return;
    }
    let m;
    if ((m = url.match(/^\/engines\/([\w.-]+)$/))) file = join(HERE, m[1]);
    else if (url.startsWith('/node_modules/') && !url.includes('..')) file = join(HERE, url);
    if (!file || !existsSync(file) || !statSync(file).isFile()) {
      res.writeHead(404).end();
      return;
    }
    res.writeHead(200, { 'Content-Type': MIME[extname(file)] ?? 'application/octet-stream' });
    res.end(readFileSync(file));
  });
  await new Promise((ok) => server.listen(0, '127.0.0.1', ok));
  return { server, base: `http://127.0.0.1:${server.address().port}` };
}

export function launchChromium(executablePath) {
  return chromium.launch({
    executablePath,
    headless: true,
    timeout: 120000,
    args: [
      '--no-sandbox', '--use-angle=swiftshader', '--enable-unsafe-swiftshader', '--ignore-gpu-blocklist',
      '--disable-background-networking', '--disable-component-update', '--disable-sync',
      '--no-first-run', '--disable-quic',
    ],
  });
}
