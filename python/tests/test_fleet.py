"""The fleet script on Spark (local mode, 2 workers) over a lake made from the real drives (each
clean drive as Parquet and five nuisance variants of it: 210 drive files, plus one file that is
not a drive) gives, per drive, what `host-sim detect` gives on the same file."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import pandas as pd
import pyarrow.parquet as pq
import pytest

import gnss_guard
from gnss_guard import fleet
from conftest import drive_csvs, host_detect

SCRIPT = Path(__file__).resolve().parents[1] / "fleet" / "spark_fleet.py"
VARIANTS = 5


@pytest.fixture(scope="module")
def lake(data, tmp_path_factory) -> Path:
    root = tmp_path_factory.mktemp("lake")
    for csv in drive_csvs():
        folder = root / csv.parent.name
        (folder / "nuisance").mkdir(parents=True, exist_ok=True)
        drive = pd.read_csv(csv)
        drive.to_parquet(folder / f"{csv.stem}.parquet", index=False)
        for seed in range(1, VARIANTS + 1):
            gnss_guard.nuisance(drive, "combined", seed=seed).to_parquet(folder / "nuisance" / f"{csv.stem}-combined-{seed}.parquet", index=False)
    (root / "broken.parquet").write_bytes(b"PAR1 not a drive")
    return root


def test_spark_fleet_gives_host_sims_results(lake, host_sim, tmp_path):
    files = sorted(lake.rglob("*.parquet"))
    assert len(files) >= 201, f"the lake holds {len(files)} files"
    out = tmp_path / "summary"
    p = subprocess.run([sys.executable, str(SCRIPT), str(lake), str(out), "--master", "local[2]"], capture_output=True, text=True)
    assert p.returncode == 0, p.stderr[-3000:]
    totals = json.loads(p.stdout.strip().splitlines()[-1])
    table = pq.read_table(out)
    assert table.schema.names == fleet.SUMMARY.names
    rows = table.to_pylist()
    assert len(rows) == len(files) == totals["drives"], "one row per file"
    by_path = {Path(r["path"].removeprefix("file:")): r for r in rows}
    assert set(by_path) == set(files)
    broken = by_path.pop(lake / "broken.parquet")
    assert "broken.parquet: not a readable Parquet file" in broken["error"] and broken["digest"] is None
    assert totals["errors"] == 1
    alarms = 0
    for f, r in sorted(by_path.items()):
        _, host = host_detect(host_sim, str(f))
        s = host["summary"]
        assert r["error"] is None, f"{f}: {r['error']}"
        assert r["digest"] == host["digest"], f"{f}: digest {r['digest']} against host-sim's {host['digest']}"
        for k in ("profile", "epochs", "alarm", "first_alarm_epoch", "first_alarm_t"):
            assert r[k] == s[k], f"{f}: {k} {r[k]!r} against host-sim's {s[k]!r}"
        assert r["format"] == "drive-parquet"
        for what in ("fired", "ran", "degraded"):
            for strategy in fleet.STRATEGIES:
                assert r[f"{what}_{strategy}"] == s[what][strategy], f"{f}: {what} {strategy}"
        alarms += r["alarm"]
    assert totals["alarms"] == alarms
    print(f"{len(by_path)} drive files ({totals['drive_hours']:.1f} drive-hours): Spark's rows = host-sim detect's; {alarms} with an alarm; the broken file reported")


def test_summarise_takes_spark_and_ray_batches(data, tmp_path):
    import pyarrow as pa

    csv = data / "drives/openxc_ford/dearborn_2012-03-26_drivingnew.csv"
    good = tmp_path / "good.parquet"
    pd.read_csv(csv).to_parquet(good, index=False)
    paths = [str(good), "garbage.parquet"]
    contents = [good.read_bytes(), b"garbage"]
    for column in ("content", "bytes"):  # Spark's binaryFile, Ray's read_binary_files
        batch = pa.RecordBatch.from_pydict({"path": paths, column: pa.array(contents, pa.binary())})
        (out,) = list(fleet.summarise([batch]))
        assert out.schema == fleet.SUMMARY
        rows = out.to_pylist()
        assert rows[0]["digest"] == gnss_guard.detect(csv, verdicts=False).digest and rows[0]["error"] is None
        assert rows[1]["error"].startswith("garbage.parquet: not a readable Parquet file") and rows[1]["epochs"] is None
