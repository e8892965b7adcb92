#!/usr/bin/env bash
# Builds the wasm module (release, size-optimised) into examples/web/www/,
# the folder to serve. Needs only cargo and the wasm32-unknown-unknown target
# (`rustup target add wasm32-unknown-unknown`).
set -euo pipefail
cd "$(dirname "$0")"
cargo build --release --target wasm32-unknown-unknown
target="${CARGO_TARGET_DIR:-$PWD/target}"
cp "$target/wasm32-unknown-unknown/release/corofem_web.wasm" www/corofem_web.wasm
echo "www/corofem_web.wasm: $(wc -c < www/corofem_web.wasm) bytes"
