#!/usr/bin/env bash
# The nuisance suite at other draws: `bash tests/seed-sweep.sh FIRST LAST [JOBS]` runs
# `host-sim eval --data $GNSS_DATA_DIR --scenarios 2 --seed N` for every seed from FIRST to LAST
# (JOBS at a time, default 2; the suite's 880 runs per seed do not depend on --scenarios), then
# prints every false alarm (seed, nuisance kind, drive and draw, what fired) and the total with
# its judged hours and Poisson 95 % upper bound. Run by hand (about 10 min for 40 seeds on two
# cores), not by the test command; docs/evaluation.md ("Other draws") records its results.
# Reports go to $SWEEP_OUT (default target/seed-sweep/sN). BIN=path runs that host-sim binary
# instead of building this tree's (two versions side by side: copy the older build aside first).
set -euo pipefail
cd "$(dirname "$0")/.."
[ $# -ge 2 ] || { echo "usage: bash tests/seed-sweep.sh FIRST LAST [JOBS]" >&2; exit 2; }
first=$1 last=$2 jobs=${3:-2}
data=${GNSS_DATA_DIR:-../shared/data}
out=${SWEEP_OUT:-target/seed-sweep}
[ -d "$data/drives" ] || { echo "no drives under $data (set GNSS_DATA_DIR)" >&2; exit 1; }
[ -n "${BIN:-}" ] || cargo build -q --release -p host-sim
bin=${BIN:-target/release/host-sim}
[ -x "$bin" ] || { echo "no host-sim binary at $bin" >&2; exit 1; }
mkdir -p "$out"
for s in $(seq "$first" "$last"); do rm -rf "$out/s$s"; done
export bin data out
seq "$first" "$last" | xargs -P "$jobs" -I{} sh -c \
  '"$bin" eval --data "$data" --scenarios 2 --seed {} --out "$out/s{}" > "$out/s{}.log" 2>&1 || echo "seed {}: eval failed, see $out/s{}.log" >&2'
python3 - "$out" "$first" "$last" <<'EOF'
import json, math, os, sys
out, first, last = sys.argv[1], int(sys.argv[2]), int(sys.argv[3])

def upper95(k):
    # Poisson, one-sided (as `upper95_per_hour`): the mean whose P(X <= k) is 5 %, by bisection.
    def cdf(mu):
        return sum(math.exp(-mu + i * math.log(mu) - math.lgamma(i + 1)) for i in range(k + 1)) if mu > 0 else 1.0
    lo, hi = 0.0, 10.0 * (k + 3)
    for _ in range(100):
        mid = 0.5 * (lo + hi)
        lo, hi = (mid, hi) if cdf(mid) > 0.05 else (lo, mid)
    return hi

total, hours, draws, missing = 0, 0.0, 0, []
for s in range(first, last + 1):
    path = os.path.join(out, f"s{s}", "report.json")
    if not os.path.exists(path):
        missing.append(s)
        continue
    r = json.load(open(path))
    draws += 1
    hours += r["nuisance_total"]["hours"]
    total += r["nuisance_total"]["false_alarms"]
    for kind, v in sorted(r["nuisance"].items()):
        for run in v.get("false_alarm_runs", []):
            print(f"seed {s} {kind}: {run}; fired {v.get('fired_reasons')}")
    clean = r["clean"].get("false_alarms") or 0
    pre = sum(x.get("pre_onset_alarms", 0) for x in r["scenarios"])
    if clean or pre:
        print(f"seed {s}: clean drives {clean} false alarms, {pre} alarms before an onset")
print(f"seeds {first} to {last}: {total} false alarms in {draws} draws, {hours:.0f} judged hours, "
      f"upper 95 % {upper95(total) / max(hours, 1e-9):.5f} per hour")
if missing:
    print(f"no report for seeds {missing}", file=sys.stderr)
    sys.exit(1)
EOF
