#!/usr/bin/env bash
# Speed of strategy 2's classifier against the Python `fastdtw` package, side by side in one run:
# the same held-out turn queries, the same templates, 1-NN. Prints a last line `speedup: <x>`.
# Installs fastdtw into a private venv (PyPI) on first use. Needs ../shared/data (or GNSS_DATA_DIR).
set -euo pipefail
cd "$(dirname "$0")/../.."
venv="${FASTDTW_VENV:-target/fastdtw-venv}"
if [ ! -x "$venv/bin/python" ] || ! "$venv/bin/python" -c "import fastdtw" 2>/dev/null; then
  python3 -m venv "$venv"
  "$venv/bin/pip" install -q fastdtw
fi
export_file="target/dtw-bench.json"
cargo run -q --release -p host-sim -- dtw-bench --export "$export_file" | tee target/dtw-bench.txt
rust_us=$(awk '/^rust_us_per_query:/ {print $2}' target/dtw-bench.txt)
"$venv/bin/python" - "$export_file" "$rust_us" <<'PY'
import json, sys, time
from fastdtw import fastdtw
d = json.load(open(sys.argv[1]))
rust_us = float(sys.argv[2])
T, Q = d["templates"], d["queries"]
dist = lambda a, b: abs(a - b)
t0 = time.perf_counter()
for q in Q:
    best = min(fastdtw(q, t, radius=1, dist=dist)[0] for t in T)
py_us = (time.perf_counter() - t0) * 1e6 / len(Q)
print(f"queries {len(Q)} templates {len(T)}")
print(f"fastdtw_us_per_query: {py_us:.1f} (Python fastdtw, radius 1)")
print(f"rust_us_per_query: {rust_us:.2f} (exact banded DTW + LB_Keogh + early abandoning)")
print(f"speedup: {py_us / rust_us:.0f}")
PY
