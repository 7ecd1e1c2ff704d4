#!/usr/bin/env bash
# Runs every test of the project. Installs what it needs on a fresh machine.
# Real-data tests read ../shared/data (or $GNSS_DATA_DIR); they skip without it, and fail in CI.
set -euo pipefail
cd "$(dirname "$0")/.."

if ! rustup target list --installed | grep -qx thumbv7em-none-eabihf; then
  rustup target add thumbv7em-none-eabihf
fi

echo "== clippy (host workspace, warnings are errors)"
cargo clippy --workspace --all-targets -q -- -D warnings
echo "== host tests"
cargo test --workspace
echo "== detector-core for Cortex-M4F (no_std, no alloc)"
if grep -rnE 'extern crate (alloc|std)|alloc::' detector-core/src; then
  echo "detector-core must not use alloc or std" >&2; exit 1
fi
cargo build -q -p detector-core --target thumbv7em-none-eabihf --release
echo "== firmware image (embassy, STM32F405RG)"
(cd firmware && cargo clippy -q --release -- -D warnings && cargo build -q --release)
echo "== all tests passed"
