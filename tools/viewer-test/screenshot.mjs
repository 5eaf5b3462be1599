// A screenshot of the viewer page (HUD included) for the docs:
//   node tools/viewer-test/screenshot.mjs PANO OUT.png [URL-QUERY]
// Environment: POMC_BIN (default target/release/pomc), CHROMIUM (default /usr/bin/chromium).
import { spawn } from 'node:child_process';
import puppeteer from 'puppeteer-core';

const [pano, out, query = 'eye=0.3,-0.2,0.1&look=1,1,0&fov=100'] = process.argv.slice(2);
if (!out) { console.error('usage: screenshot.mjs PANO OUT.png [URL-QUERY]'); process.exit(2); }
const live = spawn(process.env.POMC_BIN || 'target/release/pomc', ['view', pano, '--port', '0', '--json'], { stdio: ['ignore', 'pipe', 'inherit'] });
const url = await new Promise((ok, bad) => {
  let buf = '';
  live.stdout.on('data', (d) => { buf += d; try { ok(JSON.parse(buf).url); } catch { /* more to come */ } });
  live.on('exit', (c) => bad(new Error(`pomc view exited with ${c}`)));
});
const browser = await puppeteer.launch({
  executablePath: process.env.CHROMIUM || '/usr/bin/chromium',
  headless: true,
  args: ['--no-sandbox', '--disable-gpu', '--use-angle=swiftshader', '--enable-unsafe-swiftshader', '--disable-background-networking'],
});
try {
  const page = await browser.newPage();
  await page.setViewport({ width: 960, height: 540 });
  await page.goto(`${url}?${query}`, { waitUntil: 'load' });
  await page.waitForFunction('window.pomcReady === true', { timeout: 120000 });
  await page.screenshot({ path: out });
} finally {
  await browser.close();
  live.kill();
}
