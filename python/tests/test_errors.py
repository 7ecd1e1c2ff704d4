"""Bad input is a Python exception naming the file (or `<table>`), the row or column, and what
was expected; nothing is judged from a half-read drive."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pyarrow as pa
import pytest

import gnss_guard
from gnss_guard import InputError

DRIVE = "drives/openxc_ford/dearborn_2012-03-26_drivingnew.csv"


@pytest.fixture
def drive(data) -> pd.DataFrame:
    return pd.read_csv(data / DRIVE)


def test_a_missing_column_is_named(drive):
    with pytest.raises(InputError, match=r"<table>: missing column `lat_deg`"):
        gnss_guard.detect(drive.drop(columns=["lat_deg"]))


def test_a_column_of_text_is_named_with_its_type(drive):
    bad = drive.assign(veh_speed_mps=drive["veh_speed_mps"].astype(str))
    with pytest.raises(InputError, match=r"column `veh_speed_mps`: expected numbers, found the type (Utf8|LargeUtf8|Utf8View)"):
        gnss_guard.detect(bad)


def test_a_bad_row_is_named_and_can_be_skipped(drive):
    bad = drive.copy()
    bad.loc[120, "t_s"] = bad.loc[100, "t_s"]  # time going backwards
    with pytest.raises(InputError, match=r"<table>: row 120: "):
        gnss_guard.detect(bad)
    nan_time = drive.copy()
    nan_time.loc[7, "t_s"] = np.nan
    with pytest.raises(InputError, match=r"row 7: "):
        gnss_guard.detect(pa.Table.from_pandas(nan_time, preserve_index=False))
    # skip_bad_rows counts and drops them, as host-sim's --skip-bad-rows.
    assert gnss_guard.detect(bad, skip_bad_rows=True, verdicts=False).summary["epochs"] > 0


def test_files_that_are_not_drives(tmp_path):
    not_parquet = tmp_path / "drive.parquet"
    not_parquet.write_text("t_s,lat_deg\n")
    with pytest.raises(InputError, match=r"drive\.parquet: not a readable Parquet file"):
        gnss_guard.detect(not_parquet)
    with pytest.raises(InputError, match=r"nothing\.csv"):
        gnss_guard.detect(tmp_path / "nothing.csv")


def test_options_and_types():
    with pytest.raises(TypeError, match="expected a pandas DataFrame or a pyarrow Table, found list"):
        gnss_guard.detect([1, 2, 3])  # type: ignore[arg-type]
    with pytest.raises(ValueError, match="predictor: expected 'lstm' or 'kinematic'"):
        gnss_guard.detect(pd.DataFrame({"t_s": [0.0]}), predictor="lstm-f32")
    with pytest.raises(ValueError, match="can= needs dbc="):
        gnss_guard.detect(can="can.log")
    with pytest.raises(ValueError, match="calibration: not a valid record"):
        gnss_guard.detect(pd.DataFrame({"t_s": [0.0]}), calibration=b"\x00" * 5)
