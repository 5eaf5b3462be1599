// The viewer in a real browser: exports `pomc view PANO --export` sites, serves them from a plain
// static server, drives headless Chromium (Debian's, via puppeteer-core) to URL cameras and compares
// each frame with `pomc render --method mesh` of the same camera. Also checks the hole switch, the
// console, `pomc view --port` serving the same page, and reports time to first frame and site size.
//
//   node tools/viewer-test/run.mjs [--check] [--report FILE] [--keep DIR] PANO...
//
// Environment: POMC_BIN (default target/release/pomc), CHROMIUM (default /usr/bin/chromium).
// Each PANO is a panorama directory; cameras are placed from its centre and freedom radius.
import { spawn, spawnSync } from 'node:child_process';
import fs from 'node:fs';
import http from 'node:http';
import os from 'node:os';
import path from 'node:path';
import { PNG } from 'pngjs';
import puppeteer from 'puppeteer-core';

const args = process.argv.slice(2);
const flag = (name) => { const i = args.indexOf(name); if (i < 0) return false; args.splice(i, 1); return true; };
const option = (name) => { const i = args.indexOf(name); if (i < 0) return null; const v = args[i + 1]; args.splice(i, 2); return v; };
const check = flag('--check');
const reportFile = option('--report');
const keep = option('--keep');
const panos = args;
if (panos.length === 0) { console.error('usage: run.mjs [--check] [--report FILE] [--keep DIR] PANO...'); process.exit(2); }
const POMC = process.env.POMC_BIN || 'target/release/pomc';
const CHROMIUM = process.env.CHROMIUM || '/usr/bin/chromium';
const MIN_PSNR = 30;
const SIZE = [480, 270];
const work = keep || fs.mkdtempSync(path.join(os.tmpdir(), 'pomc-viewer-'));
fs.mkdirSync(work, { recursive: true });

function pomc(...a) {
  const r = spawnSync(POMC, a, { encoding: 'utf8', maxBuffer: 1 << 26 });
  if (r.status !== 0) throw new Error(`pomc ${a.join(' ')}: exit ${r.status}\n${r.stderr}`);
  return r.stdout;
}

function serveDir(dir) {
  const types = { '.html': 'text/html', '.js': 'text/javascript', '.json': 'application/json', '.glb': 'model/gltf-binary' };
  const server = http.createServer((req, res) => {
    const rel = decodeURIComponent(new URL(req.url, 'http://x').pathname).replace(/^\/+/, '') || 'index.html';
    const file = path.join(dir, rel);
    if (!file.startsWith(dir) || !fs.existsSync(file) || !fs.statSync(file).isFile()) { res.writeHead(404); res.end(); return; }
    res.writeHead(200, { 'Content-Type': types[path.extname(file)] || 'application/octet-stream' });
    fs.createReadStream(file).pipe(res);
  });
  return new Promise((ok) => server.listen(0, '127.0.0.1', () => ok(server)));
}

function decodePng(buf) {
  const png = PNG.sync.read(buf);
  return { width: png.width, height: png.height, data: png.data };
}

// PSNR over RGB of two RGBA images of one size; `magenta` counts pure (255, 0, 255) pixels of `a`.
function compare(a, b) {
  if (a.width !== b.width || a.height !== b.height) throw new Error(`size ${a.width}x${a.height} vs ${b.width}x${b.height}`);
  let se = 0;
  const n = a.width * a.height;
  for (let i = 0; i < n; i++) for (let c = 0; c < 3; c++) { const d = a.data[4 * i + c] - b.data[4 * i + c]; se += d * d; }
  const mse = se / (3 * n);
  return mse === 0 ? 99 : 10 * Math.log10((255 * 255) / mse);
}
function magentaShare(img) {
  let m = 0;
  const n = img.width * img.height;
  for (let i = 0; i < n; i++) if (img.data[4 * i] === 255 && img.data[4 * i + 1] === 0 && img.data[4 * i + 2] === 255) m++;
  return m / n;
}

const fmt = (v) => v.map((x) => +x.toFixed(6)).join(',');

// Cameras in the panorama's world frame: from the centre and up to 0.9 R out, several directions;
// and one eye outside the freedom radius.
function cameras(info) {
  const [cx, cy, cz] = info.centre;
  const r = info.freedom_radius;
  const dirs = [[1, 0, 0], [0, 1, 0], [-1, 0, 0], [0, -1, 0], [0.7, 0.7, -0.3], [-0.6, 0.5, 0.4]];
  const offs = [[0, 0, 0], [0.5, 0, 0], [0, -0.6, 0.1], [-0.45, 0.45, 0], [0.3, 0.3, -0.5], [-0.2, -0.7, 0.2]];
  const inside = dirs.map((d, k) => {
    const o = offs[k].map((x) => x * r);
    const eye = [cx + o[0], cy + o[1], cz + o[2]];
    return { name: `in${k}`, eye, look: [eye[0] + d[0], eye[1] + d[1], eye[2] + d[2]], fov: k % 2 ? 60 : 90, inside: true };
  });
  const outside = [[3, 0, 0], [0, 3, 0], [2.1, 2.1, 0.55]].map((o, k) => ({
    name: `out${k}`, eye: [cx + o[0] * r, cy + o[1] * r, cz + o[2] * r], look: [cx, cy, cz], fov: 90, inside: false,
  }));
  return { inside, outside };
}

async function frame(page, base, cam, extra = '') {
  const url = `${base}?eye=${fmt(cam.eye)}&look=${fmt(cam.look)}&up=0,0,1&fov=${cam.fov}&size=${SIZE[0]}x${SIZE[1]}&hud=0${extra}`;
  const t0 = Date.now();
  await page.goto(url, { waitUntil: 'load' });
  await page.waitForFunction('window.pomcReady === true || window.pomcError !== undefined', { timeout: 120000, polling: 50 });
  const ms = Date.now() - t0;
  const err = await page.evaluate('window.pomcError');
  if (err) throw new Error(err);
  const dataUrl = await page.evaluate('document.querySelector("canvas").toDataURL("image/png")');
  return { image: decodePng(Buffer.from(dataUrl.split(',')[1], 'base64')), ms };
}

// `pomc render --method mesh` of the camera: the image and its hole mask (true where no layer covers).
function reference(pano, cam, file) {
  const mask = file.replace(/\.png$/, '-mask.png');
  pomc('render', pano, '--method', 'mesh', '--eye', fmt(cam.eye), '--look-at', fmt(cam.look), '--up', '0,0,1',
    '--fov', String(cam.fov), '--size', `${SIZE[0]}x${SIZE[1]}`, '-o', file, '--mask', mask, '--quiet');
  const m = decodePng(fs.readFileSync(mask));
  const holes = new Uint8Array(m.width * m.height).map((_, i) => (m.data[4 * i] < 128 ? 1 : 0));
  return { image: decodePng(fs.readFileSync(file)), holes };
}

// How well the magenta pixels of `img` match the renderer's holes: the share of pixels where they
// disagree.
function holeDisagreement(img, holes) {
  let bad = 0;
  for (let i = 0; i < holes.length; i++) {
    const magenta = img.data[4 * i] === 255 && img.data[4 * i + 1] === 0 && img.data[4 * i + 2] === 255;
    if (magenta !== (holes[i] === 1)) bad++;
  }
  return bad / holes.length;
}

async function main() {
  const browser = await puppeteer.launch({
    executablePath: CHROMIUM,
    headless: true,
    args: ['--no-sandbox', '--disable-gpu', '--use-angle=swiftshader', '--enable-unsafe-swiftshader', '--ignore-gpu-blocklist',
      '--disable-quic', '--no-first-run', '--disable-background-networking', '--disable-component-update', '--disable-sync'],
  });
  const report = { panoramas: [], failures: [] };
  const failIf = (cond, msg) => { if (cond) report.failures.push(msg); };
  try {
    for (const pano of panos) {
      const name = path.relative(process.cwd(), path.resolve(pano)).split(path.sep).slice(-2).join('-');
      const site = path.join(work, `${name}-site`);
      const t0 = Date.now();
      const exported = JSON.parse(pomc('view', pano, '--export', site, '--json'));
      const exportS = (Date.now() - t0) / 1000;
      const info = JSON.parse(fs.readFileSync(path.join(site, 'pano.json'), 'utf8'));
      const server = await serveDir(site);
      const base = `http://127.0.0.1:${server.address().port}/`;
      const page = await browser.newPage();
      const console_ = [];
      const warnings = [];
      page.on('console', (m) => {
        if (m.type() === 'error') console_.push(`error: ${m.text()}`);
        else if (m.type() === 'warn') warnings.push(m.text());
      });
      page.on('pageerror', (e) => console_.push(`pageerror: ${e.message}`));
      page.on('requestfailed', (r) => console_.push(`requestfailed: ${r.url()}`));
      // Requests leaving localhost would break "nothing fetched at run time".
      const remote = [];
      const local = (u) => /^(blob:)?http:\/\/127\.0\.0\.1:\d+\//.test(u) || u.startsWith('data:');
      page.on('request', (r) => { if (!local(r.url())) remote.push(r.url()); });
      await page.setViewport({ width: SIZE[0], height: SIZE[1] });
      const entry = { panorama: pano, site_bytes: exported.bytes, export_seconds: exportS, triangles: exported.triangles, views: [] };
      const cams = cameras(info);
      for (const cam of [...cams.inside, ...cams.outside]) {
        const { image: ref, holes } = reference(pano, cam, path.join(work, `${name}-${cam.name}-ref.png`));
        const { image, ms } = await frame(page, base, cam);
        const holesOn = (await frame(page, base, cam, '&holes=1')).image;
        const psnr = compare(image, ref);
        const magenta = magentaShare(holesOn);
        const renderHoles = holes.reduce((a, b) => a + b, 0) / holes.length;
        const disagree = holeDisagreement(holesOn, holes);
        if (keep) fs.writeFileSync(path.join(work, `${name}-${cam.name}-view.png`), PNG.sync.write(Object.assign(new PNG({ width: image.width, height: image.height }), { data: image.data })));
        entry.views.push({ camera: cam.name, inside: cam.inside, eye: cam.eye, look: cam.look, fov: cam.fov, psnr_db: +psnr.toFixed(2), magenta_share: +magenta.toFixed(5),
          render_hole_share: +renderHoles.toFixed(5), hole_disagreement: +disagree.toFixed(5), ms });
        console.log(`${name} ${cam.name}: PSNR ${psnr.toFixed(2)} dB against pomc render --method mesh; magenta ${(100 * magenta).toFixed(3)} % ` +
          `(renderer's holes ${(100 * renderHoles).toFixed(3)} %, disagreeing ${(100 * disagree).toFixed(3)} %); ${ms} ms`);
        failIf(disagree > 0.005, `${name} ${cam.name}: the hole switch and the renderer's holes disagree on ${(100 * disagree).toFixed(3)} % of pixels`);
        if (cam.inside) {
          failIf(psnr < MIN_PSNR, `${name} ${cam.name}: PSNR ${psnr.toFixed(2)} dB < ${MIN_PSNR}`);
          failIf(magenta > 0.001, `${name} ${cam.name}: hole switch paints ${(100 * magenta).toFixed(3)} % inside the freedom radius`);
        }
      }
      // The switch paints what no visible layer covers: with every layer hidden, all of the view.
      const hidden = (await frame(page, base, cams.inside[0], '&holes=1&layers=')).image;
      entry.magenta_with_no_layer = +magentaShare(hidden).toFixed(5);
      failIf(entry.magenta_with_no_layer < 0.999, `${name}: with every layer hidden, only ${(100 * entry.magenta_with_no_layer).toFixed(2)} % is magenta`);
      // Controls: keys move and stay inside the freedom radius, a drag turns the view, R resets.
      await frame(page, base, cams.inside[2]);
      const before = await page.evaluate('window.pomcCamera()');
      await page.focus('canvas');
      await page.keyboard.down('w');
      await new Promise((ok) => setTimeout(ok, 2500));
      await page.keyboard.up('w');
      await page.keyboard.down('e');
      await new Promise((ok) => setTimeout(ok, 1500));
      await page.keyboard.up('e');
      const moved = await page.evaluate('window.pomcCamera()');
      await page.mouse.move(200, 130);
      await page.mouse.down();
      await page.mouse.move(320, 100, { steps: 5 });
      await page.mouse.up();
      const turned = await page.evaluate('window.pomcCamera()');
      // A one-finger drag on a touch screen turns the view too.
      await page.touchscreen.touchStart(240, 135);
      await page.touchscreen.touchMove(300, 135);
      await page.touchscreen.touchMove(360, 140);
      await page.touchscreen.touchEnd();
      const touched = await page.evaluate('window.pomcCamera()');
      await page.keyboard.press('r');
      const reset = await page.evaluate('window.pomcCamera()');
      const dist = (a, b) => Math.hypot(...a.map((x, i) => x - b[i]));
      entry.controls = { moved_m: +dist(before.eye, moved.eye).toFixed(4), distance_after_m: +moved.distance.toFixed(4),
        turned_deg: +(Math.acos(Math.min(1, moved.direction.reduce((a, x, i) => a + x * turned.direction[i], 0))) * 180 / Math.PI).toFixed(2) };
      failIf(entry.controls.moved_m < 0.01, `${name}: keys did not move the eye`);
      failIf(moved.distance > moved.freedomRadius * (1 + 1e-6), `${name}: keys moved the eye outside the freedom radius (${moved.distance} m)`);
      failIf(entry.controls.turned_deg < 5, `${name}: a drag did not turn the view`);
      entry.controls.touch_turned_deg = +(Math.acos(Math.min(1, turned.direction.reduce((a, x, i) => a + x * touched.direction[i], 0))) * 180 / Math.PI).toFixed(2);
      failIf(entry.controls.touch_turned_deg < 5, `${name}: a touch drag did not turn the view`);
      failIf(dist(reset.eye, before.eye) > 1e-9, `${name}: R did not reset the camera`);
      // The first page load of a fresh tab, start to pomcReady.
      const fresh = await browser.newPage();
      await fresh.bringToFront();
      await fresh.setViewport({ width: 960, height: 540 });
      const t1 = Date.now();
      await fresh.goto(`${base}?size=960x540`, { waitUntil: 'load' });
      await fresh.waitForFunction('window.pomcReady === true', { timeout: 120000, polling: 20 });
      entry.first_frame_ms = Date.now() - t1;
      await fresh.close();
      // The same page served by `pomc view --port 0`.
      const live = spawn(POMC, ['view', pano, '--port', '0', '--json'], { stdio: ['ignore', 'pipe', 'inherit'] });
      const url = await new Promise((ok, bad) => {
        let buf = '';
        // The JSON summary (pretty-printed) is complete once it parses.
        live.stdout.on('data', (d) => { buf += d; try { ok(JSON.parse(buf).url); } catch { /* more to come */ } });
        live.on('exit', (c) => bad(new Error(`pomc view exited with ${c}`)));
      });
      await page.bringToFront();
      const served = await frame(page, url, cams.inside[1]);
      const exportedView = await frame(page, base, cams.inside[1]);
      entry.served_matches_export_db = +compare(served.image, exportedView.image).toFixed(2);
      live.kill();
      failIf(entry.served_matches_export_db < 60, `${name}: pomc view --port differs from the exported site`);
      server.close();
      await page.close();
      entry.console = console_;
      // SwiftShader's "GPU stall due to ReadPixels" notes come from reading the frames back.
      entry.console_warnings = [...new Set(warnings)];
      entry.remote_requests = remote;
      failIf(console_.length > 0, `${name}: console: ${console_.join(' | ')}`);
      failIf(remote.length > 0, `${name}: requests outside the site: ${remote.join(' ')}`);
      const ins = entry.views.filter((v) => v.inside).map((v) => v.psnr_db);
      entry.min_psnr_db = Math.min(...ins);
      entry.mean_psnr_db = +(ins.reduce((a, b) => a + b, 0) / ins.length).toFixed(2);
      console.log(`${name}: min ${entry.min_psnr_db} dB, mean ${entry.mean_psnr_db} dB over ${ins.length} views inside the radius; ` +
        `outside: magenta ${entry.views.filter((v) => !v.inside).map((v) => (100 * v.magenta_share).toFixed(3)).join(', ')} %; first frame ${entry.first_frame_ms} ms; site ${entry.site_bytes} bytes`);
      report.panoramas.push(entry);
    }
  } finally {
    await browser.close();
  }
  if (reportFile) fs.writeFileSync(reportFile, JSON.stringify(report, null, 2));
  if (!keep) fs.rmSync(work, { recursive: true, force: true });
  if (report.failures.length) {
    console.error(`viewer: ${report.failures.length} failure(s):\n  ${report.failures.join('\n  ')}`);
    if (check) process.exit(1);
  } else {
    console.log('viewer: all checks passed');
  }
}

main().catch((e) => { console.error(e); process.exit(2); });
