#!/usr/bin/env bash
# Runs every test of the project. Installs what it needs on a fresh machine.
# Real-data tests read ../shared/data (or $GNSS_DATA_DIR); they skip without it, and fail in CI.
set -euo pipefail
cd "$(dirname "$0")/.."
# Each phase's heading says when it started, in seconds since the script's start.
phase() { echo "== $* (at ${SECONDS} s)"; }

if ! rustup target list --installed | grep -qx thumbv7em-none-eabihf; then
  rustup target add thumbv7em-none-eabihf
fi
if ! command -v qemu-system-arm >/dev/null; then
  sudo_=""; [ "$(id -u)" = 0 ] || sudo_="sudo"
  $sudo_ apt-get update -qq && DEBIAN_FRONTEND=noninteractive $sudo_ apt-get install -y -qq qemu-system-arm >/dev/null
fi

phase "layers: no import cycle between the files of a crate"
python3 tests/check-layers.py detector-core/src host-sim/src gnss-data/src firmware/board/src firmware/profile/src
phase "documentation: every relative link and image resolves, every figure is one eval writes"
python3 tests/check-links.py
phase "host-sim builds without training (no burn), and the firmware workspace without host tools"
if cargo tree -q -p host-sim -e normal --no-default-features | grep -qE ' burn(-[a-z]+)? v'; then
  echo "host-sim without features must not depend on burn" >&2; exit 1
fi
if grep -qE '^name = "(burn|plotters|host-sim)"' firmware/Cargo.lock; then
  echo "firmware/Cargo.lock must not contain burn, plotters or host-sim" >&2; exit 1
fi
phase "clippy (host workspace, every feature, warnings are errors)"
cargo clippy --workspace --all-targets --all-features -q -- -D warnings
phase "host tests (every feature: the LSTM training tests need burn)"
cargo test --workspace --all-features
phase "Python package: the abi3 wheel (maturin) in a private venv; pytest: its verdicts are host-sim's, and the Spark fleet run's"
if ! command -v java >/dev/null; then  # Spark's JVM (Java 17 or later)
  sudo_=""; [ "$(id -u)" = 0 ] || sudo_="sudo"
  $sudo_ apt-get update -qq && DEBIAN_FRONTEND=noninteractive $sudo_ apt-get install -y -qq openjdk-17-jre-headless >/dev/null
fi
venv=target/pyvenv
[ -x "$venv/bin/python" ] || python3 -m venv "$venv"
# pandas < 3: PySpark 4.x supports pandas 2 (the package itself takes either).
"$venv/bin/python" -m pip install -q "maturin>=1.7,<2" "pytest>=7" "pandas>=1.5,<3" "pyarrow>=14" "pyspark>=3.5"
rm -rf target/wheels
"$venv/bin/python" -m maturin build -q --release -m python/Cargo.toml -o target/wheels
"$venv/bin/python" -m pip install -q --force-reinstall --no-deps target/wheels/gnss_guard-*.whl
cargo build -q --release -p host-sim
GNSS_GUARD_HOST_SIM="$PWD/target/release/host-sim" "$venv/bin/python" -m pytest -q -p no:cacheprovider python/tests

phase "detector-core as a crate: rustdoc warning-free, packaged and verified with its kernel crate"
RUSTDOCFLAGS="-D warnings" cargo doc -q -p detector-core -p gnss-guard-dsp --no-deps
# Cargo verifies detector-core against gnss-guard-dsp unpacked into its registry cache, and
# reuses an earlier unpacking of the same version: a change to the kernel crate's code needs its
# version raised (and detector-core's requirement with it), as a release would.
cargo publish -q --dry-run --allow-dirty -p gnss-guard-dsp -p detector-core
echo "cargo publish --dry-run: gnss-guard-dsp and detector-core package and build from their packages"
phase "detector-core for Cortex-M4F (no_std, no alloc)"
if grep -rnE 'extern crate (alloc|std)|alloc::' detector-core/src; then
  echo "detector-core must not use alloc or std" >&2; exit 1
fi
cargo build -q -p detector-core --target thumbv7em-none-eabihf --release
phase "firmware images (embassy STM32F405RG, the QEMU image, the no-panic proof)"
(cd firmware && cargo clippy -q --release -- -D warnings)
phase "no-panic proof: the per-epoch path linked with panic-never (the link fails on any panic path)"
if ! (cd firmware && cargo build -q --release -p nopanic); then
  echo "panic paths survive in the per-epoch path; where:" >&2
  (cd firmware && cargo build -q --release -p nopanic --features find-panics) &&
    python3 tests/nopanic-report.py firmware/target/thumbv7em-none-eabihf/release/nopanic >&2
  exit 1
fi
echo "no panic path in the per-epoch path (nopanic links with panic-never)"
(cd firmware && cargo build -q --release)
bash tests/size-report.sh

phase "QEMU Cortex-M run of the real pipeline, and the same input on the host"
qemu_out=$(cd firmware && cargo run -q --release -p qemu-run)
echo "$qemu_out"
if [ "${CI:-}" = true ] && ! echo "$qemu_out" | grep -q '^input: REAL drive'; then
  echo "CI=true: the QEMU run must replay the real comma2k19 segment, not the simulated fallback" >&2; exit 1
fi
# The Cortex-M4 cost targets (deterministic instruction counts under -icount, so a hard check).
lstm_step=$(echo "$qemu_out" | sed -n 's/^instructions per LSTM step.* median \([0-9]*\) .*/\1/p')
epoch=$(echo "$qemu_out" | sed -n 's/^instructions per epoch: .* median \([0-9]*\) .*/\1/p')
# A car's next drive (started from a stored calibration) runs paths a first minute does not.
stored=$(echo "$qemu_out" | sed -n 's/^instructions per epoch (from a stored calibration): .* median \([0-9]*\) .*/\1/p')
if [ -z "$lstm_step" ] || [ -z "$epoch" ] || [ -z "$stored" ] || [ "$lstm_step" -gt 210000 ] || [ "$epoch" -gt 300000 ] || [ "$stored" -gt 300000 ]; then
  echo "Cortex-M4 cost targets: LSTM step '$lstm_step' (<= 210000), epoch median '$epoch' and from a stored calibration '$stored' (<= 300000)" >&2; exit 1
fi
echo "Cortex-M4 cost: LSTM step $lstm_step instructions (<= 210000), epoch median $epoch and from a stored calibration $stored (<= 300000)"
host_out=$(cargo run -q --release -p host-sim -- digest)
echo "$host_out" | tail -1
q=$(echo "$qemu_out" | grep '^verdict digest:')
h=$(echo "$host_out" | grep '^verdict digest:')
if [ -z "$q" ] || [ "$q" != "$h" ]; then
  echo "verdict streams differ between Cortex-M (QEMU) and host: '$q' vs '$h'" >&2; exit 1
fi
echo "Cortex-M and host verdict streams identical ($q)"

phase "detector-core's no_std example image in QEMU (its own CAN and GNSS sources)"
example_out=$(cd firmware && cargo run -q --release -p detector-core-cortex-m-example)
echo "$example_out"
echo "$example_out" | grep -qx 'core-example: PASS'

phase "the documentation's measured parts are this code's (eval --scenarios 100 --check-docs)"
data="${GNSS_DATA_DIR:-../shared/data}"
if [ -d "$data/drives" ]; then
  cargo run -q --release -p host-sim -- eval --data "$data" --scenarios 100 --out target/eval-docs --check-docs . | tail -1
elif [ "${CI:-}" = true ]; then
  echo "CI=true: $data/drives is missing; the documentation check needs the real drives" >&2; exit 1
else
  echo "SKIPPED the documentation check: real data not found at $data (set GNSS_DATA_DIR)"
fi
phase "all tests passed"
