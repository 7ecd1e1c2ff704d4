#!/usr/bin/env python3
"""Writes the drive_parquet fuzz seeds (tests/fuzz/seeds/drive_parquet/): small synthetic drives
(40 rows, no real data) in the common layout, written by pyarrow the ways a lake's writers do:
float64 and float32 and integer columns, booleans, nulls, dictionary and plain encoding, snappy
and uncompressed, one and several row groups, data pages v1 and v2, and an extra column.
Needs pyarrow (python3 -m pip install pyarrow, in a venv)."""
import os
import random

import pyarrow as pa
import pyarrow.parquet as pq

random.seed(1)
out = os.path.join(os.path.dirname(os.path.abspath(__file__)), "seeds", "drive_parquet")
os.makedirs(out, exist_ok=True)
n = 40
t = [k * 0.1 for k in range(n)]
new_fix = [1 if k % 10 == 0 else 0 for k in range(n)]
lat, lon = [], []
la, lo = 48.137, 11.575
for k in range(n):
    if new_fix[k]:
        la += 0.00008
        lo += 0.00003
    lat.append(la)
    lon.append(lo)
cols = {
    "t_s": t,
    "unix_time_s": [1600000000 + x for x in t],
    "lat_deg": lat,
    "lon_deg": lon,
    "gnss_new_fix": new_fix,
    "gnss_fix_age_s": [(k % 10) * 0.1 for k in range(n)],
    "gnss_speed_mps": [9.0] * n,
    "gnss_course_deg": [23.0] * n,
    "veh_speed_mps": [9.0 + random.random() * 0.1 for _ in range(n)],
    "steer_wheel_deg": [random.uniform(-5, 5) for _ in range(n)],
    "accel_pedal_pct": [20.0] * n,
    "long_accel_mps2": [0.1] * n,
    "yaw_rate_degps": [0.0] * n,
}
full = pa.table(cols)
pq.write_table(full, f"{out}/float64_snappy.parquet", compression="snappy")
pq.write_table(full, f"{out}/float64_plain_v2.parquet", compression="none", use_dictionary=False, data_page_version="2.0")
pq.write_table(full, f"{out}/row_groups.parquet", compression="none", row_group_size=16)
narrow = pa.table({
    "t_s": pa.array(t, pa.float32()),
    "lat_deg": lat,
    "lon_deg": lon,
    "gnss_new_fix": pa.array([bool(x) for x in new_fix]),
    "veh_speed_mps": pa.array([None if k % 7 == 3 else int(9 + k % 2) for k in range(n)], pa.int16()),
    "yaw_rate_degps": pa.array([float("nan") if k % 5 == 0 else 0.5 for k in range(n)], pa.float32()),
    "driver": pa.array(["x"] * n),
})
pq.write_table(narrow, f"{out}/types_nulls_extra.parquet", compression="none")
minimal = pa.table({"t_s": [0.0, 1.0], "lat_deg": [48.0, 48.0001], "lon_deg": [11.0, 11.0], "gnss_new_fix": pa.array([1, 1], pa.int8()), "veh_speed_mps": [1.0, None]})
pq.write_table(minimal, f"{out}/minimal.parquet", compression="none", use_dictionary=False)
for f in sorted(os.listdir(out)):
    print(f, os.path.getsize(os.path.join(out, f)))
