#!/usr/bin/env bash
# Builds the browser bundle: crates/web for wasm32 (release), then
# wasm-bindgen's JS glue, beside index.html and main.js, into
# $CARGO_TARGET_DIR/web/bundle (target/web/bundle by default), which
# `gigawalk web` and `gigawalk serve` take by default.
#
# Needs the wasm32 target and wasm-bindgen-cli at the version Cargo.lock
# pins (it prints the commands to install either when missing).
set -euo pipefail
cd "$(dirname "$0")/../.."
target_dir="${CARGO_TARGET_DIR:-target}"
out="$target_dir/web/bundle"
want=$(awk '/^name = "wasm-bindgen"$/ { getline; gsub(/version = |"/, ""); print; exit }' Cargo.lock)
if ! rustup target list --installed 2>/dev/null | grep -qx wasm32-unknown-unknown; then
  echo "error: the wasm32 target is missing: rustup target add wasm32-unknown-unknown" >&2
  exit 1
fi
have=$(wasm-bindgen --version 2>/dev/null | awk '{ print $2 }' || true)
if [ "$have" != "$want" ]; then
  echo "error: wasm-bindgen-cli $want is needed (found: ${have:-none}):" \
    "cargo install wasm-bindgen-cli --version $want" >&2
  exit 1
fi
# No debug info and no name section in the page: they are a third of
# the .wasm otherwise.
CARGO_PROFILE_RELEASE_DEBUG=false \
  cargo build --release --target wasm32-unknown-unknown -p gigawalk-web
rm -rf "$out.tmp"
mkdir -p "$out.tmp"
wasm-bindgen --target web --no-typescript --remove-name-section --remove-producers-section \
  --out-dir "$out.tmp" \
  "$target_dir/wasm32-unknown-unknown/release/gigawalk_web.wasm"
if command -v wasm-opt >/dev/null 2>&1; then
  wasm-opt -O2 --enable-bulk-memory --enable-nontrapping-float-to-int --enable-sign-ext \
    "$out.tmp/gigawalk_web_bg.wasm" -o "$out.tmp/gigawalk_web_bg.wasm"
fi
cp crates/web/static/index.html crates/web/static/main.js "$out.tmp/"
rm -rf "$out"
mv "$out.tmp" "$out"
echo "bundle: $out ($(du -sh "$out" | cut -f1))"
