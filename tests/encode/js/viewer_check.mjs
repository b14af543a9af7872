// Opens an `isoslab view` page in a real browser (Debian's chromium through playwright-core), over
// http from a local server and from file://, and prints what it showed as JSON:
// {triangles, primitives, nonBlank, chunkChanged, flatChanged, title, external, file}. Exits non-zero when the
// page did not load. Usage: node viewer_check.mjs PAGE.html SCREENSHOT.png
import http from 'node:http';
import fs from 'node:fs';
import path from 'node:path';
import { pathToFileURL } from 'node:url';
import { chromium } from 'playwright-core';

const [pageFile, screenshot] = process.argv.slice(2);
if (!pageFile || !screenshot) {
  console.error('usage: node viewer_check.mjs PAGE.html SCREENSHOT.png');
  process.exit(2);
}
const folder = path.dirname(path.resolve(pageFile));

// A static server for the page's folder.
const server = http.createServer((req, res) => {
  const file = path.join(folder, decodeURIComponent(new URL(req.url, 'http://127.0.0.1').pathname));
  if (!file.startsWith(folder + path.sep) || !fs.existsSync(file) || !fs.statSync(file).isFile()) {
    res.writeHead(404).end();
    return;
  }
  res.writeHead(200, { 'Content-Type': file.endsWith('.html') ? 'text/html; charset=utf-8' : 'application/octet-stream' });
  fs.createReadStream(file).pipe(res);
});
await new Promise((resolve) => server.listen(0, '127.0.0.1', resolve));
const base = `http://127.0.0.1:${server.address().port}/`;

const browser = await chromium.launch({
  executablePath: process.env.ISOSLAB_CHROMIUM || '/usr/bin/chromium',
  args: ['--headless', '--no-sandbox', '--disable-gpu', '--disable-background-networking',
    '--use-angle=swiftshader', '--enable-unsafe-swiftshader'],
});

// Pixels of the WebGL canvas that differ from the background (its corner), and those that differ
// from the previous call's, read back in the page.
const countPixels = () => {
  const gl = document.querySelector('canvas');
  const c = document.createElement('canvas');
  c.width = gl.width;
  c.height = gl.height;
  const g = c.getContext('2d');
  g.drawImage(gl, 0, 0);
  const p = g.getImageData(0, 0, c.width, c.height).data;
  const q = window.viewerCheckPixels;
  const far = (a, i, b, j) => Math.abs(a[i] - b[j]) + Math.abs(a[i + 1] - b[j + 1]) + Math.abs(a[i + 2] - b[j + 2]) > 12;
  let count = 0;
  let changed = 0;
  for (let i = 0; i < p.length; i += 4) {
    if (far(p, i, p, 0)) ++count;
    if (q && far(p, i, q, i)) ++changed;
  }
  window.viewerCheckPixels = p;
  return { count, changed };
};

async function open(url, shot) {
  const page = await browser.newPage({ viewport: { width: 800, height: 600 } });
  const messages = [];
  const external = [];
  page.on('pageerror', (e) => messages.push(String(e)));
  page.on('console', (m) => { if (m.type() === 'error') messages.push(m.text()); });
  page.on('request', (r) => {
    const u = r.url();
    if (!(u === url || u.startsWith('blob:') || u.startsWith('data:'))) external.push(u);
  });
  const start = Date.now();
  await page.goto(url);
  await page.waitForFunction(() => window.isoslabViewer && (window.isoslabViewer.ready || window.isoslabViewer.error),
    null, { timeout: 60000 });
  const viewer = await page.evaluate(() => window.isoslabViewer);
  console.error(`viewer_check: ${url.slice(0, 7)}... ready in ${Date.now() - start} ms`);
  const result = { ...viewer, title: await page.title(), external, messages };
  if (viewer.ready && shot) {
    const before = await page.evaluate(countPixels);
    result.nonBlank = before.count;
    await page.screenshot({ path: shot });
    // Colour by chunk: the mesh's pixels change colour.
    await page.click('#chunks');
    result.chunkChanged = (await page.evaluate(countPixels)).changed;
    // Flat shading: the facets show.
    await page.click('#flat');
    result.flatChanged = (await page.evaluate(countPixels)).changed;
  }
  await page.close();
  return result;
}

let ok = false;
try {
  const overHttp = await open(base + encodeURIComponent(path.basename(pageFile)), screenshot);
  const fromFile = await open(pathToFileURL(path.resolve(pageFile)).href, null);
  const out = {
    triangles: overHttp.triangles,
    primitives: overHttp.primitives,
    nonBlank: overHttp.nonBlank,
    chunkChanged: overHttp.chunkChanged,
    flatChanged: overHttp.flatChanged,
    title: overHttp.title,
    error: overHttp.error,
    external: overHttp.external.concat(fromFile.external),
    messages: overHttp.messages,
    file: { ready: fromFile.ready === true, triangles: fromFile.triangles, error: fromFile.error, messages: fromFile.messages },
  };
  console.log(JSON.stringify(out));
  ok = overHttp.ready === true && fromFile.ready === true;
} catch (e) {
  console.log(JSON.stringify({ error: String(e) }));
} finally {
  await browser.close();
  server.close();
}
process.exit(ok ? 0 : 1);
