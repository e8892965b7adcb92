#!/usr/bin/env bash
# Builds this program once per math backend, runs the same scenes with each,
# and prints micromath's error against libm and the time ratio.
# Usage: bash examples/backend-compare/run.sh
set -euo pipefail
cd "$(dirname "$0")"
target="${CARGO_TARGET_DIR:-$PWD/../../target}/backend-compare"
out="$target/results"
mkdir -p "$out"
for backend in libm micromath; do
  cargo build --release -q --no-default-features --features "$backend" \
    --target-dir "$target/$backend"
  "$target/$backend/release/corofem-backend-compare" run "$out/$backend.txt"
done
"$target/libm/release/corofem-backend-compare" compare "$out/libm.txt" "$out/micromath.txt"
