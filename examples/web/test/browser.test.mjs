// The page in a real browser: Debian's Chromium, headless, driven by
// playwright-core (which never downloads a browser of its own).
//
//   COROFEM_WEB_URL         the served www/ folder (default http://127.0.0.1:8765/)
//   CHROMIUM                the browser (default /usr/bin/chromium)
//   COROFEM_WEB_SCREENSHOT  where the screenshot goes (default test-output/web-demo.png); the
//                           one of the blob's embedded surface goes beside it, as web-surface.png,
//                           and the one of the probe pressed into the blob as web-probe.png
//   COROFEM_WEB_TIMING      where the measured ms/step goes (default test-output/browser-timing.json)
//
// Run: node --test test/browser.test.mjs   (with the folder served; see .ci/web.sh)

import { test, before, after } from 'node:test';
import assert from 'node:assert/strict';
import fs from 'node:fs';
import path from 'node:path';
import { fileURLToPath } from 'node:url';
import { chromium } from 'playwright-core';
import { boxMesh, sphereObj, toMsh2, toMsh41, toTetmesh, toStl } from './meshes.mjs';

const here = path.dirname(fileURLToPath(import.meta.url));
const URL = process.env.COROFEM_WEB_URL ?? 'http://127.0.0.1:8765/';
const SHOT = process.env.COROFEM_WEB_SCREENSHOT ?? path.join(here, '../test-output/web-demo.png');
const SHOT_SURFACE = path.join(path.dirname(SHOT), 'web-surface.png');
const SHOT_PROBE = path.join(path.dirname(SHOT), 'web-probe.png');
const TIMING = process.env.COROFEM_WEB_TIMING ?? path.join(here, '../test-output/browser-timing.json');
const LAUNCH = {
  executablePath: process.env.CHROMIUM ?? '/usr/bin/chromium',
  headless: true,
  args: ['--no-sandbox', '--disable-gpu', '--disable-quic', '--no-first-run',
    '--disable-background-networking', '--disable-component-update', '--disable-sync'],
};

let browser, page;
const pageErrors = [];

before(async () => {
  browser = await chromium.launch(LAUNCH);
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

// Page coordinates of the centroid of the camera-facing boundary triangle
// nearest `want` (m): a point the pick ray is sure to hit.
async function surfacePoint(want, pg = page) {
  const pt = await pg.evaluate((want) => {
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
  const box = await pg.locator('#canvas').boundingBox();
  return [box.x + pt[0], box.y + pt[1]];
}

// Draws a frame now and reads the canvas: how many pixels show the body
// (its blue: blue well above red, as the background and the ground never
// are), how many are near white (edges), and how rough the shading is: of the
// horizontally neighbouring body pixels, the share whose brightness jumps by
// more than 3 levels (the edges of flat-shaded facets; a smooth surface
// varies by a level or two from pixel to pixel). What was drawn, too.
const look = (pg = page) => pg.evaluate(() => {
  demo.draw();
  const c = document.getElementById('canvas');
  const { data, width, height } = c.getContext('2d').getImageData(0, 0, c.width, c.height);
  const body = (i) => data[i + 2] - data[i] > 40 && data[i + 2] > 60;
  let pixels = 0, bright = 0, pairs = 0, jumps = 0;
  for (let y = 0; y < height; y++) {
    for (let x = 0; x < width; x++) {
      const i = 4 * (y * width + x);
      if (data[i] > 170 && data[i + 1] > 170 && data[i + 2] > 170) bright++;
      if (!body(i)) continue;
      pixels++;
      if (x + 1 < width && body(i + 4)) {
        pairs++;
        const l = (j) => data[j] + data[j + 1] + data[j + 2];
        if (Math.abs(l(i) - l(i + 4)) > 9) jumps++;
      }
    }
  }
  return { pixels, bright, rough: jumps / Math.max(pairs, 1), drawn: demo.state.drawn };
});
const surfaceStatus = (pg = page) => pg.evaluate(() => ({
  text: document.getElementById('surface-status').textContent,
  error: document.getElementById('surface-status').className === 'error',
}));
const embedded = (pg = page) => pg.evaluate(() => ({
  vertices: demo.exports.cf_embedded_vertex_count(),
  triangles: demo.exports.cf_embedded_triangle_count(),
}));
async function loadSurface(name, text, pg = page) {
  await pg.setInputFiles('#surface-file', { name, mimeType: 'text/plain', buffer: Buffer.from(text) });
  await pg.waitForFunction((name) => document.getElementById('surface-status').textContent.startsWith(name), name);
  return surfaceStatus(pg);
}

test('the page loads the module and frames keep advancing', async (t) => {
  const f0 = await frames();
  await page.waitForTimeout(1000);
  const f1 = await frames();
  const ms = Number(await page.textContent('#ms-step'));
  // How many frames a second, and how long a step takes, are the machine's
  // (docs/web.md measures them): reported, not asserted. What must hold is
  // that the animation loop runs on its own and times its steps.
  t.diagnostic(`${f1 - f0} frames in 1 s, ${ms} ms per step`);
  assert.ok(f1 - f0 >= 2, `only ${f1 - f0} frames in 1 s`);
  const s = await stats();
  assert.equal(s[0], 8, 'steps per frame');
  assert.ok(Number.isFinite(ms) && ms > 0, `time per step ${ms} ms`);
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
  await page.mouse.up();
  await page.waitForTimeout(200);
  assert.equal(Number(await page.textContent('#force')), 0, 'released: no force');
  assert.deepEqual(pageErrors, []);
});

// The probe test's checks while the mouse presses the sphere at (sx, sy).
async function pressed(sx, sy, before) {
  await simulate(0.5);
  const r = await page.evaluate(() => ({
    probe: demo.probe(), press: demo.press(), stats: Array.from(demo.state.stats),
    readout: Number(document.getElementById('probe-force').textContent),
    nodes: Number(document.getElementById('probe-contacts').textContent),
    drawn: demo.state.drawn, positions: demo.positions(),
  }));
  assert.ok(r.probe && r.press, JSON.stringify(r.press));
  const { force, contacts, radius } = r.probe;
  const mag = Math.hypot(...force);
  const along = force.reduce((a, f, k) => a + f * r.press.dir[k], 0);
  console.log(`probe (radius ${radius.toFixed(3)} m, pressed ${r.press.depth.toFixed(3)} m): force [${force.map((v) => v.toFixed(2))}] N, |F| ${mag.toFixed(2)} N, F·press ${along.toFixed(2)} N, ${contacts} contacts`);
  assert.ok(Math.abs(radius - 0.06) < 1e-6);
  assert.ok(Math.abs(r.press.depth - 0.03) < 1e-6, `depth ${r.press.depth}`);
  assert.ok(contacts > 0, 'no node touches the probe');
  assert.ok(mag > 1, `probe force ${mag} N`);
  // The body pushes the probe back out, against the press (aslant: along
  // the surface's normal, the press along the view).
  assert.ok(along < -0.1 * mag, `force · press direction = ${along} N of ${mag} N`);
  // The HUD shows it, and the statistics agree with the probe's own.
  assert.ok(Math.abs(r.readout - mag) < 0.01 * mag + 0.01, `${r.readout} vs ${mag}`);
  assert.equal(r.nodes, contacts);
  assert.deepEqual(r.stats.slice(12, 15), force);
  assert.equal(r.stats[15], 0, 'the probe was made outside the body');
  assert.ok([...r.stats, ...force, ...r.probe.centre, ...r.positions].every(Number.isFinite), 'a NaN');
  assert.equal(r.drawn.sphere, true);
  // Dented and pushed down: the beam moved, and no node is inside the sphere.
  const moved = maxMove(before, r.positions);
  assert.ok(moved > 0.01, `the body moved only ${moved} m`);
  let inside = Infinity;
  for (let i = 0; i < r.positions.length; i += 3) {
    inside = Math.min(inside, Math.hypot(...[0, 1, 2].map((k) => r.positions[i + k] - r.probe.centre[k])) - radius);
  }
  console.log(`probe: the body moved up to ${moved.toFixed(3)} m; the nearest node is ${(1000 * inside).toFixed(2)} mm from the sphere`);
  assert.ok(inside > -1e-3 * radius, `a node ${inside} m inside the sphere`);
  // Dragged, the sphere slides over the beam, still pressing.
  await page.mouse.move(sx - 60, sy + 10, { steps: 10 });
  await simulate(0.3);
  const slid = await page.evaluate(() => demo.probe());
  assert.ok(Math.hypot(...slid.centre.map((v, k) => v - r.probe.centre[k])) > 0.02, 'the sphere did not slide');
  assert.ok(slid.contacts > 0 && slid.force.every(Number.isFinite));
  // Wheel forward while pressing: deeper.
  await page.mouse.wheel(0, -200);
  assert.equal(await page.inputValue('#probe-depth'), '3.5');
}

test('probe mode: the sphere pressed into the beam is pushed back out and dents it', async () => {
  await page.check('#mode-probe');
  assert.match(await page.textContent('#hint'), /^press the body to push the sphere in/);
  assert.equal(await page.isVisible('#probe-hud'), true);
  // At rest, without gravity: the beam released by the last test swings by
  // tens of centimetres, and so would one sagging under gravity. Where it
  // is when the sphere lands and slides would then depend on how fast this
  // machine draws frames.
  await page.uncheck('#gravity');
  await page.evaluate(() => demo.exports.cf_reset());
  await simulate(0.1);
  const before = await page.evaluate(() => demo.positions());
  // Aiming: the sphere rests on the surface under the cursor, translucent,
  // and nothing touches the body yet. Near the clamp.
  const [sx, sy] = await surfacePoint([-0.3, 0, 0.75]);
  await page.mouse.move(sx, sy);
  await page.waitForFunction(() => demo.state.ghost !== null);
  assert.equal(await page.evaluate(() => demo.probe()), null);
  // Pressed: 3 cm (the default press depth) along the cursor's ray.
  await page.mouse.down();
  try {
    await pressed(sx, sy, before);
  } finally {
    await page.mouse.up();
  }
  await page.waitForTimeout(200);
  assert.equal(await page.evaluate(() => demo.probe()), null, 'released: no probe');
  assert.equal(Number(await page.textContent('#probe-force')), 0, 'released: no force');
  await page.fill('#probe-depth', '3');

  // Through the module, a sphere made inside the beam: the core refuses its
  // first step, the page moves it out against its press direction and says
  // so; bad input is refused with a return code and changes nothing.
  const odd = await page.evaluate(() => {
    const x = demo.exports;
    const p = demo.positions();
    let top = 0; // the highest node
    for (let i = 0; i < p.length; i += 3) if (p[i + 2] > p[top + 2]) top = i;
    const bad = [x.cf_probe_set(NaN, 0, 0, 0.06, 0, 0, -1), x.cf_probe_set(0, 0, 0.6, -1, 0, 0, -1),
      x.cf_probe_set(0, 0, 0.6, 0.06, 0, 0, 0), x.cf_probe_friction(-0.5), x.cf_probe_cast(NaN, 0, 0, 0, 0, -1, 0.06)];
    const none = demo.probe();
    const set = x.cf_probe_set(p[top], p[top + 1], p[top + 2] - 0.02, 0.06, 0, 0, -1);
    return { bad, none, set };
  });
  assert.deepEqual(odd.bad, [1, 1, 1, 1, -1]);
  assert.equal(odd.none, null);
  assert.equal(odd.set, 0);
  await page.waitForFunction(() => /moved out/.test(document.getElementById('probe-status').textContent));
  await simulate(0.1);
  const held = await page.evaluate(() => ({ probe: demo.probe(), finite: demo.positions().every(Number.isFinite) }));
  assert.ok(held.finite && held.probe.force.every(Number.isFinite), JSON.stringify(held));
  await page.evaluate(() => demo.exports.cf_probe_clear());
  await page.check('#mode-pull');
  await page.check('#gravity');
  assert.equal(await page.isVisible('#probe-hud'), false);
  assert.equal((await status()).error, false);
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

test('the blob shows its smooth embedded surface; the toggle shows the tetrahedra', async () => {
  await page.selectOption('#body', '2');
  await simulate(0.2);
  assert.deepEqual(await embedded(), { vertices: 3458, triangles: 6912 });
  assert.equal(await page.isChecked('#show-surface'), true);
  assert.match((await surfaceStatus()).text, /^built-in smooth surface \(3458 vertices\)/);
  assert.match(await page.textContent('#counts'), /surface 3458 vertices · 6912 triangles/);
  const smooth = await look();
  assert.deepEqual(smooth.drawn, { surfaceTriangles: 6912, tetTriangles: 0, edges: 0 });
  assert.ok(smooth.pixels > 20000, `the surface covers only ${smooth.pixels} pixels`);
  await page.uncheck('#show-surface');
  const tets = await look();
  assert.deepEqual(tets.drawn, { surfaceTriangles: 0, tetTriangles: 768, edges: 0 });
  // The same body, about as large on screen, but shaded in flat facets.
  assert.ok(Math.abs(tets.pixels - smooth.pixels) < 0.05 * smooth.pixels, `${tets.pixels} vs ${smooth.pixels}`);
  console.log('shading roughness, smooth surface vs tetrahedra:', smooth.rough.toFixed(4), tets.rough.toFixed(4));
  assert.ok(smooth.rough < 0.01, `the embedded surface is not smooth: ${smooth.rough}`);
  assert.ok(tets.rough > 3 * smooth.rough, `${tets.rough} vs ${smooth.rough}`);
  // The boundary's edges over the surface: 1152 edges, drawn bright.
  await page.check('#show-surface');
  await page.check('#show-edges');
  const wire = await look();
  assert.deepEqual(wire.drawn, { surfaceTriangles: 6912, tetTriangles: 0, edges: 1152 });
  console.log('near-white pixels without and with the edges:', smooth.bright, wire.bright);
  assert.ok(wire.bright > smooth.bright + 2000, `edges: ${wire.bright} bright pixels against ${smooth.bright}`);
  await page.uncheck('#show-edges');
  // The surface moves with the body: pulled, its vertices follow.
  const rest = await page.evaluate(() => Array.from(new Float32Array(demo.exports.memory.buffer,
    demo.exports.cf_embedded_positions_ptr(), 3 * 3458)));
  const [sx, sy] = await surfacePoint([0.1, -0.1, 0.3]);
  await page.mouse.move(sx, sy);
  await page.mouse.down();
  await page.mouse.move(sx + 10, sy - 120, { steps: 20 });
  await simulate(0.3);
  const pulled = await page.evaluate(() => Array.from(new Float32Array(demo.exports.memory.buffer,
    demo.exports.cf_embedded_positions_ptr(), 3 * 3458)));
  await page.mouse.up();
  assert.ok(maxMove(rest, pulled) > 0.05, `the surface moved only ${maxMove(rest, pulled)} m`);
  assert.ok(pulled.every(Number.isFinite));
  assert.deepEqual(pageErrors, []);
});

test('a surface file loads onto the blob; bad ones are reported and change nothing', async () => {
  await page.selectOption('#body', '2');
  const blob = await look();
  // A sphere of radius 0.12 m inside the blob (radii 0.22, 0.19, 0.16 m),
  // in the body's own coordinates (the blob is centred on the origin).
  const sphere = sphereObj([0, 0, 0], 0.12, 3);
  const st = await loadSurface('ball.obj', sphere.text);
  assert.equal(st.error, false, st.text);
  assert.equal(st.text, 'ball.obj: 258 vertices, 512 triangles');
  assert.deepEqual(await embedded(), { vertices: sphere.vertices, triangles: sphere.triangles });
  const ball = await look();
  assert.deepEqual(ball.drawn, { surfaceTriangles: 512, tetTriangles: 0, edges: 0 });
  // Smaller than the blob on screen: about (0.12² π) against the blob's outline.
  const ratio = ball.pixels / blob.pixels;
  assert.ok(ratio > 0.3 && ratio < 0.75, `sphere ${ball.pixels} px, blob ${blob.pixels} px`);
  await simulate(0.1);

  // Errors name the problem under the picker; the surface stays.
  const far = sphereObj([5, 0, 0], 0.1, 1);
  const flat = 'v 0 0 0\nv 0.05 0 0\nv 0.1 0 0\nv 0 0.05 0\nf 1 2 4\nf 1 2 3\n';
  let big = '';
  for (let i = 0; i <= 200000; i++) big += `v ${i % 7} 0 0\n`;
  big += 'f 1 2 3\n';
  for (const [name, text, want] of [
    ['far.obj', far.text, /^far\.obj: vertex 1 lies farther than 0\.0\d+ from every tetrahedron .*units and place\?$/],
    ['flat.obj', flat, /^flat\.obj: triangle 2 is degenerate: a repeated vertex or collinear corners$/],
    ['broken.obj', 'v 0 0 0\nv 1 x 0\nv 0 1 0\nf 1 2 3\n', /^broken\.obj: OBJ: /],
    ['empty.stl', 'solid x\nendsolid x\n', /^empty\.stl: expected at least one triangle, found none$/],
    ['ball.ply', sphere.text, /^ball\.ply: unknown surface file extension "\.ply" \(expected \.obj or \.stl\)$/],
    ['big.obj', big, /^big\.obj: 200001 vertices: the page takes at most 200000$/],
  ]) {
    const bad = await loadSurface(name, text);
    assert.equal(bad.error, true, `${name}: ${bad.text}`);
    assert.match(bad.text, want);
    assert.deepEqual(await embedded(), { vertices: 258, triangles: 512 }, `${name} changed the surface`);
  }
  assert.equal((await status()).error, false, 'the body has no error');

  // Held otherwise, the same body keeps its surface file.
  await page.selectOption('#support', '2');
  assert.deepEqual(await embedded(), { vertices: 258, triangles: 512 });
  assert.match((await surfaceStatus()).text, /^ball\.obj: 258 vertices/);
  await page.check('#gravity');
  await page.selectOption('#support', '0');
  assert.deepEqual(pageErrors, []);
});

test('a surface file follows its mesh file when the page scales it; a new mesh drops it', async () => {
  // A box in millimetres (scaled to 0.4 m) and a smaller box inside it, in
  // the same millimetres, as ASCII STL. (The body settles under gravity
  // meanwhile: sizes to 1%.)
  const mesh = boxMesh([300, 300, 300], [4, 4, 4]);
  await page.setInputFiles('#file', { name: 'mm.tetmesh', mimeType: 'text/plain', buffer: Buffer.from(toTetmesh(mesh)) });
  await page.waitForFunction(() => document.getElementById('status').textContent.startsWith('mm.tetmesh'));
  assert.match((await status()).text, /scaled ×0\.00133 to 0\.4 m/);
  assert.deepEqual(await embedded(), { vertices: 0, triangles: 0 });
  assert.equal(await page.isDisabled('#show-surface'), true);
  assert.match((await surfaceStatus()).text, /^none: the tetrahedra's boundary is drawn/);
  const st = await loadSurface('inner.stl', toStl([20, 20, 0], [280, 280, 260]));
  assert.equal(st.error, false, st.text);
  assert.deepEqual(await embedded(), { vertices: 8, triangles: 12 });
  const size = await page.evaluate(() => {
    const p = new Float32Array(demo.exports.memory.buffer, demo.exports.cf_embedded_positions_ptr(), 24);
    const n = demo.positions();
    const ext = (a) => [0, 1, 2].map((k) => {
      const c = a.filter((_, i) => i % 3 === k);
      return [Math.min(...c), Math.max(...c)];
    });
    return { surface: ext(Array.from(p)), body: ext(n) };
  });
  const s = 0.4 / 300;
  for (let k = 0; k < 3; k++) {
    const [lo, hi] = size.surface[k], [blo, bhi] = size.body[k];
    assert.ok(Math.abs(hi - lo - s * 260) < 3e-3, `axis ${k}: ${lo}..${hi}`);
    assert.ok(Math.abs(lo - (blo + s * (k < 2 ? 20 : 0))) < 3e-3, `axis ${k}: ${lo} vs body ${blo}`);
    assert.ok(bhi > hi);
  }
  assert.equal((await look()).drawn.surfaceTriangles, 12);
  // A new mesh: the surface of the old one goes.
  const other = boxMesh([0.3, 0.2, 0.2], [6, 4, 4]);
  await page.setInputFiles('#file', { name: 'box.msh', mimeType: 'text/plain', buffer: Buffer.from(toMsh41(other)) });
  await page.waitForFunction(() => document.getElementById('status').textContent.startsWith('box.msh'));
  assert.deepEqual(await embedded(), { vertices: 0, triangles: 0 });
  assert.deepEqual((await look()).drawn, { surfaceTriangles: 0, tetTriangles: 2 * 2 * (6 * 4 + 4 * 4 + 6 * 4), edges: 0 });
  assert.deepEqual(pageErrors, []);
});

test('moving and shading the embedded surface costs little next to a step (the blob)', async () => {
  await page.selectOption('#body', '2');
  await page.click('#pause');
  const r = await page.evaluate(() => ({ step: demo.bench(300, 50), surface: demo.benchSurface(400, 50) }));
  await page.click('#pause');
  console.log(`blob: ${r.step.toFixed(3)} ms/step, ${(1000 * r.surface).toFixed(1)} µs per update_surface + vertex_normals (3458 vertices, 6912 triangles), ${(r.surface / r.step).toFixed(3)} steps`);
  fs.mkdirSync(path.dirname(TIMING), { recursive: true });
  fs.writeFileSync(TIMING.replace(/\.json$/, '-surface.json'), JSON.stringify({
    scene: 'blob 2560 tets on the ground, defaults; its surface 3458 vertices, 6912 triangles',
    ms_per_step: r.step,
    ms_per_surface_update: r.surface,
  }, null, 2) + '\n');
  assert.ok(r.surface > 0 && r.surface < 0.25 * r.step, JSON.stringify(r));
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

test('screenshots with multisampling: the beam pulled, the blob pulled with the edges over its surface', async () => {
  const pg = await browser.newPage({ viewport: { width: 1280, height: 760 } });
  pg.on('pageerror', (e) => pageErrors.push(e.message));
  await pg.goto(`${URL}?antialias=on`);
  await pg.waitForFunction(() => window.demo?.ready === true, null, { timeout: 20000 });
  assert.match(await pg.textContent('#renderer'), /^WebGL 2$/);
  const sim = async (seconds) => {
    const t0 = await pg.evaluate(() => window.demo.state.stats[8]);
    await pg.waitForFunction((t) => window.demo.state.stats[8] >= t, t0 + seconds, { timeout: 30000 });
  };
  const pull = async (want, dx, dy) => {
    const [sx, sy] = await surfacePoint(want, pg);
    await pg.mouse.move(sx, sy);
    await pg.mouse.down();
    await pg.mouse.move(sx + dx, sy + dy, { steps: 30 });
    await sim(0.6);
    assert.ok(await pg.evaluate(() => demo.exports.cf_grabbed_count()) > 0, 'nothing grabbed');
  };
  fs.mkdirSync(path.dirname(SHOT), { recursive: true });
  await sim(1.0);
  await pull([0.45, -0.1, 0.75], 20, -200);
  await pg.screenshot({ path: SHOT });
  await pg.mouse.up();
  // The blob, softer (1e5 Pa), pulled up and sideways from its top.
  await pg.selectOption('#body', '2');
  await pg.fill('#young', '5');
  await pg.check('#show-edges');
  const box = await pg.locator('#canvas').boundingBox();
  await pg.mouse.move(box.x + 40, box.y + box.height - 40);
  await pg.mouse.wheel(0, -350); // closer
  await sim(0.5);
  await pull([0.05, -0.1, 0.3], -50, -70);
  const l = await look(pg);
  assert.equal(l.drawn.surfaceTriangles, 6912);
  await pg.screenshot({ path: SHOT_SURFACE });
  await pg.mouse.up();
  await pg.close();
  assert.deepEqual(pageErrors, []);
});

test('screenshot with multisampling: the probe pressed into the soft blob', async () => {
  const pg = await browser.newPage({ viewport: { width: 1280, height: 760 } });
  pg.on('pageerror', (e) => pageErrors.push(e.message));
  await pg.goto(`${URL}?antialias=on`);
  await pg.waitForFunction(() => window.demo?.ready === true, null, { timeout: 20000 });
  const sim = async (seconds) => {
    const t0 = await pg.evaluate(() => window.demo.state.stats[8]);
    await pg.waitForFunction((t) => window.demo.state.stats[8] >= t, t0 + seconds, { timeout: 30000 });
  };
  // The blob, softer (1e5 Pa), a 6 cm sphere pressed 10 cm along the view into its top;
  // friction on the ground keeps the blob from sliding away from the press.
  await pg.selectOption('#body', '2');
  await pg.fill('#young', '5');
  await pg.fill('#ground-mu', '0.8');
  await pg.check('#mode-probe');
  await pg.fill('#probe-depth', '10');
  const box = await pg.locator('#canvas').boundingBox();
  await pg.mouse.move(box.x + 40, box.y + box.height - 40);
  await pg.mouse.wheel(0, -350); // closer
  await sim(0.5);
  const [sx, sy] = await surfacePoint([0, 0, 0.32], pg);
  await pg.mouse.move(sx, sy);
  await pg.mouse.down();
  await sim(0.6);
  const p = await pg.evaluate(() => demo.probe());
  assert.ok(p && p.contacts > 0 && Math.hypot(...p.force) > 1, JSON.stringify(p));
  console.log(`screenshot: the blob at 1e5 Pa, probe pressed 10 cm: |F| ${Math.hypot(...p.force).toFixed(2)} N, ${p.contacts} contacts`);
  // Seen lower, from the side, the dent shows around the sphere.
  await pg.evaluate(() => { demo.cam.pitch = 0.22; demo.cam.yaw -= 0.35; });
  await sim(0.1);
  fs.mkdirSync(path.dirname(SHOT_PROBE), { recursive: true });
  await pg.screenshot({ path: SHOT_PROBE });
  await pg.mouse.up();
  await pg.close();
  assert.deepEqual(pageErrors, []);
});

test('without WebGL 2 the page draws with Canvas 2D: the embedded surface and the edges too', async () => {
  const pg = await browser.newPage({ viewport: { width: 1280, height: 760 } });
  pg.on('pageerror', (e) => pageErrors.push(e.message));
  await pg.goto(`${URL}?renderer=2d`);
  await pg.waitForFunction(() => window.demo?.ready === true, null, { timeout: 20000 });
  assert.equal(await pg.evaluate(() => demo.renderer), '2d');
  // Asked for by the address, Canvas 2D needs no notice.
  assert.equal(await pg.isHidden('#notice'), true);
  await pg.selectOption('#body', '2');
  await pg.check('#show-edges');
  const l = await look(pg);
  assert.equal(l.drawn.surfaceTriangles, 6912);
  assert.ok(l.drawn.edges > 0);
  assert.ok(l.pixels > 20000 && l.bright > 1000, JSON.stringify(l));
  await pg.close();
  assert.deepEqual(pageErrors, []);
});

// A page whose module cannot load says why, over the view, instead of
// leaving the canvas empty.
async function brokenModule(fulfil) {
  const pg = await browser.newPage({ viewport: { width: 1280, height: 760 } });
  const errors = [];
  pg.on('pageerror', (e) => errors.push(e.message));
  await pg.route('**/corofem_web.wasm', (route) => route.fulfill(fulfil));
  await pg.goto(URL);
  await pg.waitForSelector('#notice:not([hidden])', { timeout: 20000 });
  const shown = await pg.evaluate(() => ({
    text: document.getElementById('notice').textContent,
    kind: document.getElementById('notice').className,
    demo: window.demo,
  }));
  await pg.close();
  return { ...shown, errors };
}

test('a missing module is explained on the page', async () => {
  const s = await brokenModule({ status: 404, contentType: 'text/plain', body: 'not found' });
  assert.equal(s.kind, 'error');
  assert.match(s.text, /The simulation module is missing/);
  assert.match(s.text, /corofem_web\.wasm: HTTP 404/);
  assert.match(s.text, /bash examples\/web\/build\.sh/);
  assert.deepEqual(s.demo, { ready: false, failed: 'The simulation module is missing' });
  // The page stops there, with one error naming why.
  assert.deepEqual(s.errors, ['corofem web demo: The simulation module is missing']);
});

test('an invalid module is explained on the page', async () => {
  const s = await brokenModule({ status: 200, contentType: 'application/wasm', body: 'not wasm at all' });
  assert.equal(s.kind, 'error');
  assert.match(s.text, /The simulation module is not valid WebAssembly/);
  assert.match(s.text, /corofem_web\.wasm \(15 bytes\) did not compile/);
  assert.equal(s.demo.ready, false);
});

test('without WebGL 2 the page says it draws with Canvas 2D, and does', async () => {
  const pg = await browser.newPage({ viewport: { width: 1280, height: 760 } });
  const errors = [];
  pg.on('pageerror', (e) => errors.push(e.message));
  // A browser without WebGL 2: no context of that kind for any canvas.
  await pg.addInitScript(() => {
    const get = HTMLCanvasElement.prototype.getContext;
    HTMLCanvasElement.prototype.getContext = function (kind, ...rest) {
      return kind === 'webgl2' ? null : get.call(this, kind, ...rest);
    };
  });
  await pg.goto(URL);
  await pg.waitForFunction(() => window.demo?.ready === true, null, { timeout: 20000 });
  assert.equal(await pg.evaluate(() => demo.renderer), '2d');
  const n = await pg.evaluate(() => ({
    hidden: document.getElementById('notice').hidden,
    kind: document.getElementById('notice').className,
    text: document.getElementById('notice').textContent,
  }));
  assert.equal(n.hidden, false);
  assert.equal(n.kind, 'warn');
  assert.match(n.text, /WebGL 2 is not available/);
  assert.match(n.text, /draws with Canvas 2D instead/);
  const l = await look(pg);
  assert.ok(l.pixels > 20000, JSON.stringify(l));
  await pg.close();
  assert.deepEqual(errors, []);
});
