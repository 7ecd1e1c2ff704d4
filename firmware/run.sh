#!/usr/bin/env bash
# Cargo runner for thumbv7em-none-eabihf (see .cargo/config.toml): the QEMU image runs under
# qemu-system-arm (netduinoplus2 = STM32F405 memory map, semihosting, deterministic -icount);
# so does detector-core's example image (core-example); every other image is flashed to a board with probe-rs.
set -euo pipefail
elf="$1"; shift
case "$(basename "$elf")" in
  qemu-run|core-example)
    exec qemu-system-arm -M netduinoplus2 -nographic -monitor none -serial none \
      -semihosting-config enable=on,target=native -icount shift=0,sleep=off -kernel "$elf" ;;
  *)
    exec probe-rs run --chip STM32F405RGTx "$elf" "$@" ;;
esac
