// The page in a real browser: Debian's Chromium, headless, driven by
// playwright-core (which never downloads a browser of its own).
//
//   COROFEM_WEB_URL         the served www/ folder (default http://127.0.0.1:8765/)
//   CHROMIUM                the browser (default /usr/bin/chromium)
//   COROFEM_WEB_SCREENSHOT  where the screenshot goes (default test-output/web-demo.png)
//   COROFEM_WEB_TIMING      where the measured ms/step goes (default test-output/browser-timing.json)
//
// Run: node --test test/browser.test.mjs   (with the folder served; see .ci/web.sh)

import { test, before, after } from 'node:test';
import assert from 'node:assert/strict';
import fs from 'node:fs';
import path from 'node:path';
import { fileURLToPath } from 'node:url';
import { chromium } from 'playwright-core';
import { boxMesh, toMsh2, toMsh41, toTetmesh } from './meshes.mjs';

const here = path.dirname(fileURLToPath(import.meta.url));
const URL = process.env.COROFEM_WEB_URL ?? 'http://127.0.0.1:8765/';
const SHOT = process.env.COROFEM_WEB_SCREENSHOT ?? path.join(here, '../test-output/web-demo.png');
const TIMING = process.env.COROFEM_WEB_TIMING ?? path.join(here, '../test-output/browser-timing.json');

let browser, page;
const pageErrors = [];

before(async () => {
  browser = await chromium.launch({
    executablePath: process.env.CHROMIUM ?? '/usr/bin/chromium',
    headless: true,
    args: ['--no-sandbox', '--disable-gpu', '--disable-quic', '--no-first-run',
      '--disable-background-networking', '--disable-component-update', '--disable-sync'],
  });
  page = await browser.newPage({ viewport: { width: 1280, height: 760 } });
  page.on('pageerror', (e) => pageErrors.push(e.message));
  page.on('console', (m) => { if (m.type() === 'error') pageErrors.push(m.text()); });
  await page.goto(URL);
  await page.waitForFunction(() => window.demo?.ready === true, null, { timeout: 20000 });
});

after(async () => {
  await browser?.close();
});

const stats = () => page.evaluate(() => Array.from(window.demo.state.stats));
// Waits until the simulation has advanced `seconds` of simulated time, so the
// checks do not depend on how fast this machine draws frames.
async function simulate(seconds) {
  const t0 = (await stats())[8];
  await page.waitForFunction((t) => window.demo.state.stats[8] >= t, t0 + seconds, { timeout: 30000 });
}
const frames = () => page.evaluate(() => window.demo.state.frames);
const status = () => page.evaluate(() => ({
  text: document.getElementById('status').textContent,
  error: document.getElementById('status').className === 'error',
}));

// Largest distance any node moved between two position arrays (m).
function maxMove(a, b) {
  let m = 0;
  for (let i = 0; i < a.length; i += 3) m = Math.max(m, Math.hypot(a[i] - b[i], a[i + 1] - b[i + 1], a[i + 2] - b[i + 2]));
  return m;
}

// Page coordinates of the centroid of the camera-facing surface triangle
// nearest `want` (m): a point the pick ray is sure to hit.
async function surfacePoint(want) {
  const pt = await page.evaluate((want) => {
    const p = demo.positions(), tris = demo.surface(), eye = demo.eye();
    let best = null, bd = Infinity;
    for (let t = 0; t < tris.length; t += 3) {
      const v = [0, 1, 2].map((k) => [0, 1, 2].map((j) => p[3 * tris[t + k] + j]));
      const c = [0, 1, 2].map((j) => (v[0][j] + v[1][j] + v[2][j]) / 3);
      const e1 = [0, 1, 2].map((j) => v[1][j] - v[0][j]), e2 = [0, 1, 2].map((j) => v[2][j] - v[0][j]);
      const n = [e1[1] * e2[2] - e1[2] * e2[1], e1[2] * e2[0] - e1[0] * e2[2], e1[0] * e2[1] - e1[1] * e2[0]];
      const facing = n[0] * (eye[0] - c[0]) + n[1] * (eye[1] - c[1]) + n[2] * (eye[2] - c[2]);
      if (facing <= 0) continue;
      const d = Math.hypot(c[0] - want[0], c[1] - want[1], c[2] - want[2]);
      if (d < bd) { bd = d; best = c; }
    }
    return demo.screenOf(best);
  }, want);
  const box = await page.locator('#canvas').boundingBox();
  return [box.x + pt[0], box.y + pt[1]];
}

test('the page loads the module and frames advance at display rate', async () => {
  const f0 = await frames();
  await page.waitForTimeout(1000);
  const f1 = await frames();
  assert.ok(f1 - f0 >= 20, `only ${f1 - f0} frames in 1 s`);
  const s = await stats();
  assert.equal(s[0], 8, 'steps per frame');
  const ms = Number(await page.textContent('#ms-step'));
  assert.ok(ms > 0 && ms < 16, `time per step ${ms} ms`);
  assert.deepEqual(pageErrors, []);
  assert.equal((await status()).error, false);
});

test('the clamped beam sags under gravity', async () => {
  // Reset and read the rest shape in one go, so no frame runs in between.
  const rest = await page.evaluate(() => {
    demo.exports.cf_reset();
    demo.state.stats.fill(0);
    return demo.positions();
  });
  await simulate(0.4); // about half the beam's first period: near the lowest point
  const now = await page.evaluate(() => demo.positions());
  // The free end (largest x) goes down.
  let tip = 0;
  for (let i = 0; i < rest.length; i += 3) if (rest[i] > rest[3 * tip]) tip = i / 3;
  const drop = rest[3 * tip + 2] - now[3 * tip + 2];
  assert.ok(drop > 0.05, `the free end dropped ${drop} m`);
  assert.ok(now.every(Number.isFinite));
});

test('dragging the beam pulls with a force and deforms it', async () => {
  await simulate(1.0); // let the sag settle a little
  const before = await page.evaluate(() => demo.positions());
  const [sx, sy] = await surfacePoint([0.45, -0.1, 0.75]);
  await page.mouse.move(sx, sy);
  await page.mouse.down();
  await page.mouse.move(sx + 20, sy - 200, { steps: 30 });
  await simulate(0.6);
  const grabbed = await page.evaluate(() => demo.exports.cf_grabbed_count());
  assert.ok(grabbed > 0, 'nothing grabbed');
  const force = Number(await page.textContent('#force'));
  assert.ok(force > 1, `tool force readout ${force} N`);
  const s = await stats();
  assert.ok(Math.abs(Math.hypot(s[3], s[4], s[5]) - force) < 0.01 * force + 0.01);
  const during = await page.evaluate(() => demo.positions());
  const moved = maxMove(before, during);
  assert.ok(moved > 0.1, `the body moved only ${moved} m`);
  fs.mkdirSync(path.dirname(SHOT), { recursive: true });
  await page.screenshot({ path: SHOT });
  await page.mouse.up();
  await page.waitForTimeout(200);
  assert.equal(Number(await page.textContent('#force')), 0, 'released: no force');
  assert.deepEqual(pageErrors, []);
});

test('every method runs; with a free beam QR keeps the spin (with either preconditioner) and QR rest-B turns it', async () => {
  await page.selectOption('#support', '2'); // free: gravity goes off
  assert.equal(await page.isChecked('#gravity'), false);
  await page.fill('#young', '3.7'); // 5e3 Pa: a soft beam wobbles a lot
  const spinDrift = {};
  for (const [value, name, pre] of [['1', 'polar', '0'], ['2', 'linear', '0'], ['0', 'qr two-level', '2'],
    ['0', 'qr', '0'], ['3', 'qr-rest-b', '0']]) {
    await page.selectOption('#method', value);
    await page.selectOption('#preconditioner', pre);
    // The same pull for every method, through the module's exports in one
    // synchronous call (no frame runs in between, so it does not depend on
    // this machine's speed): grab one end, pull it for 0.24 s, let go, then
    // 0.002 s and 2 s later read the spin about the centre of mass.
    const r = await page.evaluate(() => {
      const x = demo.exports;
      const spin = () => new Float32Array(x.memory.buffer, x.cf_stats_ptr(), 12)[9];
      x.cf_reset();
      const t = x.cf_pick(0.3, -3, 0.62, 0, 1, 0);
      if (!(t > 0)) return { error: 'the ray missed the beam' };
      const hit = [0.3, -3 + t, 0.62];
      if (x.cf_grab(...hit) === 0) return { error: 'nothing grabbed' };
      for (let j = 0; j < 15; j++) {
        x.cf_set_target(hit[0] + 0.01 * j, hit[1] - 0.01 * j, hit[2] + 0.01 * j);
        x.cf_step(8);
      }
      x.cf_release();
      x.cf_step(1);
      const l0 = spin();
      let steps = 0;
      for (let k = 0; k < 10; k++) steps += x.cf_step(100);
      const s = Array.from(new Float32Array(x.memory.buffer, x.cf_stats_ptr(), 12));
      return { l0, l1: spin(), steps, finite: demo.positions().every(Number.isFinite), diverged: s[7] };
    });
    assert.equal(r.error, undefined, `${name}: ${r.error}`);
    assert.equal(r.steps, 1000, `${name}: refused steps`);
    assert.ok(r.finite && r.l0 > 0.1, `${name}: ${JSON.stringify(r)}`);
    spinDrift[name] = Math.abs(r.l1 - r.l0) / r.l0;
  }
  console.log('relative spin drift in the 2 s after release:', spinDrift);
  assert.ok(spinDrift.qr < 1e-4, `QR changed the spin by ${spinDrift.qr}`);
  // The two-level preconditioner keeps a free body's momentum too.
  assert.ok(spinDrift['qr two-level'] < 1e-4, `QR with two-level changed the spin by ${spinDrift['qr two-level']}`);
  assert.ok(spinDrift['qr-rest-b'] > 0.05, `QR rest-B changed the spin by only ${spinDrift['qr-rest-b']}`);
  // The page still runs and draws with the last method.
  await simulate(0.2);
  assert.deepEqual(pageErrors, []);
  // Back to the defaults.
  await page.fill('#young', '6.3');
  await page.selectOption('#method', '4');
  await page.selectOption('#preconditioner', '2');
  await page.check('#gravity');
  await page.selectOption('#support', '1');
});

test('mesh files load: Gmsh 4.1, Gmsh 2.2, tetmesh; a broken one is reported', async () => {
  const mesh = boxMesh([0.3, 0.2, 0.2], [6, 4, 4]);
  const load = async (name, text) => {
    await page.setInputFiles('#file', { name, mimeType: 'text/plain', buffer: Buffer.from(text) });
    await page.waitForFunction((name) => document.getElementById('status').textContent.startsWith(name), name);
    return status();
  };
  for (const [name, text] of [['box41.msh', toMsh41(mesh)], ['box22.msh', toMsh2(mesh)], ['box.tetmesh', toTetmesh(mesh)]]) {
    const st = await load(name, text);
    assert.equal(st.error, false, st.text);
    assert.match(st.text, new RegExp(`^${name}: ${mesh.tets.length} tetrahedra, ${mesh.nodes.length} nodes`));
    assert.equal(await page.evaluate(() => demo.exports.cf_tet_count()), mesh.tets.length);
    await simulate(0.1); // it runs
  }
  // The repository's own example file: one equilateral tetrahedron.
  const tet = fs.readFileSync(path.join(here, '../../scenes/equilateral_tet.tetmesh'), 'utf8');
  const st = await load('equilateral_tet.tetmesh', tet);
  assert.equal(st.error, false, st.text);
  assert.equal(await page.evaluate(() => demo.exports.cf_tet_count()), 1);
  // Broken files: the error names the line; the body stays.
  const broken = toMsh41(mesh).replace(/\$EndNodes/, '1 2 3\n$EndNodes');
  const bad = await load('broken.msh', broken);
  assert.equal(bad.error, true);
  assert.match(bad.text, /^broken\.msh: line \d+: /);
  const flat = await load('flat.tetmesh', 'tetmesh 1\n4 1\n0 0 0\n1 0 0\n2 0 0\n3 0 0\n0 1 2 3\n');
  assert.equal(flat.error, true);
  assert.match(flat.text, /zero rest volume|flat/);
  assert.equal(await page.evaluate(() => demo.exports.cf_tet_count()), 1);
  assert.deepEqual(pageErrors, []);
});

test('time per step in the browser (the beam, default settings)', async () => {
  await page.selectOption('#body', '1');
  await page.click('#pause'); // nothing else runs while we time
  const ms = await page.evaluate(() => demo.bench(500, 50));
  await page.click('#pause');
  const info = {
    scene: 'beam 1920 tets, clamped, QR-invertible, two-level, 4 CG iterations (warm), dt 2 ms, gravity',
    ms_per_step: ms,
    user_agent: await page.evaluate(() => navigator.userAgent),
  };
  console.log('browser:', JSON.stringify(info));
  fs.mkdirSync(path.dirname(TIMING), { recursive: true });
  fs.writeFileSync(TIMING, JSON.stringify(info, null, 2) + '\n');
  assert.ok(ms > 0 && ms < 16);
});
