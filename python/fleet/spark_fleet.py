#!/usr/bin/env python3
"""Judge a data lake of Parquet drives on Apache Spark: one summary row per drive, as Parquet.

    python python/fleet/spark_fleet.py LAKE OUT --master 'local[2]'       # this machine, 2 workers
    spark-submit python/fleet/spark_fleet.py s3a://lake/drives s3a://lake/gnss-guard   # a cluster

LAKE is a folder (or any Hadoop path: hdfs://, s3a://, abfss://) searched recursively for
``*.parquet`` files, each one drive in the common layout. Spark's ``binaryFile`` source reads each
file's bytes where it lies and hands them to ``gnss_guard.fleet.summarise`` through
``mapInArrow`` (Arrow batches, no pickling per row); the rows (``gnss_guard.fleet.SUMMARY``: alarm,
first alarm, time judged, per-strategy counts, digest, error) are written to OUT as Parquet.
Workers need the ``gnss-guard`` wheel installed (or shipped with ``--py-files``/an environment
archive); without ``--master`` the session takes spark-submit's (or the cluster's) settings, so
the script runs unchanged on a cluster. It prints one JSON line at the end: the drives, the
alarms, the errors, the drive-hours judged and the seconds the job took.
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import time

from pyspark.sql import SparkSession
from pyspark.sql import functions as F

from gnss_guard import fleet


def session(master: str | None, files_per_batch: int) -> SparkSession:
    # Local mode: the workers are this interpreter's Python (the one with gnss_guard installed).
    os.environ.setdefault("PYSPARK_PYTHON", sys.executable)
    b = SparkSession.builder.appName("gnss-guard fleet")
    if master:
        b = b.master(master)
    return (
        b.config("spark.sql.execution.arrow.maxRecordsPerBatch", str(files_per_batch))  # files per batch: bounds a worker's memory
        # A task's share of the lake: drive files are small (0.1 to 10 MB), and Spark's default
        # counts 4 MB per file opened, which makes a task of every few files (tasks cost ~50 ms).
        .config("spark.sql.files.maxPartitionBytes", "32m")
        .config("spark.sql.files.openCostInBytes", "64k")
        .config("spark.sql.sources.ignoreCorruptFiles", "false")
        .config("spark.ui.enabled", "false")
        .config("spark.ui.showConsoleProgress", "false")
        .getOrCreate()
    )


def run(spark: SparkSession, lake: str, out: str, partitions: int | None = None) -> dict:
    """Judges every ``*.parquet`` under ``lake``, writes the summary to ``out``; returns totals."""
    t0 = time.monotonic()
    files = (
        spark.read.format("binaryFile")
        .option("pathGlobFilter", "*.parquet")
        .option("recursiveFileLookup", "true")
        .load(lake)
        .select("path", "content")
    )
    if partitions:
        files = files.repartition(partitions)
    files.mapInArrow(fleet.summarise, fleet.spark_schema()).write.mode("overwrite").parquet(out)
    elapsed = time.monotonic() - t0
    totals = (
        spark.read.parquet(out)
        .agg(
            F.count("*").alias("drives"),
            F.sum(F.col("alarm").cast("int")).alias("alarms"),
            F.sum(F.col("error").isNotNull().cast("int")).alias("errors"),
            F.sum("judged_s").alias("judged_s"),
            F.sum("worker_s").alias("worker_s"),
            F.sum("read_s").alias("read_s"),
            F.sum("sync_s").alias("sync_s"),
            F.sum("detector_s").alias("detector_s"),
        )
        .first()
        .asDict()
    )
    totals["drive_hours"] = (totals.pop("judged_s") or 0.0) / 3600.0
    totals["job_s"] = elapsed
    return totals


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("lake", help="folder or Hadoop path searched recursively for *.parquet drives")
    ap.add_argument("out", help="where the summary table is written (Parquet, one row per drive; replaced)")
    ap.add_argument("--master", help="Spark master, e.g. local[2] (default: spark-submit's)")
    ap.add_argument("--files-per-batch", type=int, default=8, help="drive files per Arrow batch handed to a worker (default 8)")
    ap.add_argument("--partitions", type=int, help="repartition the file list (default: Spark's split of the files)")
    a = ap.parse_args()
    spark = session(a.master, a.files_per_batch)
    spark.sparkContext.setLogLevel("ERROR")
    try:
        totals = run(spark, a.lake, a.out, a.partitions)
    finally:
        spark.stop()
    print(json.dumps(totals))
    return 0


if __name__ == "__main__":
    sys.exit(main())
