#!/usr/bin/env bash
# Short coverage-guided fuzz run (cargo-fuzz / libFuzzer) of every target in
# fuzz/: FUZZ_RUNS (default 300 000) executions each, at most FUZZ_SECONDS
# (default 60) seconds, from the committed seeds, with debug assertions and
# overflow checks on. A crash fails the run and leaves the input in
# fuzz/artifacts/TARGET/ (make it a regression test and a seed).
#
# The run is reproducible: libFuzzer's random seed is fixed (FUZZ_SEED,
# default 1) and the number of executions bounded, so CI explores exactly
# what a developer's run of this script explored, and a CI failure
# reproduces locally. New ground is broken by long runs with other seeds:
# FUZZ_SEED=0 (random) FUZZ_RUNS=-1 FUZZ_SECONDS=900, as reported in
# docs/reliability.md.
set -euo pipefail
cd "$(dirname "$0")/../fuzz"
seconds="${FUZZ_SECONDS:-60}"
runs="${FUZZ_RUNS:-300000}"
seed="${FUZZ_SEED:-1}"

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
      -max_total_time="$seconds" -runs="$runs" -seed="$seed" -print_final_stats=1 \
      -artifact_prefix="artifacts/$target/" >"$corpus.log" 2>&1; then
    done_runs=$(sed -n 's/^stat::number_of_executed_units: *//p' "$corpus.log")
    echo "fuzz $target: ${done_runs:-?} executions (seed $seed), no crash"
  else
    status=1
    echo "fuzz $target: FAILED"
    tail -n 40 "$corpus.log"
  fi
  rm -rf "$corpus" "$corpus.log"
done
exit "$status"
