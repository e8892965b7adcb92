#!/usr/bin/env bash
# Firmware checks (docs/firmware.md), called by .ci/run:
#
#  1. the host test computes the firmware scene at every size and prints its
#     state hashes (host-tests/tests/firmware_hash.rs);
#  2. the wasm32 module computes the same scenes under node;
#  3. the firmware is built for thumbv7em-none-eabihf at every size and run
#     in QEMU (mps2-an386, Cortex-M4F); it must exit 0 (plausible results)
#     and print the host's hash. The reference size is also built with
#     the Rust stiffness product instead of the assembly one (fpu-product),
#     with libm's software square root instead of vsqrt as well, and tuned
#     for the Cortex-M4 with the assembly's VMUL+VADD form
#     (_fpu-product-vmul), and with the core's features two-level,
#     nalgebra and free-rotation compiled in but unused: same hash, and with the firmware's
#     feature nalgebra, which calls the core's nalgebra twins of the probe
#     and the coupling (so the proof covers them): same hash. Every size is also built
#     running the two-level preconditioner (the firmware's feature
#     two-level), against the host's and wasm32's hashes of that run.
#     The reference size is also built with the features ground, probe
#     and probe + friction (the scene in contact): the host's hashes of
#     that scene, and contacts made;
#  4. the scene is a `static StaticScene`: an empty scene is all zero bits,
#     so it must land in .bss. Every build's .data stays under 1 KiB
#     (MAX_DATA), and the flash images (vectors, code, constants, .data's
#     initial values) of the builds at every size differ by less than 4 KiB
#     (MAX_FLASH_SPREAD) while their scenes' RAM grows eightfold: flash is
#     code and constants only;
#  5. panic-freedom: every release build above links only because no
#     panicking branch is left (the panic handler calls an undefined
#     symbol); the negative control adds one bounds check and must fail to
#     link on exactly that symbol;
#  6. the defmt log is decoded when defmt-print is installed
#     (COROFEM_INSTALL_DEFMT_PRINT=1 installs it: ~5 minutes).
#
# Prints a cost table (instructions per tetrahedron-step, stack, flash,
# RAM) and ends with "firmware: N passed, M failed"; exits non-zero on any
# failure. Honours CARGO_TARGET_DIR (default: the workspace's target/).
set -euo pipefail

ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
export CARGO_TARGET_DIR="${CARGO_TARGET_DIR:-$ROOT/target}"
FW="$ROOT/examples/firmware"
WASM="$ROOT/examples/wasm-hash"
OUT="$CARGO_TARGET_DIR/firmware-ci"
MODULE="$CARGO_TARGET_DIR/wasm32-unknown-unknown/release/corofem_wasm_hash.wasm"
QEMU=(qemu-system-arm -machine mps2-an386 -cpu cortex-m4 -nographic -monitor none
      -serial null -semihosting-config enable=on,target=native -icount shift=0 -kernel)
REFERENCE=10x2x2
# The scene in contact: the firmware's features and the obstacles they
# give (ContactSet::name, the host's firmware-scene-<set> lines).
CONTACT_FEATURES=(ground probe probe,friction)
CONTACT_SETS=(ground ground-probe ground-probe-friction)
PROOF_SYMBOL=corofem_firmware_panic_is_reachable
# Bytes of .data allowed: the runtime's and defmt's few statics. A scene in
# .data (a non-zero byte in its initial value) is kilobytes.
MAX_DATA=1024
# Most bytes by which the flash of the builds at different sizes may differ:
# the capacities are constants that the optimiser folds into the code
# (1.2 kB apart measured, not growing with the size), while a scene in flash
# adds 6.5 kB (2x2x2) to 53 kB (20x2x2).
MAX_FLASH_SPREAD=4096

rm -rf "$OUT"
mkdir -p "$OUT"
passed=0
failed=0
ok() { echo "ok: $*"; passed=$((passed + 1)); }
bad() { echo "FAILED: $*" >&2; failed=$((failed + 1)); }
step() { echo; echo "== firmware: $*"; }
finish() {
  echo
  echo "firmware: $passed passed, $failed failed"
  [ "$failed" -eq 0 ]
}

step "tools"
if ! command -v qemu-system-arm >/dev/null; then
  # --no-install-recommends: ~15 MB instead of ~850 MB.
  apt-get update -qq
  DEBIAN_FRONTEND=noninteractive apt-get install -y -qq --no-install-recommends qemu-system-arm >/dev/null
fi
for target in thumbv7em-none-eabihf wasm32-unknown-unknown; do
  rustup target list --installed | grep -qx "$target" || rustup target add "$target"
done
if ! command -v defmt-print >/dev/null && [ "${COROFEM_INSTALL_DEFMT_PRINT:-0}" = 1 ]; then
  cargo install defmt-print --locked --quiet
fi
qemu-system-arm --version | head -1
node --version

# "cells=10x2x2 ... hash=0x..." lines -> "10x2x2 0x..." pairs.
pairs() { grep -o 'cells=[0-9x]* .*hash=0x[0-9a-f]\{16\}' | sed -E 's/cells=([0-9x]+) .*hash=(0x[0-9a-f]+)/\1 \2/' | sort -u; }
# Size in bytes of the ELF's flash (loaded: vectors, code, constants, .data's
# initial values) and RAM (.data, .bss, .uninit) images, and of .data alone
# (initialised RAM: its image is in flash too).
elf_sizes() {
  python3 - "$1" <<'EOF'
import struct, sys
data = open(sys.argv[1], 'rb').read()
assert data[:4] == b'\x7fELF' and data[4] == 1, 'a 32-bit ELF'
shoff, = struct.unpack_from('<I', data, 0x20)
shentsize, shnum = struct.unpack_from('<HH', data, 0x2e)
flash = ram = initialised = 0
for i in range(shnum):
    _, kind, flags, addr, _, size = struct.unpack_from('<IIIIII', data, shoff + i * shentsize)
    if not flags & 2 or size == 0:  # SHF_ALLOC
        continue
    in_ram = 0x20000000 <= addr < 0x40000000
    if kind == 1:  # PROGBITS: stored in flash (.data as its initial values)
        flash += size
    if in_ram:
        ram += size
        if kind == 1:
            initialised += size
print(flash, ram, initialised)
EOF
}

step "host: the firmware scene at every size"
(cd "$ROOT" && cargo test -q -p corofem-host-tests --test host firmware_hash:: -- --nocapture --test-threads 1) \
  >"$OUT/host.txt" 2>&1 || { cat "$OUT/host.txt"; bad "host test"; finish; }
# The scene with the lumped mass (firmware-scene lines) and with the
# two-level preconditioner (firmware-scene-two-level lines).
grep 'firmware-scene cells=' "$OUT/host.txt" | pairs >"$OUT/host.hashes"
grep 'firmware-scene-two-level cells=' "$OUT/host.txt" | pairs >"$OUT/host-two-level.hashes"
# The scene in contact (reference size): firmware-scene-ground,
# -ground-probe and -ground-probe-friction lines.
for set in "${CONTACT_SETS[@]}"; do
  grep "firmware-scene-$set cells=" "$OUT/host.txt" | pairs >"$OUT/host-$set.hashes"
  [ -s "$OUT/host-$set.hashes" ] || { bad "host test printed no hash for the scene in contact ($set)"; finish; }
done
cat "$OUT/host.hashes" "$OUT/host-two-level.hashes"
mapfile -t SIZES < <(cut -d' ' -f1 "$OUT/host.hashes")
[ "${#SIZES[@]}" -ge 2 ] || { bad "host test printed no sizes"; finish; }
[ "$(wc -l <"$OUT/host-two-level.hashes")" -eq "${#SIZES[@]}" ] ||
  { bad "host test printed no two-level hash for some size"; finish; }
ok "host test (${#SIZES[@]} sizes, each with both preconditioners)"
# host_hash CELLS [FILE]: the host's hash of that size (FILE: the mass's).
host_hash() { awk -v s="$1" '$1 == s { print $2 }' "${2:-$OUT/host.hashes}"; }

step "wasm32: the same scenes under node"
(cd "$WASM" && cargo build -q --release --target wasm32-unknown-unknown)
if node "$WASM/hash.mjs" "$MODULE" "${SIZES[@]}" >"$OUT/wasm.txt" &&
   node "$WASM/hash.mjs" "$MODULE" --two-level "${SIZES[@]}" >"$OUT/wasm-two-level.txt"; then
  cat "$OUT/wasm.txt" "$OUT/wasm-two-level.txt"
  pairs <"$OUT/wasm.txt" >"$OUT/wasm.hashes"
  pairs <"$OUT/wasm-two-level.txt" >"$OUT/wasm-two-level.hashes"
  if diff -u "$OUT/host.hashes" "$OUT/wasm.hashes" &&
     diff -u "$OUT/host-two-level.hashes" "$OUT/wasm-two-level.hashes"; then
    ok "wasm32 hashes equal the host's, with both preconditioners"
  else
    bad "wasm32 hashes differ from the host's"
  fi
else
  cat "$OUT/wasm.txt"
  bad "wasm module"
fi

# Builds the firmware (extra cargo arguments in "$@"; FW_RUSTFLAGS and
# FW_TARGET_DIR for a tuned build), runs it in QEMU and checks its exit code
# and hash against the host's. Leaves its output in $OUT/fw-<cells>-<variant>.*.
run_firmware() {
  local cells="$1" variant="$2"
  shift 2
  local log="$OUT/fw-$cells-$variant"
  local tdir="${FW_TARGET_DIR:-$CARGO_TARGET_DIR}"
  if ! (cd "$FW" && COROFEM_FW_CELLS="${cells//x/,}" CARGO_TARGET_DIR="$tdir" \
        RUSTFLAGS="${FW_RUSTFLAGS:-}" cargo build -q --release "$@") >"$log.build" 2>&1; then
    cat "$log.build"
    bad "firmware $cells ($variant) does not link: a panicking branch remains (or a build error)"
    return
  fi
  ok "firmware $cells ($variant): release build links, so no panicking branch remains"
  cp "$tdir/thumbv7em-none-eabihf/release/corofem-firmware" "$log.elf"
  local flash ram data
  read -r flash ram data < <(elf_sizes "$log.elf")
  if [ "$data" -le "$MAX_DATA" ]; then
    ok "firmware $cells ($variant): $flash B of flash, $data B of .data, $ram B of RAM: the static scene is in .bss"
  else
    bad "firmware $cells ($variant): $data B of .data (at most $MAX_DATA): the static scene landed in .data and costs flash"
  fi
  local status=0
  (cd "$OUT" && rm -f defmt.bin && timeout 300 "${QEMU[@]}" "$log.elf") >"$log.txt" 2>&1 || status=$?
  [ -f "$OUT/defmt.bin" ] && mv "$OUT/defmt.bin" "$log.defmt"
  cat "$log.txt"
  local want got
  want="$(host_hash "$cells" "${FW_HASHES:-}")"
  got="$(pairs <"$log.txt" | cut -d' ' -f2)"
  if [ "$status" -ne 0 ]; then
    bad "firmware $cells ($variant) exited with $status"
  elif [ -z "$got" ] || [ "$got" != "$want" ]; then
    bad "firmware $cells ($variant): hash ${got:-none}, host $want"
  elif ! grep -q 'instr_per_tick=40\.000 ' "$log.txt"; then
    bad "firmware $cells ($variant): SysTick is not counting instructions (-icount?)"
  else
    ok "firmware $cells ($variant) in QEMU: exit 0, hash equals the host's"
  fi
}

step "firmware in QEMU (thumbv7em-none-eabihf, vsqrt), every size"
for cells in "${SIZES[@]}"; do
  run_firmware "$cells" vsqrt
done
step "flash does not grow with the scene"
flashes=()
for cells in "${SIZES[@]}"; do
  elf="$OUT/fw-$cells-vsqrt.elf"
  [ -f "$elf" ] && flashes+=("$(elf_sizes "$elf" | cut -d' ' -f1)")
done
if [ "${#flashes[@]}" -ne "${#SIZES[@]}" ]; then
  bad "not every size built"
else
  lo="$(printf '%s\n' "${flashes[@]}" | sort -n | head -1)"
  hi="$(printf '%s\n' "${flashes[@]}" | sort -n | tail -1)"
  if [ "$((hi - lo))" -lt "$MAX_FLASH_SPREAD" ]; then
    ok "flash $lo..$hi B at every size (${SIZES[*]}): code and constants only"
  else
    bad "flash $lo..$hi B across sizes (${SIZES[*]}): it grows with the scene"
  fi
fi
step "firmware with the Rust stiffness product instead of the assembly one ($REFERENCE)"
run_firmware "$REFERENCE" rust-prod --no-default-features --features fpu-sqrt
step "firmware with libm's software sqrt and the Rust product ($REFERENCE)"
run_firmware "$REFERENCE" libm --no-default-features
step "firmware tuned for the Cortex-M4 (-C target-cpu=cortex-m4 and _fpu-product-vmul: VMUL+VADD instead of VMLA) ($REFERENCE)"
FW_RUSTFLAGS="-C target-cpu=cortex-m4" FW_TARGET_DIR="$CARGO_TARGET_DIR/firmware-cortex-m4" \
  run_firmware "$REFERENCE" cortex-m4 --features _fpu-product-vmul
step "firmware with the core's features two-level, nalgebra and free-rotation compiled in, unused ($REFERENCE): same hash"
run_firmware "$REFERENCE" features --features corofem/two-level,corofem/nalgebra,corofem/free-rotation
step "firmware calling the core's nalgebra twins of the probe and the coupling ($REFERENCE): linked panic-free, same hash"
run_firmware "$REFERENCE" nalgebra --features nalgebra
step "firmware running the two-level preconditioner (4 CG iterations, warm start), every size: the host's two-level hashes"
for cells in "${SIZES[@]}"; do
  FW_HASHES="$OUT/host-two-level.hashes" run_firmware "$cells" two-level --features two-level
done

step "firmware in contact (features ground, probe, probe + friction) ($REFERENCE): the host's hashes, contacts made"
for i in "${!CONTACT_FEATURES[@]}"; do
  set="${CONTACT_SETS[$i]}"
  FW_HASHES="$OUT/host-$set.hashes" run_firmware "$REFERENCE" "$set" --features "${CONTACT_FEATURES[$i]}"
  line="$(grep -m1 '^corofem-firmware ' "$OUT/fw-$REFERENCE-$set.txt" 2>/dev/null)" || line=""
  contacts="$(sed -nE 's/.* contact_steps=([0-9]+).*/\1/p' <<<"$line")"
  probe="$(sed -nE 's/.* probe_contacts=([0-9]+).*/\1/p' <<<"$line")"
  if ! grep -q " contact=$set " <<<"$line"; then
    bad "firmware ($set): not the scene in contact"
  elif [ "${contacts:-0}" -eq 0 ]; then
    bad "firmware ($set): no step made contact"
  elif [[ "$set" == *probe* ]] && [ "${probe:-0}" -eq 0 ]; then
    bad "firmware ($set): the probe touched nothing"
  else
    ok "firmware ($set): contacts in $contacts of the steps, the probe held up to ${probe:-0} nodes"
  fi
done

step "panic-freedom: negative control"
if (cd "$FW" && cargo build --release --features panic-negative-control) >"$OUT/negative.txt" 2>&1; then
  bad "the negative control linked: the panic-freedom check does not catch panics"
elif grep -q "undefined symbol: $PROOF_SYMBOL" "$OUT/negative.txt"; then
  grep -m1 "undefined symbol" "$OUT/negative.txt"
  ok "negative control: one bounds check and the link fails on $PROOF_SYMBOL"
else
  cat "$OUT/negative.txt"
  bad "the negative control failed for another reason"
fi

step "defmt log"
ref_defmt="$OUT/fw-$REFERENCE-vsqrt.defmt"
if [ ! -s "$ref_defmt" ]; then
  bad "the firmware wrote no defmt log"
elif command -v defmt-print >/dev/null; then
  defmt-print -e "$OUT/fw-$REFERENCE-vsqrt.elf" stdin <"$ref_defmt" >"$OUT/defmt.txt" 2>&1 || true
  cat "$OUT/defmt.txt"
  if grep -q "hash $(host_hash "$REFERENCE")" "$OUT/defmt.txt"; then
    ok "defmt log decoded, with the same hash"
  else
    bad "defmt log does not decode to the hash"
  fi
else
  echo "defmt-print not installed: $(wc -c <"$ref_defmt") bytes of defmt frames not decoded" \
    "(COROFEM_INSTALL_DEFMT_PRINT=1 installs it)"
fi

step "cost per scene size (Qr, 500 steps; 5 CG iterations, two-level: 4 and warm start)"
{
  printf '%-8s %5s %5s %-21s %10s %9s %6s %7s %6s %7s %5s %5s\n' \
    cells nodes tets build instr/step instr/tet stack flash ram ram+stk node cg
  for f in "$OUT"/fw-*.txt; do
    line="$(grep -m1 '^corofem-firmware ' "$f")" || continue
    field() { sed -nE "s/.* $1=([^ ]+).*/\\1/p" <<<"$line"; }
    read -r flash ram _ < <(elf_sizes "${f%.txt}.elf")
    variant="${f##*/fw-}"
    variant="${variant#*-}"
    variant="${variant%.txt}"
    printf '%-8s %5s %5s %-21s %10s %9s %6s %7s %6s %7s %5s %5s\n' \
      "$(field cells)" "$(field nodes)" "$(field tets)" "$variant" "$(field instr_per_step)" \
      "$(field instr_per_tet_step)" "$(field stack_step)" "$flash" "$ram" \
      "$((ram + $(field stack_peak)))" "$(field node_bytes)" "$(field cg_iterations)"
  done | sort -k3,3n -k4,4r
} | tee "$OUT/summary.txt"
echo "(build: vsqrt = default (fpu-sqrt, fpu-product: the assembly product with VMLA),"
echo " rust-prod = vsqrt and the Rust product, libm = software sqrt and the Rust product,"
echo " cortex-m4 = -C target-cpu=cortex-m4 and _fpu-product-vmul (VMUL+VADD),"
echo " features = vsqrt with the core's features two-level, nalgebra and free-rotation compiled in, unused;"
echo " two-level = vsqrt running the two-level preconditioner, 4 CG iterations with warm start;"
echo " ground, ground-probe, ground-probe-friction = vsqrt with the firmware's features ground,"
echo "   probe, probe + friction: the beam on the ground, a sphere probe pressing in, friction;"
echo " node: bytes of RAM per node (Node + NodeWork); cg: CG iterations of the 500 steps;"
echo " stack: bytes of one step; flash, ram: bytes of the image;"
echo " ram+stk: with the peak stack, which is the mesh generation's scratch)"

finish
