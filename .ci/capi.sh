#!/usr/bin/env bash
# C API: the generated header is up to date and compiles as C99 and
# C++; the Rust tests pass; the C example, linked against the staticlib,
# gives the Rust API's state hash; the same example cross-compiled for a
# Cortex-M4F gives it too in QEMU; a shortened 1 kHz real-time loop runs.
# Called from .ci/run; runs on its own too: `bash .ci/capi.sh`.
set -euo pipefail
cd "$(dirname "$0")/.."
ROOT=$PWD
export PATH="$HOME/.cargo/bin:$PATH"
export CARGO_TARGET_DIR="${CARGO_TARGET_DIR:-$ROOT/target}"
MANIFEST=capi/Cargo.toml
OUT=$(mktemp -d)
trap 'rm -rf "$OUT"' EXIT
LIVER=../shared/meshes/sofa_liver.tetmesh
FINE_LIVER=../shared/meshes/liver_ftw_3k.tetmesh
checks=0
step() { echo; echo "=== capi: $*"; }
pass() { checks=$((checks + 1)); echo "ok: $*"; }

step "header is cbindgen's output for the current source"
if ! command -v cbindgen >/dev/null; then
    # ≈ 3 min on 2 cores; the version is pinned so the output is stable.
    cargo install cbindgen --version 0.29.4 --locked --quiet
fi
(cd capi && cbindgen --quiet --config cbindgen.toml --output "$OUT/corofem.h")
diff -u capi/include/corofem.h "$OUT/corofem.h" || {
    echo "capi/include/corofem.h is stale: run (cd capi && cbindgen --config cbindgen.toml --output include/corofem.h)"
    exit 1
}
cc -std=c99 -Wall -Wextra -pedantic -Werror -fsyntax-only -x c capi/include/corofem.h
if command -v c++ >/dev/null; then c++ -std=c++11 -Wall -Werror -fsyntax-only -x c++ capi/include/corofem.h; fi
pass "header up to date, compiles as C99 and C++"

step "fmt and clippy"
cargo fmt --manifest-path $MANIFEST -- --check
cargo clippy --manifest-path $MANIFEST --all-targets -- -D warnings
# The firmware's feature set on the host: no surfaces, no ground.
cargo clippy --manifest-path $MANIFEST --all-targets --no-default-features --features qr -- -D warnings
# The coupling alone (it brings the probes, without friction or surfaces).
cargo clippy --manifest-path $MANIFEST --all-targets --no-default-features --features qr,coupling -- -D warnings
pass "fmt and clippy"

step "staticlib and the C example on the host"
cargo build --release --manifest-path $MANIFEST --lib
# What a Rust staticlib with std needs from the system on Linux
# (`rustc --print native-static-libs`).
NATIVE="-lgcc_s -lutil -lrt -lpthread -lm -ldl -lc"
cc -std=c11 -O2 -Wall -Wextra -pedantic -Werror -ffp-contract=off -Icapi/include \
    capi/examples/haptic_loop.c "$CARGO_TARGET_DIR/release/libcorofem_capi.a" $NATIVE -o "$OUT/haptic_loop"
"$OUT/haptic_loop" box 2000 | tee "$OUT/box.txt"
# The probe scene: a sphere pressed into the body, slid and lifted.
"$OUT/haptic_loop" box 2000 --probe --friction
# The same path as a haptic device's, the probe its proxy through the
# virtual coupling.
"$OUT/haptic_loop" box 2000 --probe --coupling
if [ -f "$LIVER" ]; then
    "$OUT/haptic_loop" "$LIVER" 2000 --rt
    "$OUT/haptic_loop" "$FINE_LIVER" 2000 --probe
    "$OUT/haptic_loop" "$FINE_LIVER" 3000 --probe --friction --rt
    "$OUT/haptic_loop" "$FINE_LIVER" 2000 --probe --coupling --rt
fi
pass "C example on the host (the tool, the probe with and without friction, the coupling)"

step "Rust API, C functions from Rust, and the C program: same hashes"
COROFEM_C_EXAMPLE="$OUT/haptic_loop" cargo test --manifest-path $MANIFEST
# Without the features `surface`, `probe`, `friction` and `coupling` their
# functions are there and say so.
cargo test --manifest-path $MANIFEST --no-default-features --features qr --test api -- _unsupported_without_the_feature
pass "Rust tests, hashes from Rust, from the C functions and from the C program agree"

step "the same C example on a Cortex-M4F (thumbv7em staticlib, arm-none-eabi-gcc, QEMU mps2-an386)"
# newlib too: a machine can have the compiler without it (seen here), and the
# example links with rdimon.specs (semihosting).
if ! command -v arm-none-eabi-gcc >/dev/null || ! command -v qemu-system-arm >/dev/null \
    || [ "$(arm-none-eabi-gcc -print-file-name=rdimon.specs)" = rdimon.specs ]; then
    (apt-get update -qq && apt-get install -y -qq --no-install-recommends \
        gcc-arm-none-eabi libnewlib-arm-none-eabi qemu-system-arm) >/dev/null 2>&1 || true
fi
# m4f FEATURES NAME: the staticlib with FEATURES, the C example linked
# against it for the Cortex-M4F as $OUT/NAME.elf, checked free of panicking
# code (with --gc-sections, the panic machinery is only there if some
# reachable code can panic), and run in QEMU into $OUT/NAME.txt.
m4f() {
    cargo rustc --release --manifest-path $MANIFEST --target thumbv7em-none-eabihf --lib \
        --crate-type staticlib --no-default-features --features "$1"
    arm-none-eabi-gcc -mcpu=cortex-m4 -mthumb -mfloat-abi=hard -mfpu=fpv4-sp-d16 -O2 -std=c11 \
        -Wall -Wextra -Werror -ffp-contract=off -DCOROFEM_BARE_METAL -Icapi/include \
        -nostartfiles -T capi/cortex-m4f/link.ld --specs=rdimon.specs \
        capi/cortex-m4f/startup.c capi/examples/haptic_loop.c \
        "$CARGO_TARGET_DIR/thumbv7em-none-eabihf/release/libcorofem_capi.a" -lm \
        -Wl,--gc-sections -Wl,--no-warn-execstack -o "$OUT/$2.elf"
    arm-none-eabi-size "$OUT/$2.elf"
    if arm-none-eabi-nm -C "$OUT/$2.elf" | grep -E 'core::panicking|rust_begin_unwind'; then
        echo "the Cortex-M4F image $2 links panicking code (see the symbols above)"
        exit 1
    fi
    timeout 600 qemu-system-arm -machine mps2-an386 -cpu cortex-m4 -nographic -monitor none \
        -serial none -semihosting-config enable=on,target=native -kernel "$OUT/$2.elf" \
        | tee "$OUT/$2.txt"
}
# same KEY NAME: the line starting with KEY is in the host's output and the
# same in $OUT/NAME.txt.
same() {
    host=$(grep "$1" "$OUT/box.txt")
    here=$(grep "$1" "$OUT/$2.txt")
    if [ -z "$host" ] || [ "$host" != "$here" ]; then
        echo "Cortex-M4F $2: '$here' differs from host '$host'"
        exit 1
    fi
}
if command -v arm-none-eabi-gcc >/dev/null && command -v qemu-system-arm >/dev/null; then
    m4f qr,fpu-sqrt,panic-handler haptic_loop
    same '^hash ' haptic_loop
    pass "Cortex-M4F image has no panicking code; its $here equals the host's"
    # With embedded surfaces: binding and moving them link no panicking
    # code either, and give the host's surface (printed to 1 µm).
    m4f qr,fpu-sqrt,panic-handler,surface haptic_loop_surface
    same '^hash ' haptic_loop_surface
    same '^surface tip ring centre ' haptic_loop_surface
    pass "Cortex-M4F image with surfaces has no panicking code; its surface (to 1 µm) and hash equal the host's"
    # The Cortex-M4F images are built without `probe` and `friction`: the
    # probe scene is the host's (on a microcontroller the example runs the
    # tool scene, which takes no arguments there).
else
    # A check that cannot run is a failure, not a pass.
    echo "arm-none-eabi-gcc (with newlib) or qemu-system-arm could not be installed"
    exit 1
fi

step "real-time loop at 1 kHz (shortened; the full run is 100 000 steps)"
cargo build --release --manifest-path $MANIFEST --example rt_loop
RT="$CARGO_TARGET_DIR/release/examples/rt_loop"
if [ -f "$LIVER" ]; then
    # Pinned with SCHED_FIFO where allowed (reported, not required).
    "$RT" --scene liver --steps 3000 --cpu 1 --fifo 80
    "$RT" --scene liver --steps 3000 --cpu 1 --fifo 80 --load
    # The probe scene of haptic_loop.c --probe, one cycle with friction.
    "$RT" --scene liver-ftw --probe --friction --steps 1200 --cpu 1 --fifo 80
fi
"$RT" --scene box10k --steps 300
pass "real-time loop ran"
echo
echo "capi: $checks passed, 0 failed"
