// Runs the firmware example's scene in the wasm module and prints one line
// per size, like the firmware and the host test:
//
//   node hash.mjs <corofem_wasm_hash.wasm> 10x2x2 [20x2x2 ...]
//   wasm-scene cells=10x2x2 hash=0x5f254f788421d41f
//
// Exits 1 if a size fails (the module returns 0 for a failed or implausible run).
import { readFileSync } from 'node:fs';

const [wasmPath, ...sizes] = process.argv.slice(2);
if (!wasmPath || sizes.length === 0) {
  console.error('usage: node hash.mjs <module.wasm> CXxCYxCZ...');
  process.exit(2);
}
const { instance } = await WebAssembly.instantiate(readFileSync(wasmPath));
let failed = false;
for (const spec of sizes) {
  const [cx, cy, cz] = spec.split('x').map(Number);
  // An i64 result arrives as a signed BigInt.
  const hash = BigInt.asUintN(64, instance.exports.scene_hash(cx, cy, cz));
  if (hash === 0n) {
    console.log(`wasm-scene cells=${spec} error`);
    failed = true;
    continue;
  }
  console.log(`wasm-scene cells=${spec} hash=0x${hash.toString(16).padStart(16, '0')}`);
}
process.exit(failed ? 1 : 0);
