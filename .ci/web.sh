#!/usr/bin/env bash
# The web demo (examples/web): native unit tests, the wasm build, the wasm
# module's state hash in Node against the host's, and the page in headless
# Chromium (Debian's package, driven by playwright-core from npm; no tool
# downloads a browser). Writes the screenshots to $out/web-demo.png and,
# beside it, web-surface.png (set COROFEM_WEB_SCREENSHOT=docs/web-demo.png to
# refresh docs/'s two). Called by .ci/run; runs alone too: `bash .ci/web.sh`.
# About a minute when everything is installed.
set -euo pipefail
root="$(cd "$(dirname "$0")/.." && pwd)"
web="$root/examples/web"
out="$web/test-output"
mkdir -p "$out"

echo "== web: tools"
if ! command -v chromium >/dev/null 2>&1; then
  apt-get update -qq
  DEBIAN_FRONTEND=noninteractive apt-get install -y -qq --no-install-recommends chromium >/dev/null
fi
chromium --version 2>/dev/null || true
rustup target add wasm32-unknown-unknown >/dev/null 2>&1 \
  || rustup target list --installed | grep -qx wasm32-unknown-unknown
cd "$web"
npm ci --no-audit --no-fund --loglevel=error

echo "== web: native unit tests (the shared mesh and surface readers as the page builds them, mesh preparation, surface files)"
cargo test --quiet

echo "== web: wasm build"
bash build.sh

echo "== web: serve www/"
port="$(python3 -c 'import socket; s = socket.socket(); s.bind(("127.0.0.1", 0)); print(s.getsockname()[1])')"
python3 -m http.server "$port" --bind 127.0.0.1 --directory www >"$out/http.log" 2>&1 &
server=$!
trap 'kill "$server" 2>/dev/null || true' EXIT
python3 - "$port" <<'PY'
import sys, time, urllib.request
for _ in range(100):
    try:
        urllib.request.urlopen(f"http://127.0.0.1:{sys.argv[1]}/", timeout=1)
        break
    except OSError:
        time.sleep(0.1)
else:
    sys.exit("the web server did not start")
PY

echo "== web: wasm module in Node (hash against the host's)"
node --test test/hash.test.mjs

echo "== web: the page in headless Chromium"
# A relative COROFEM_WEB_SCREENSHOT is taken from the repository's root.
shot="${COROFEM_WEB_SCREENSHOT:-$out/web-demo.png}"
case "$shot" in /*) ;; *) shot="$root/$shot" ;; esac
COROFEM_WEB_URL="http://127.0.0.1:$port/" \
COROFEM_WEB_SCREENSHOT="$shot" \
COROFEM_WEB_TIMING="$out/browser-timing.json" \
  node --test test/browser.test.mjs

echo "== web: native time per step of the same scene, and of the blob's surface update"
cargo run --quiet --release --example bench
echo "wasm size: $(wc -c < www/corofem_web.wasm) bytes ($(gzip -9 < www/corofem_web.wasm | wc -c) gzipped)"
