#!/usr/bin/env bash
# Flash and static RAM of the release firmware image, checked against the targets
# (flash <= 256 KiB with the model and templates, static RAM <= 48 KiB). Uses GNU size (binutils).
set -euo pipefail
cd "$(dirname "$0")/.."
elf=firmware/target/thumbv7em-none-eabihf/release/gnss-guard-fw
# Always build: measuring an image left from older sources would report a stale figure.
(cd firmware && cargo build -q --release -p gnss-guard-fw)
read -r flash ram < <(size -A "$elf" | awk '
  $1 ~ /^\.(vector_table|text|rodata|data)$/ { f += $2 }
  $1 ~ /^\.(data|bss|uninit)$/ { r += $2 }
  END { print f, r }')
echo "firmware image: flash ${flash} bytes ($((flash / 1024)) KiB, target <= 256 KiB), static RAM ${ram} bytes ($((ram / 1024)) KiB, target <= 48 KiB)"
[ "$flash" -le $((256 * 1024)) ] && [ "$ram" -le $((48 * 1024)) ] || { echo "size target exceeded" >&2; exit 1; }
