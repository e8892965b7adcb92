#!/usr/bin/env bash
# Short coverage-guided fuzz run (cargo-fuzz / libFuzzer) of every target in
# fuzz/: about FUZZ_SECONDS (default 15) seconds each, from the committed
# seeds, with debug assertions and overflow checks on. A crash fails the run
# and leaves the input in fuzz/artifacts/TARGET/ (make it a regression test).
#
# The long run reported in docs/reliability.md is the same command with
# FUZZ_SECONDS=900.
set -euo pipefail
cd "$(dirname "$0")/../fuzz"
seconds="${FUZZ_SECONDS:-15}"

# cargo-fuzz needs the nightly toolchain for its sanitizer flags. Without
# one (this machine's kind ships a single stable toolchain), build with
# stable: libFuzzer's coverage instrumentation is stable `-C` flags, and no
# sanitizer is used (corofem and its readers have no unsafe code).
if cargo +nightly --version >/dev/null 2>&1; then
  toolchain=(+nightly)
else
  echo "fuzz: no nightly toolchain, using stable with RUSTC_BOOTSTRAP=1"
  toolchain=()
  export RUSTC_BOOTSTRAP=1
fi
if ! cargo fuzz --version >/dev/null 2>&1; then
  echo "fuzz: installing cargo-fuzz (a few minutes, once per machine)"
  cargo install cargo-fuzz --locked
fi

flags=(--sanitizer none --debug-assertions)
cargo "${toolchain[@]}" fuzz build "${flags[@]}"
status=0
for target in $(cargo "${toolchain[@]}" fuzz list); do
  corpus="$(mktemp -d)"
  seeds=()
  [ -d "seeds/$target" ] && seeds=("seeds/$target")
  mkdir -p "artifacts/$target"
  if cargo "${toolchain[@]}" fuzz run "${flags[@]}" "$target" "$corpus" "${seeds[@]}" -- \
      -max_total_time="$seconds" -print_final_stats=1 \
      -artifact_prefix="artifacts/$target/" >"$corpus.log" 2>&1; then
    runs=$(sed -n 's/^stat::number_of_executed_units: *//p' "$corpus.log")
    echo "fuzz $target: ${runs:-?} executions in ${seconds} s, no crash"
  else
    status=1
    echo "fuzz $target: FAILED"
    tail -n 40 "$corpus.log"
  fi
  rm -rf "$corpus" "$corpus.log"
done
exit "$status"
