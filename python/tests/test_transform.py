"""attack and nuisance in the package write what `host-sim attack` and `host-sim nuisance` write
(the same table, the same ground truth), and the attacked drive's verdicts are host-sim's."""

from __future__ import annotations

import pandas as pd
import pytest

import gnss_guard
from conftest import host_detect, run

DRIVE = "drives/openxc_ford/dearborn_2012-03-26_drivingnew.csv"


@pytest.mark.parametrize("kind", ["turn-by-turn", "overshoot", "stop", "slow-drift", "replay"])
def test_attack_is_host_sims(data, host_sim, tmp_path, kind):
    out = tmp_path / f"{kind}.parquet"
    run(host_sim, "attack", str(data / DRIVE), "--kind", kind, "--seed", "3", "-o", str(out))
    ours = gnss_guard.attack(pd.read_csv(data / DRIVE), kind, seed=3)
    pd.testing.assert_frame_equal(ours, pd.read_parquet(out), check_like=False)
    assert ours["attack_active"].any(), f"{kind}: no row attacked"
    assert ours.attrs["attack"]["onset_t"] >= 0
    _, host = host_detect(host_sim, str(out))
    assert gnss_guard.detect(ours, verdicts=False).digest == host["digest"]


def test_attack_parameters(data, host_sim, tmp_path):
    out = tmp_path / "drift.parquet"
    run(host_sim, "attack", str(data / DRIVE), "--kind", "slow-drift", "--seed", "2", "--rate-mps", "0.7", "--onset", "40", "-o", str(out))
    ours = gnss_guard.attack(data / DRIVE, "slow-drift", seed=2, onset=40.0, rate_mps=0.7)
    pd.testing.assert_frame_equal(ours, pd.read_parquet(out))
    with pytest.raises(ValueError, match="rate_mph"):
        gnss_guard.attack(data / DRIVE, "slow-drift", rate_mph=1.0)
    with pytest.raises(ValueError, match="kind: expected one of"):
        gnss_guard.attack(data / DRIVE, "teleport")


@pytest.mark.parametrize("kind,seed", [("combined", 1), ("combined", 7), ("vehicle-late", 2), ("coarse-steering", 1)])
def test_nuisance_is_host_sims(data, host_sim, tmp_path, kind, seed):
    out = tmp_path / f"{kind}-{seed}.parquet"
    run(host_sim, "nuisance", str(data / DRIVE), "--kind", kind, "--seed", str(seed), "-o", str(out))
    ours = gnss_guard.nuisance(pd.read_csv(data / DRIVE), kind, seed=seed)
    pd.testing.assert_frame_equal(ours, pd.read_parquet(out))
    _, host = host_detect(host_sim, str(out))
    assert gnss_guard.detect(ours, verdicts=False).digest == host["digest"]
