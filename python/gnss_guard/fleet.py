"""A data lake of drives judged on a distributed engine: one summary row per drive.

The engine (Spark, Ray, Dask, a process pool) reads the files wherever they are (a folder, HDFS,
S3) and hands them over as Arrow record batches with a ``path`` and a ``content`` column (the
file's bytes: Spark's ``binaryFile`` source; Ray's ``read_binary_files(include_paths=True)``
names it ``bytes``, also taken);
:func:`summarise` is the map function, and yields record batches of :data:`SUMMARY` rows. The
workers need this package and nothing else: no shared file system, no scheduler of ours.

A drive file is a Parquet table in the common layout (``host-sim detect`` on the same file gives
the same verdicts and digest). A file that cannot be judged (not Parquet, a missing column, a bad
row) gives a row with ``error`` set (the reader's message: file, row or column, what was
expected) and the numbers null: a fleet run loses no drive silently and stops for none.

``python/fleet/spark_fleet.py`` runs this on Spark; see ``docs/fleet.md``.
"""

from __future__ import annotations

import json
import time
from typing import Any, Dict, Iterable, Iterator, List

import pyarrow as pa

from . import _gnss_guard as _engine

__all__ = ["STRATEGIES", "SUMMARY", "spark_schema", "summarise", "summarise_file"]

#: The detector's strategies, in the order of the summary's columns.
STRATEGIES = ("location_shift", "turn", "motion", "track")

#: One row per drive file. ``epochs`` to ``digest`` are ``host-sim detect --json``'s summary line
#: (``fired_*``: epochs a strategy fired, ``ran_*``: epochs it judged, ``degraded_*``: epochs it was
#: degraded; ``judged_s``: the seconds of the drive the detector judged). The last four are
#: wall-clock seconds on the worker: reading and decoding the Parquet file (``read_s``),
#: synchronising it into the detector's samples (``sync_s``), in the detector core
#: (``detector_s``), and the whole row (``worker_s``: the three, the summary and the row itself).
SUMMARY = pa.schema(
    [
        ("path", pa.string()),
        ("bytes", pa.int64()),
        ("format", pa.string()),
        ("profile", pa.string()),
        ("epochs", pa.int64()),
        ("duration_s", pa.float64()),
        ("judged_s", pa.float64()),
        ("alarm", pa.bool_()),
        ("first_alarm_epoch", pa.int64()),
        ("first_alarm_t", pa.float64()),
    ]
    + [(f"{what}_{s}", pa.int64()) for what in ("fired", "ran", "degraded") for s in STRATEGIES]
    + [
        ("digest", pa.string()),
        ("error", pa.string()),
        ("read_s", pa.float64()),
        ("sync_s", pa.float64()),
        ("detector_s", pa.float64()),
        ("worker_s", pa.float64()),
    ]
)

_SPARK_TYPES = {pa.string(): "string", pa.int64(): "bigint", pa.float64(): "double", pa.bool_(): "boolean"}


def spark_schema() -> str:
    """:data:`SUMMARY` as a Spark DDL string (``mapInArrow``'s output schema)."""
    return ", ".join(f"{f.name} {_SPARK_TYPES[f.type]}" for f in SUMMARY)


def summarise_file(path: str, content: bytes) -> Dict[str, Any]:
    """One drive file's summary row (a dict with :data:`SUMMARY`'s columns)."""
    t0 = time.perf_counter()
    row: Dict[str, Any] = {f.name: None for f in SUMMARY}
    row["path"] = path
    row["bytes"] = len(content)
    try:
        _table, summary, digest, _record = _engine.detect_table(content, name=path, verdicts=False)
    except ValueError as e:  # InputError (the drive) or ValueError (the engine's options)
        row["error"] = str(e)
        row["worker_s"] = time.perf_counter() - t0
        return row
    s = json.loads(summary)
    sm = s["summary"]
    row.update(
        format=s["format"],
        profile=sm["profile"],
        epochs=sm["epochs"],
        duration_s=s["duration_s"],
        judged_s=s["judged_s"],
        alarm=sm["alarm"],
        first_alarm_epoch=sm["first_alarm_epoch"],
        first_alarm_t=sm["first_alarm_t"],
        digest=digest,
    )
    row.update({k: s["timing"][k] for k in ("read_s", "sync_s", "detector_s")})
    for what in ("fired", "ran", "degraded"):
        for strategy in STRATEGIES:
            row[f"{what}_{strategy}"] = sm[what][strategy]
    row["worker_s"] = time.perf_counter() - t0
    return row


def summarise(batches: Iterable[pa.RecordBatch]) -> Iterator[pa.RecordBatch]:
    """The map function: record batches of files (``path``, and ``content`` or ``bytes``) in,
    record batches of :data:`SUMMARY` rows out, one per file, in the input's order."""
    for batch in batches:
        paths = batch.column("path").to_pylist()
        # Spark's binaryFile names the bytes `content`, Ray's read_binary_files `bytes`.
        contents = batch.column("content" if "content" in batch.schema.names else "bytes")
        rows: List[Dict[str, Any]] = [summarise_file(p, contents[i].as_py()) for i, p in enumerate(paths)]
        yield pa.RecordBatch.from_pylist(rows, schema=SUMMARY)
