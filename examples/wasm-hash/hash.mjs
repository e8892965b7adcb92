// Runs the firmware example's scene in the wasm module and prints one line
// per size, like the firmware and the host test:
//
//   node hash.mjs <corofem_wasm_hash.wasm> [--two-level] 10x2x2 [20x2x2 ...]
//   wasm-scene cells=10x2x2 hash=0x5f254f788421d41f
//
// With --two-level the scene runs with the two-level preconditioner and the
// lines read wasm-scene-two-level.
//
// Exits 1 if a size fails (the module returns 0 for a failed or implausible run).
import { readFileSync } from 'node:fs';

const [wasmPath, ...rest] = process.argv.slice(2);
const twoLevel = rest[0] === '--two-level';
const sizes = twoLevel ? rest.slice(1) : rest;
const label = twoLevel ? 'wasm-scene-two-level' : 'wasm-scene';
if (!wasmPath || sizes.length === 0) {
  console.error('usage: node hash.mjs <module.wasm> [--two-level] CXxCYxCZ...');
  process.exit(2);
}
const { instance } = await WebAssembly.instantiate(readFileSync(wasmPath));
let failed = false;
for (const spec of sizes) {
  const [cx, cy, cz] = spec.split('x').map(Number);
  // An i64 result arrives as a signed BigInt.
  const run = twoLevel ? instance.exports.scene_hash_two_level : instance.exports.scene_hash;
  const hash = BigInt.asUintN(64, run(cx, cy, cz));
  if (hash === 0n) {
    console.log(`${label} cells=${spec} error`);
    failed = true;
    continue;
  }
  console.log(`${label} cells=${spec} hash=0x${hash.toString(16).padStart(16, '0')}`);
}
process.exit(failed ? 1 : 0);
