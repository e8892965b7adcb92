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
