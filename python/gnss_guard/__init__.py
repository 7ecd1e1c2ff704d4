"""gnss-guard for Python: GNSS spoofing detection by in-vehicle sensor fusion.

The same detector core as the command line (`host-sim`) and the firmware, through PyO3; nothing
is reimplemented here, so a drive gives the same verdicts, and the same digest, from Python as
from ``host-sim detect``.

A drive is a table in the common layout (the columns of ``../shared/data/drives``: ``t_s``,
``lat_deg``, ``lon_deg``, ``gnss_new_fix``, ... in SI units; see ``docs/evaluation.md``), given as
a pandas DataFrame or a pyarrow Table, or a path to any drive ``host-sim`` reads (CSV, Parquet,
comma2k19 segments, OpenXC traces, HDD sessions, logs folders), or one's own car's logs with
DBCs and a map. Errors about the input are :class:`InputError` (a :class:`ValueError`) naming
the file (``<table>`` for a table), the row or column, and what was expected.

>>> import gnss_guard
>>> d = gnss_guard.detect("drive.parquet")            # doctest: +SKIP
>>> d.summary["alarm"], d.digest, d.verdicts.shape     # doctest: +SKIP
"""

from __future__ import annotations

import io
import json
import os
from dataclasses import dataclass
from typing import Any, Dict, Optional, Sequence, Union

import pandas as pd
import pyarrow as pa
import pyarrow.parquet as pq

from ._gnss_guard import InputError
from . import _gnss_guard as _engine

__all__ = ["Detection", "InputError", "attack", "detect", "evaluate", "nuisance", "__version__"]
__version__: str = _engine.version()

Drive = Union[pd.DataFrame, pa.Table, str, "os.PathLike[str]"]


@dataclass
class Detection:
    """A drive judged.

    ``verdicts``: one row per epoch (time, alarm, the strategies that fired, ran and were
    degraded, the reason codes, and each strategy's numbers; the columns of
    ``host-sim detect --out``). ``summary``: epochs, the receiver profile, per strategy the
    epochs it fired, ran and was degraded, the alarm and its first epoch and time, the drive's
    duration and the seconds judged. ``digest``: the verdict digest ``host-sim detect`` and the
    firmware compute. ``calibration``: the car's calibration record this drive leaves (116 bytes;
    ``None`` when there is nothing to store), to pass to the car's next drive. ``timing``: the
    engine's wall-clock seconds reading and decoding the drive (``read_s``), synchronising it into
    the detector's samples (``sync_s``), in the detector core (``detector_s``) and writing the
    verdict table (``write_s``).
    """

    verdicts: pd.DataFrame
    summary: Dict[str, Any]
    digest: str
    calibration: Optional[bytes]
    timing: Dict[str, float]


def _parquet_bytes(table: Union[pd.DataFrame, pa.Table]) -> bytes:
    if isinstance(table, pd.DataFrame):
        table = pa.Table.from_pandas(table, preserve_index=False)
    if not isinstance(table, pa.Table):
        raise TypeError(f"expected a pandas DataFrame or a pyarrow Table, found {type(table).__name__}")
    buf = io.BytesIO()
    pq.write_table(table, buf, compression="none")
    return buf.getvalue()


def _frame(parquet: bytes) -> pd.DataFrame:
    return pq.read_table(io.BytesIO(parquet)).to_pandas()


def _detection(result: Any) -> Detection:
    table, summary, digest, record = result
    s = json.loads(summary)
    flat: Dict[str, Any] = dict(s["summary"])
    flat.update({k: s[k] for k in ("format", "duration_s", "judged_s")})
    return Detection(verdicts=_frame(table) if table else pd.DataFrame(), summary=flat, digest=digest, calibration=record, timing=s["timing"])


def detect(
    drive: Optional[Drive] = None,
    *,
    can: Optional[Union[str, "os.PathLike[str]"]] = None,
    gnss: Optional[Union[str, "os.PathLike[str]"]] = None,
    dbc: Optional[Sequence[Union[str, "os.PathLike[str]"]]] = None,
    map: Optional[Union[str, "os.PathLike[str]"]] = None,
    profile: Optional[str] = None,
    predictor: str = "lstm",
    calibration: Optional[bytes] = None,
    skip_bad_rows: bool = False,
    verdicts: bool = True,
) -> Detection:
    """Run the detector over one drive.

    ``drive``: a table in the common layout, or a path to a drive. Or one's own car's logs:
    ``can`` (candump, Vector ASC or BLF, an MF4 file or a folder of one session's MF4 files),
    ``dbc`` (one or more DBC files), ``map`` (the map file), and ``gnss`` (an NMEA or UBX log;
    omit it when the map reads GNSS on CAN). ``profile``: ``"ublox-10hz"`` or ``"logger-1hz"``
    (default: from the fix rate). ``predictor``: ``"lstm"`` (default) or ``"kinematic"``.
    ``calibration``: the car's stored record (``Detection.calibration`` of its previous drive).
    ``verdicts=False`` skips the per-epoch table (a fleet run needs only the summary).
    """
    if can is not None:
        if drive is not None:
            raise ValueError("give a drive, or can= with dbc= and map=, not both")
        if not dbc or map is None:
            raise ValueError("can= needs dbc= (one or more DBC files) and map=")
        return _detection(_engine.detect_logs(os.fspath(can), [os.fspath(d) for d in dbc], os.fspath(map), None if gnss is None else os.fspath(gnss), profile, predictor, calibration, skip_bad_rows, verdicts))
    if drive is None:
        raise ValueError("give a drive (a table or a path), or can= with dbc= and map=")
    if isinstance(drive, (str, os.PathLike)):
        return _detection(_engine.detect_path(os.fspath(drive), profile, predictor, calibration, skip_bad_rows, verdicts))
    return _detection(_engine.detect_table(_parquet_bytes(drive), "<table>", profile, predictor, calibration, skip_bad_rows, verdicts))


def _table_bytes(drive: Drive) -> bytes:
    if isinstance(drive, (str, os.PathLike)):
        path = os.fspath(drive)
        if path.endswith(".parquet"):
            with open(path, "rb") as f:
                return f.read()
        return _parquet_bytes(pd.read_csv(path))
    return _parquet_bytes(drive)


def attack(drive: Drive, kind: str, *, seed: int = 1, onset: Optional[float] = None, **params: Any) -> pd.DataFrame:
    """An attacked copy of a drive in the common layout, with ``attack_active`` (the ground truth
    per row) and the attack as applied in ``DataFrame.attrs["attack"]``.

    ``kind``: turn-by-turn, overshoot, stop, wrong-turn, slow-drift, small-biased, direction,
    replay, jump. ``onset``: seconds on the drive's clock (default: drawn from ``seed`` among
    the times where the kind makes sense). ``params`` fix what is otherwise drawn: ``offset_m``,
    ``bearing_deg``, ``speed_mps``, ``rate_mps``, ``across``, ``step_m``, ``deg_per_s``,
    ``delay_s``, ``right`` (as ``host-sim attack``'s options).
    """
    table, spec = _engine.attack_table(_table_bytes(drive), kind, seed, onset, json.dumps(params))
    df = _frame(table)
    df.attrs["attack"] = json.loads(spec)
    return df


def nuisance(drive: Drive, kind: str = "combined", *, seed: int = 1, **params: Any) -> pd.DataFrame:
    """A drive transformed as a new installation differs (not an attack), in the common layout;
    what was applied in ``DataFrame.attrs["nuisance"]``.

    ``kind``: delay, speed-course-1hz, wheel-speed, gyro, rate-switch, jitter, outage,
    vehicle-late, coarse-steering, gnss-noise, combined (drawn from ``seed``). ``params`` give
    the transformation instead: ``pos_delay_s``, ``vel_delay_s``, ``vel_1hz_lag_s``,
    ``wheel_scale``, ``gyro_bias_degps``, ``gyro_scale``, ``rate_switch_s``, ``jitter_s``,
    ``outages`` (a list of (start, length) seconds), ``vehicle_delay_s``, ``steering_step_deg``,
    ``gnss_noise`` (time constant s, standard deviation m).
    """
    table, what = _engine.nuisance_table(_table_bytes(drive), kind, seed, json.dumps(params))
    df = _frame(table)
    df.attrs["nuisance"] = what
    return df


def evaluate(
    data: Union[str, "os.PathLike[str]"],
    *,
    scenarios: int = 10,
    seed: int = 1,
    nuisance_variants: int = 8,
    protocol: str = "loso",
    predictor: str = "lstm",
    out: Optional[Union[str, "os.PathLike[str]"]] = None,
) -> Dict[str, Any]:
    """``host-sim eval`` on a data folder (with ``drives/``, or a folder of drives, one folder
    per source): the report as a dict (``report.json``'s contents); with ``out``, the report,
    its Markdown and figures written there too."""
    return json.loads(_engine.evaluate(os.fspath(data), scenarios, seed, nuisance_variants, protocol, predictor, None if out is None else os.fspath(out)))
