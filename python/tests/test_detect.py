"""The package's verdicts are `host-sim detect`'s: every drive of the real data, digest for
digest and summary for summary, from a path, a pandas DataFrame and a pyarrow Table; the
verdict table equals `detect --out`'s; the car's calibration record carries across drives as
`detect --calibration` carries it."""

from __future__ import annotations

from pathlib import Path

import pandas as pd
import pyarrow.csv as pacsv
import pytest

import gnss_guard
from conftest import csv_ids, csv_params, drive_csvs, host_detect, run

REPO = Path(__file__).resolve().parents[2]


def same_summary(d: gnss_guard.Detection, host: dict, what: str) -> None:
    assert d.digest == host["digest"], f"{what}: digest {d.digest} against host-sim's {host['digest']}"
    for k, v in host["summary"].items():
        assert d.summary[k] == v, f"{what}: summary[{k!r}] {d.summary[k]!r} against host-sim's {v!r}"


@pytest.mark.parametrize("csv", csv_params(), ids=csv_ids())
def test_every_drive_csv_from_a_path_a_dataframe_and_a_table(data, host_sim, csv):
    _, host = host_detect(host_sim, str(csv))
    same_summary(gnss_guard.detect(csv, verdicts=False), host, f"{csv.name} (path)")
    same_summary(gnss_guard.detect(pd.read_csv(csv), verdicts=False), host, f"{csv.name} (pandas)")
    same_summary(gnss_guard.detect(pacsv.read_csv(csv), verdicts=False), host, f"{csv.name} (pyarrow)")


def test_the_raw_originals(data, host_sim):
    # The comma2k19 segment (NumPy arrays and its CAN frames) and the OpenXC trace, as published.
    for raw in [data / "raw/comma2k19_rav4_seg40", data / "raw/openxc_ford/drivingnew.jsonl"]:
        _, host = host_detect(host_sim, str(raw))
        same_summary(gnss_guard.detect(raw, verdicts=False), host, raw.name)
    # The CANedge's MF4 logs with GNSS on CAN, through the OBD-II and GNSS DBCs and the map.
    profiles = REPO / "firmware/board/profiles"
    dbc = [profiles / "obd2.dbc", data / "raw/css_canedge_mf4/gnss.dbc"]
    mapf = profiles / "css_canedge.map"
    for session in ["00000164", "00000165"]:
        can = data / "raw/css_canedge_mf4/3BA199E2" / session
        _, host = host_detect(host_sim, "--can", str(can), "--dbc", str(dbc[0]), "--dbc", str(dbc[1]), "--map", str(mapf))
        same_summary(gnss_guard.detect(can=can, dbc=dbc, map=mapf, verdicts=False), host, f"CANedge {session}")


def test_the_verdict_table_is_detect_outs(data, host_sim, tmp_path):
    for csv in [drive_csvs()[0], data / "drives/sddi_commuter/nl_20210215_072115.csv"]:
        out = tmp_path / f"{csv.stem}.parquet"
        epochs, host = host_detect(host_sim, str(csv), "--out", str(out))
        d = gnss_guard.detect(csv)
        pd.testing.assert_frame_equal(d.verdicts, pd.read_parquet(out))
        assert len(d.verdicts) == len(epochs) == host["summary"]["epochs"]
        assert d.verdicts["alarm"].tolist() == [e["alarm"] for e in epochs]
        assert d.verdicts["t"].tolist() == [e["t"] for e in epochs]


def test_the_calibration_record_carries_across_drives(data, host_sim, tmp_path):
    # The sddi car's five commutes in order: the record each drive leaves is the next one's
    # start, in the package as with detect --calibration FILE.
    record_file = tmp_path / "car.cal"
    record = None
    stored = 0
    for csv in sorted((data / "drives/sddi_commuter").glob("*.csv")):
        _, host = host_detect(host_sim, str(csv), "--calibration", str(record_file))
        d = gnss_guard.detect(csv, calibration=record, verdicts=False)
        same_summary(d, host, f"{csv.name} (calibrated)")
        if d.calibration is not None:
            record = d.calibration
            stored += 1
        assert record == (record_file.read_bytes() if record_file.exists() else None), csv.name
    assert stored > 0, "no drive of the sddi car left a calibration record"


def test_predictor_and_profile_options(data, host_sim):
    csv = data / "drives/openxc_ford/dearborn_2012-03-26_drivingnew.csv"
    _, host = host_detect(host_sim, str(csv), "--predictor", "kinematic", "--profile", "ublox-10hz")
    same_summary(gnss_guard.detect(csv, predictor="kinematic", profile="ublox-10hz", verdicts=False), host, "kinematic, ublox-10hz")
