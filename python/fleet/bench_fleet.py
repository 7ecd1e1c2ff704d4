#!/usr/bin/env python3
"""Throughput of a fleet run: drive-hours judged per core-hour, from Parquet, on 10 Hz drives.

    target/pyvenv/bin/python python/fleet/bench_fleet.py --data ../shared/data

A benchmark, run by hand (not a test). It builds a lake of 10 Hz drives (the real drives whose
GNSS gives 5 fixes a second or more: comma2k19's RAV4 minute and Udacity's CH2; each clean, and
variants of each under the nuisances and attacks that keep the fix rate, each variant one file),
then judges it three ways and prints one table:

1. in one Python process, one core, file after file (``gnss_guard.fleet.summarise_file``): what
   the package costs per drive, split into reading (Parquet decoding), synchronisation, the
   detector core and the rest (the summary, the row, Python);
2. on Spark in local mode with 1 worker, then with 2 (``spark_fleet.run``, the fleet script's
   job: listing, reading the files' bytes, ``mapInArrow``, writing the summary as Parquet), by
   the job's wall-clock time times the workers. Timed apart, as costs paid once per fleet run
   and not per drive: the session's start (the JVM) and a first job on 16 of the files (the
   Python workers' start, the JVM's warm-up; ~4 s here).

The detector's own bound is the drive-hours one core judges when it does nothing but the
detector core (``detector_s`` summed): no run of the package can beat it. The machine's cores
must be idle for the Spark rows to mean anything; the script prints ``os.cpu_count()`` and the
load average at its start.
"""

from __future__ import annotations

import argparse
import csv
import json
import os
import shutil
import sys
import time
from pathlib import Path

import pandas as pd

import gnss_guard
from gnss_guard import fleet

sys.path.insert(0, str(Path(__file__).resolve().parent))
import spark_fleet  # noqa: E402

# Transformations that keep a drive's fix rate (rate-switch and the 1 Hz velocity lag do not).
NUISANCES = ["delay", "vehicle-late", "wheel-speed", "gyro", "jitter", "gnss-noise", "coarse-steering", "outage"]
ATTACKS = ["turn-by-turn", "overshoot", "stop", "slow-drift", "small-biased", "direction", "replay", "jump"]


def ten_hz_drives(data: Path, source: str | None) -> list[Path]:
    with open(data / "index.csv") as f:
        return [data / r["file"] for r in csv.DictReader(f) if float(r["gnss_fix_rate_hz"]) >= 5.0 and (source is None or r["source"] == source)]


def build_lake(data: Path, lake: Path, files: int, source: str | None) -> None:
    stamp = lake / "LAKE.json"
    if stamp.exists() and json.loads(stamp.read_text()).get("files") == files:
        return
    shutil.rmtree(lake, ignore_errors=True)
    lake.mkdir(parents=True)
    drives = [(p.stem, pd.read_csv(p)) for p in ten_hz_drives(data, source)]
    if not drives:
        raise SystemExit(f"no drive of 5 fixes a second or more in {data / 'index.csv'}" + (f" from {source}" if source else ""))
    n = 0
    seed = 0
    while n < files:
        for name, d in drives:
            if n >= files:
                break
            k = seed % (1 + len(NUISANCES) + len(ATTACKS))
            s = seed // (1 + len(NUISANCES) + len(ATTACKS)) + 1
            if k == 0:
                v, what = d, "clean"
            elif k <= len(NUISANCES):
                what = NUISANCES[k - 1]
                v = gnss_guard.nuisance(d, what, seed=s)
            else:
                what = ATTACKS[k - 1 - len(NUISANCES)]
                try:
                    v = gnss_guard.attack(d, what, seed=s).drop(columns=["attack_active"])
                except gnss_guard.InputError:  # a kind this drive cannot host (no stop to attack, ...)
                    continue
            v.to_parquet(lake / f"{name}-{what}-{s}-{n:05}.parquet", index=False)
            n += 1
        seed += 1
    stamp.write_text(json.dumps({"files": files, "drives": [n for n, _ in drives]}))


def in_process(lake: Path) -> dict:
    t = {"files": 0, "epochs": 0, "judged_s": 0.0, "read_s": 0.0, "sync_s": 0.0, "detector_s": 0.0, "worker_s": 0.0, "file_read_s": 0.0}
    cpu0 = time.process_time()
    for p in sorted(lake.glob("*.parquet")):
        t0 = time.perf_counter()
        content = p.read_bytes()
        t["file_read_s"] += time.perf_counter() - t0
        row = fleet.summarise_file(str(p), content)
        if row["error"]:
            raise SystemExit(f"{p}: {row['error']}")
        t["files"] += 1
        for k in ("epochs", "judged_s", "read_s", "sync_s", "detector_s", "worker_s"):
            t[k] += row[k]
    t["cpu_s"] = time.process_time() - cpu0
    return t


def per_core_hour(drive_hours: float, core_s: float) -> float:
    return drive_hours / (core_s / 3600.0)


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--data", default=os.environ.get("GNSS_DATA_DIR", "../shared/data"))
    ap.add_argument("--lake", default="target/fleet-bench/lake", help="where the 10 Hz lake is built (kept for the next run)")
    ap.add_argument("--files", type=int, default=2400, help="drive files in the lake (default 2400)")
    ap.add_argument("--workers", type=int, nargs="+", default=[1, 2])
    ap.add_argument("--source", help="only the 10 Hz drives of this source (index.csv's `source`: comma2k19, udacity_ch2)")
    a = ap.parse_args()
    data, lake = Path(a.data), Path(a.lake + (f"-{a.source}" if a.source else ""))
    print(f"cores {os.cpu_count()}, load average {os.getloadavg()}, gnss_guard {gnss_guard.__version__}", flush=True)
    build_lake(data, lake, a.files, a.source)

    t = in_process(lake)
    dh = t["judged_s"] / 3600.0
    rows = [
        ("detector core only (the bound)", 1, t["detector_s"]),
        ("package, one process, file after file", 1, t["file_read_s"] + t["worker_s"]),
    ]
    outside = {
        "reading and decoding Parquet": t["read_s"] + t["file_read_s"],
        "synchronisation": t["sync_s"],
        "summary, row, Python": t["worker_s"] - t["read_s"] - t["sync_s"] - t["detector_s"],
    }
    spark_runs = []
    warmup = lake.parent / "warmup"
    shutil.rmtree(warmup, ignore_errors=True)
    warmup.mkdir()
    for p in sorted(lake.glob("*.parquet"))[:16]:
        shutil.copy(p, warmup / p.name)
    for w in a.workers:
        t0 = time.monotonic()
        spark = spark_fleet.session(f"local[{w}]", 8)
        spark.sparkContext.setLogLevel("ERROR")
        start_s = time.monotonic() - t0
        try:
            # A first job pays once for the Python workers' start and the JVM's warm-up: timed
            # apart, on a few of the lake's files.
            warm = spark_fleet.run(spark, str(warmup), str(lake.parent / f"summary-warmup-{w}"))
            totals = spark_fleet.run(spark, str(lake), str(lake.parent / f"summary-{lake.name}-{w}"))
        finally:
            spark.stop()
        if totals["errors"]:
            raise SystemExit(f"Spark local[{w}]: {totals['errors']} files failed")
        rows.append((f"Spark local[{w}], the fleet script's job", w, totals["job_s"] * w))
        spark_runs.append({"workers": w, "session_start_s": start_s, "warmup_job_s": warm["job_s"], **totals})

    print(f"\nlake {lake}: {t['files']} Parquet drive files, {dh:.1f} drive-hours judged, {t['epochs']:,} epochs ({t['epochs'] / dh:,.0f} per drive-hour)")
    print(f"detector core: {t['detector_s'] / t['epochs'] * 1e6:.2f} us per epoch\n")
    print("| run | workers | core-seconds | drive-hours per core-hour |")
    print("|---|---|---|---|")
    for name, w, core_s in rows:
        print(f"| {name} | {w} | {core_s:.1f} | {per_core_hour(dh, core_s):,.0f} |")
    print("\ntime outside the detector core, one process (share of the package's core-seconds):")
    total = t["file_read_s"] + t["worker_s"]
    for k, v in outside.items():
        print(f"  {k}: {v:.2f} s ({100 * v / total:.0f} %)")
    for r in spark_runs:
        print(f"Spark local[{r['workers']}]: job {r['job_s']:.1f} s wall for {r['drive_hours']:.1f} drive-hours ({r['drive_hours'] / (r['job_s'] / 3600):,.0f} drive-hours per wall-clock hour); "
              f"workers' rows {r['worker_s']:.1f} s, of which detector core {r['detector_s']:.1f} s; apart: the session's start {r['session_start_s']:.1f} s, a first job on 16 files {r['warmup_job_s']:.1f} s")
    out = lake.parent / f"bench-{lake.name}.json"
    out.write_text(json.dumps({"in_process": t, "spark": spark_runs}, indent=1))
    print(f"\nwritten {out}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
