"""Shared fixtures: the real data (../shared/data or $GNSS_DATA_DIR: skipped with the reason
printed when absent, a failure under CI=true), and `host-sim`, the command line the package must
agree with ($GNSS_GUARD_HOST_SIM, else target/release/host-sim; the test command builds it)."""

from __future__ import annotations

import json
import os
import subprocess
from pathlib import Path
from typing import Any, Dict, List, Tuple

import pytest

ROOT = Path(__file__).resolve().parents[2]


def _data_dir() -> Path:
    return Path(os.environ.get("GNSS_DATA_DIR") or ROOT.parent / "shared" / "data")


@pytest.fixture(scope="session")
def data() -> Path:
    d = _data_dir()
    if not (d / "drives").is_dir():
        reason = f"real data not found at {d} (set GNSS_DATA_DIR)"
        if os.environ.get("CI") == "true":
            pytest.fail(f"CI=true: {reason}")
        print(f"SKIPPED: {reason}")
        pytest.skip(reason)
    return d


def drive_csvs() -> List[Path]:
    """Every drive CSV of the data folder (empty without it; the `data` fixture then skips)."""
    return sorted((_data_dir() / "drives").glob("*/*.csv"))


def csv_ids() -> List[str]:
    return [p.stem for p in drive_csvs()] or ["no-data"]


def csv_params() -> List[Any]:
    return drive_csvs() or [None]


@pytest.fixture(scope="session")
def host_sim() -> Path:
    exe = Path(os.environ.get("GNSS_GUARD_HOST_SIM") or ROOT / "target" / "release" / "host-sim")
    if not exe.is_file():
        pytest.fail(f"{exe} not found: build it with `cargo build --release -p host-sim` (or set GNSS_GUARD_HOST_SIM)")
    return exe


def run(host_sim: Path, *args: str) -> subprocess.CompletedProcess:
    p = subprocess.run([str(host_sim), *args], capture_output=True, text=True)
    if p.returncode != 0:
        raise AssertionError(f"host-sim {' '.join(args)} failed: {p.stderr}")
    return p


def host_detect(host_sim: Path, *args: str) -> Tuple[List[Dict[str, Any]], Dict[str, Any]]:
    """`host-sim detect --json ARGS`: the per-epoch lines and the final summary line."""
    lines = [json.loads(line) for line in run(host_sim, "detect", "--json", *args).stdout.splitlines()]
    epochs = [x for x in lines if "epoch" in x]
    return epochs, lines[-1]
