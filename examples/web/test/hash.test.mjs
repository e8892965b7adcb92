// The wasm module headless in Node: it loads with no imports, its API builds
// and steps a body, and its scripted scene (hash_script, defined once in
// test-scenes/src/web.rs) gives bit for bit the state hash the host computes:
// the value stored in test-scenes/src/web_hash_script.txt, which
// host-tests/tests/web_hash.rs and that module's unit test assert too.
//
// Run: node --test test/hash.test.mjs   (after build.sh)

import { test } from 'node:test';
import assert from 'node:assert/strict';
import fs from 'node:fs';
import path from 'node:path';
import { fileURLToPath } from 'node:url';

const here = path.dirname(fileURLToPath(import.meta.url));
const wasmPath = process.env.COROFEM_WASM ?? path.join(here, '../www/corofem_web.wasm');
const expected = BigInt(fs.readFileSync(path.join(here, '../../../test-scenes/src/web_hash_script.txt'), 'utf8').trim());

const module = await WebAssembly.compile(fs.readFileSync(wasmPath));
const { exports: x } = await WebAssembly.instantiate(module, {});
const hex = (h) => '0x' + BigInt.asUintN(64, h).toString(16).padStart(16, '0');

test('the module needs no imports', () => {
  assert.deepEqual(WebAssembly.Module.imports(module), []);
});

test('the scripted scene hashes as on the host', () => {
  const t0 = performance.now();
  const got = x.cf_hash_script();
  const ms = performance.now() - t0;
  console.log(`wasm hash_script: ${hex(got)} in ${ms.toFixed(0)} ms (host: ${hex(expected)})`);
  assert.equal(hex(got), hex(expected));
});

test('the exported API builds and steps a body', () => {
  assert.equal(x.cf_load_body(1, 99), 0); // beam, its default support (clamp)
  assert.equal(x.cf_tet_count(), 1920);
  assert.equal(x.cf_node_count(), 525);
  assert.equal(x.cf_support(), 1);
  assert.ok(x.cf_fixed_count() > 0);
  assert.equal(x.cf_set_params(2e6, 0.3, 0, 0.002, 10, 1, 0), 0);
  const n = x.cf_node_count();
  const z0 = new Float32Array(x.memory.buffer, x.cf_positions_ptr(), 3 * n).slice();
  assert.equal(x.cf_step(100), 100);
  const z1 = new Float32Array(x.memory.buffer, x.cf_positions_ptr(), 3 * n);
  assert.ok(z1[3 * 20 + 2] < z0[3 * 20 + 2] - 0.01, 'the free end sags');
  // A bad parameter is refused with a message.
  assert.equal(x.cf_set_params(2e6, 0.7, 0, 0.002, 10, 1, 0), 1);
  const msg = new TextDecoder().decode(new Uint8Array(x.memory.buffer, x.cf_message_ptr(), x.cf_message_len()));
  assert.match(msg, /Poisson's ratio/);
});

test('the two-level preconditioner steps the beam; an unknown one is refused', () => {
  assert.equal(x.cf_load_body(1, 99), 0);
  assert.equal(x.cf_set_params(2e6, 0.3, 0, 0.002, 10, 1, 2), 0);
  const n = x.cf_node_count();
  const z0 = new Float32Array(x.memory.buffer, x.cf_positions_ptr(), 3 * n).slice();
  assert.equal(x.cf_step(100), 100);
  const z1 = new Float32Array(x.memory.buffer, x.cf_positions_ptr(), 3 * n);
  assert.ok(z1[3 * 20 + 2] < z0[3 * 20 + 2] - 0.01, 'the free end sags');
  assert.equal(x.cf_set_params(2e6, 0.3, 0, 0.002, 10, 1, 7), 1);
  const msg = new TextDecoder().decode(new Uint8Array(x.memory.buffer, x.cf_message_ptr(), x.cf_message_len()));
  assert.match(msg, /no preconditioner 7/);
});

test('the built-in bodies carry their smooth surfaces; a surface file is read and bound', () => {
  for (const [body, vertices, triangles] of [[0, 1538, 3072], [1, 2680, 5356], [2, 3458, 6912]]) {
    assert.equal(x.cf_load_body(body, 99), 0);
    assert.equal(x.cf_embedded_vertex_count(), vertices);
    assert.equal(x.cf_embedded_triangle_count(), triangles);
    assert.equal(x.cf_embedded_update(), 1);
    const n = new Float32Array(x.memory.buffer, x.cf_embedded_normals_ptr(), 3 * vertices);
    for (let i = 0; i < vertices; i++) {
      assert.ok(Math.abs(Math.hypot(n[3 * i], n[3 * i + 1], n[3 * i + 2]) - 1) < 1e-5);
    }
  }
  // A tetrahedron-shaped OBJ inside the blob, its name before its bytes.
  const name = new TextEncoder().encode('t.obj');
  const obj = new TextEncoder().encode('v 0 0 0\nv 0.1 0 0\nv 0 0.1 0\nv 0 0 0.1\nf 1 3 2\nf 1 2 4\nf 1 4 3\nf 2 3 4\n');
  const ptr = x.cf_input(name.length + obj.length);
  new Uint8Array(x.memory.buffer, ptr, name.length + obj.length).set([...name, ...obj]);
  assert.equal(x.cf_load_surface_input(name.length), 0);
  const msg = new TextDecoder().decode(new Uint8Array(x.memory.buffer, x.cf_message_ptr(), x.cf_message_len()));
  assert.equal(msg, '4 vertices, 4 triangles');
  assert.equal(x.cf_embedded_vertex_count(), 4);
});

test('the probe: pressed into the cube it is pushed back; bad input is refused; one inside is moved out', () => {
  const text = () => new TextDecoder().decode(new Uint8Array(x.memory.buffer, x.cf_message_ptr(), x.cf_message_len()));
  const stats = () => Array.from(new Float32Array(x.memory.buffer, x.cf_stats_ptr(), 16));
  const probe = () => (x.cf_probe_state() ? Array.from(new Float32Array(x.memory.buffer, x.cf_vec_ptr(), 8)) : null);
  assert.equal(x.cf_load_body(0, 99), 0); // the cube on the ground, top at z = 0.3 m
  assert.equal(x.cf_set_params(2e6, 0.3, 4, 0.002, 4, 1, 2), 0);
  x.cf_step(40);
  const r = 0.06;
  // Coming down from above, the sphere stops short of the top nodes.
  const t = x.cf_probe_cast(0.02, 0.01, 2, 0, 0, -1, r);
  assert.ok(Math.abs(2 - t - r - 0.3) < 0.01, `cast t = ${t}`);
  for (const bad of [[NaN, 0, 2, 0, 0, -1, r], [0, 0, 2, 0, 0, 0, r], [0, 0, 2, 0, 0, -1, -1], [0, 0, 0.3, 0, 0, -1, r], [3, 0, 2, 0, 0, -1, r]]) {
    assert.equal(x.cf_probe_cast(...bad), -1, `cast ${bad}`);
  }
  // Bad input: refused with a message, no probe made.
  for (const bad of [[NaN, 0, 1, r, 0, 0, -1], [0, 0, 1, NaN, 0, 0, -1], [0, 0, 1, 0, 0, 0, -1], [0, 0, 1, r, 0, 0, 0],
    [0, 0, Infinity, r, 0, 0, -1], [0, 0, 1, r, NaN, 0, -1]]) {
    assert.equal(x.cf_probe_set(...bad), 1, `set ${bad}`);
    assert.match(text(), /probe/);
    assert.equal(probe(), null);
  }
  assert.equal(x.cf_probe_friction(-1), 1);
  assert.equal(x.cf_probe_friction(NaN), 1);
  assert.equal(x.cf_probe_friction(0.3), 0);
  // Pressed 3 cm in over 80 steps, then held.
  const top = 2 - t;
  assert.equal(x.cf_probe_set(0.02, 0.01, top, r, 0, 0, -1), 0);
  for (let k = 1; k <= 20; k++) {
    assert.equal(x.cf_probe_set(0.02, 0.01, top - 0.03 * k / 20, r, 0, 0, -1), 0);
    assert.equal(x.cf_step(4), 4);
  }
  assert.equal(x.cf_step(20), 20);
  const s = stats();
  const p = probe();
  console.log(`probe 6 cm, 3 cm into the cube: force ${p.slice(4, 7).map((v) => v.toFixed(1))} N, ${p[7]} contacts`);
  assert.deepEqual(p.slice(0, 4).map((v) => +v.toFixed(5)), [0.02, 0.01, +(top - 0.03).toFixed(5), r]);
  assert.ok(p[6] > 50, `the body pushes the probe up: ${p.slice(4, 7)}`);
  assert.ok(p[7] > 0 && s[11] === p[7] && s[2] >= p[7]);
  assert.deepEqual(s.slice(12, 15), p.slice(4, 7));
  assert.equal(s[15], 0);
  // A bad goal changes nothing.
  assert.equal(x.cf_probe_set(NaN, 0, 0, r, 0, 0, -1), 1);
  assert.deepEqual(probe(), p);
  x.cf_probe_clear();
  assert.equal(probe(), null);
  // Made 2 cm inside the top: moved out upwards, then pressed in from there.
  x.cf_step(50);
  assert.equal(x.cf_probe_set(0, 0, 0.28, r, 0, 0, -1), 0);
  assert.equal(x.cf_step(8), 8);
  assert.equal(stats()[15], 1, 'moved out');
  assert.ok(probe()[6] > 0);
  assert.equal(x.cf_step(8), 8);
  assert.equal(stats()[15], 0);
  const n = x.cf_node_count();
  assert.ok(new Float32Array(x.memory.buffer, x.cf_positions_ptr(), 3 * n).every(Number.isFinite));
  x.cf_reset();
  assert.equal(probe(), null);
});

test('time per step in Node (the beam, default settings)', () => {
  assert.equal(x.cf_load_body(1, 99), 0);
  assert.equal(x.cf_set_params(2e6, 0.3, 0, 0.002, 10, 1, 0), 0);
  x.cf_step(50);
  const t0 = performance.now();
  const done = x.cf_step(500);
  const ms = (performance.now() - t0) / done;
  console.log(`node wasm: ${ms.toFixed(3)} ms/step (beam 1920 tets, QR-invertible, two-level, 4 CG iterations, warm)`);
  assert.ok(ms > 0);
});
