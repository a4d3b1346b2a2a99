"""`attitude-faults` (clients/python/src/attitude_client/faults.py, docs/faults.md) on a committed BROAD excerpt:
the command starts the real binary itself and sends through the real zenoh link; every case it injects must be
accounted for by the service's own counts, the recovered cases must give the undisturbed estimates bit for bit,
and the lossy ones must stay honest and beat VQF fed the same samples.

Data: an excerpt of BROAD trial 16 committed in tests/data/broad (Laidig, Caruso, Cereatti, Seel, Data 6(7), 2021,
doi:10.3390/data6070072), CC-BY-4.0.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys

import json5
import pytest

from conftest import BIN, ROOT

TRIAL = ROOT / "tests" / "data" / "broad" / "16_undisturbed_fast_translation_B_excerpt.hdf5"
CASES = ["none", "loss-1%", "burst-1s", "duplicates", "reorder-within", "reorder-beyond", "cut-cache",
         "cut-small-cache", "cut-plain", "restart"]
LOSSY = ["loss-1%", "burst-1s", "reorder-beyond"]


@pytest.fixture(scope="module")
def study(tmp_path_factory):
    if not TRIAL.exists():
        pytest.fail(f"{TRIAL} is missing (committed with the repository)")
    if not BIN.exists():
        pytest.fail(f"{BIN} does not exist: build it (cargo build --release) or run scripts/python-tests.sh")
    env = dict(os.environ, ATTITUDE_SERVICE_BIN=str(BIN))
    # The preset with BROAD's magnetometer taken as calibrated in place (it is): on this excerpt (a translation) no
    # rotation ever confirms the field, and the preset's allowance for an unknown offset would keep the published
    # heading σ near 77° throughout, which would hide what these cases do to the heading (docs/faults.md).
    config = json5.loads((ROOT / "config" / "imu.json5").read_text())
    config["service"]["imu"]["mag"]["hard_iron"]["unconfirmed_offset"] = 0.0
    config_path = tmp_path_factory.mktemp("faults") / "imu-calibrated.json5"
    config_path.write_text(json.dumps(config, indent=2))
    proc = subprocess.run(
        [sys.executable, "-m", "attitude_client.faults", str(TRIAL), "--excerpt-seconds", "35", "--cases",
         ",".join(CASES), "--config", str(config_path), "--json"],
        capture_output=True, text=True, env=env, timeout=300)
    assert proc.returncode == 0, f"exit {proc.returncode}:\n{proc.stderr[-4000:]}"
    [result] = json.loads(proc.stdout)
    return result


def test_every_case_runs_and_is_accounted_for(study):
    assert list(study["cases"]) == CASES
    for case, r in study["cases"].items():
        assert r["problems"] == [], (case, r["problems"])
    none = study["cases"]["none"]["counts"]
    assert none["rejected"] == {} and none["missed"] == 0 and none["gaps"] == 0, none
    assert none["sent_without_estimate"] == 0 and none["processed"] == study["samples"], none


def test_losses_are_counted_as_gaps_of_the_length_lost(study):
    rate = study["rate_hz"]
    for case in ("loss-1%", "burst-1s"):
        r = study["cases"][case]
        c, inj = r["counts"], r["injected"]
        assert inj["lost_samples"] > 0
        assert c["gaps"] == inj["lost_runs"] == c["rejected"].get("gap"), (case, c, inj)
        assert abs(c["blind_s"] - inj["lost_s"]) <= inj["lost_runs"] * 1.5 / rate, (case, c, inj)
        assert c["processed"] == study["samples"] - inj["lost_samples"], (case, c)


def test_copies_and_late_batches_are_refused_or_fused_and_counted(study):
    dup = study["cases"]["duplicates"]
    assert dup["counts"]["rejected"] == {"duplicate": dup["injected"]["copies"]} and dup["injected"]["copies"] > 0
    within = study["cases"]["reorder-within"]
    assert within["injected"]["late_samples"] > 0 and within["injected"]["late_s"] < study["max_lag_s"]
    assert within["counts"]["late_fused"] == within["injected"]["late_samples"], within["counts"]
    beyond = study["cases"]["reorder-beyond"]
    assert beyond["injected"]["late_s"] > study["max_lag_s"]
    assert beyond["counts"]["rejected"].get("out_of_order") == beyond["injected"]["late_samples"] > 0
    assert beyond["counts"]["sent_without_estimate"] == beyond["injected"]["late_samples"]


def test_recovered_cases_give_the_undisturbed_estimates(study):
    for case in ("duplicates", "reorder-within", "cut-cache", "restart"):
        r = study["cases"][case]
        assert r["identical_to_none"], (case, r["max_diff_to_none_deg"])
        assert r["counts"]["sent_without_estimate"] == 0 and r["counts"]["missed"] == 0, (case, r["counts"])
    # The faults happened: puts that only the sender's cache could give back.
    assert study["cases"]["cut-cache"]["sender"]["puts_during_fault"] >= 20
    restart = study["cases"]["restart"]["sender"]
    assert restart["puts_during_fault"] >= 20 and restart["restored"] == 1 and restart["redelivered"] > 0, restart


def test_what_is_not_recovered_is_lost_or_told(study):
    plain = study["cases"]["cut-plain"]
    # Plain puts made during the cut are gone and nothing reports them (nothing numbers them); the gap is told.
    assert plain["counts"]["sent_without_estimate"] >= 10 * 40 and plain["counts"]["missed"] == 0, plain["counts"]
    assert plain["counts"]["gaps"] >= 1, plain["counts"]
    small = study["cases"]["cut-small-cache"]
    # A cache of 4 puts: the rest is reported lost (samples_missed), and each such put's samples have no estimate.
    assert small["counts"]["missed"] > 4 and small["counts"]["rejected"].get("samples_missed", 0) >= 1, small["counts"]
    assert small["counts"]["sent_without_estimate"] == small["counts"]["missed"] * 40


def test_a_batch_refused_as_too_late_stays_honest_and_beats_vqf_fed_the_same_samples(study):
    """Deterministic (the same samples in the same order every run): bounds measured (19.3°, ×VQF 0.71, tilt in99
    0.991, 3-axis in99 0.913; before the gap's variance was made coherent over a quarter swing and the gyro frame's
    error correlated over the low-pass: 16.2°, 0.59, 0.993 on 3 axes) with a margin."""
    base = study["cases"]["none"]
    assert base["ours"]["total_rmse_deg"] < 1.0 and base["ours"]["att_in99"] > 0.98, base["ours"]
    r = study["cases"]["reorder-beyond"]
    assert r["ours"]["total_rmse_deg"] < 21.0 and r["ratio_to_vqf"] < 0.8, r["ours"]
    assert r["ours"]["att_in99"] >= 0.9 and r["ours"]["tilt_in99"] >= 0.97, r["ours"]


def test_lost_batches_and_bursts_keep_their_measured_accuracy(study):
    """Deterministic: loss-1% 19.2° (VQF as fed 21.7°), burst-1s 24.0° (VQF as fed 18.0°); docs/faults.md."""
    assert study["cases"]["loss-1%"]["ours"]["total_rmse_deg"] < 24.0
    assert study["cases"]["burst-1s"]["ours"]["total_rmse_deg"] < 29.0


def test_lost_batches_and_bursts_stay_honest(study):
    """After lost batches and a 1 s burst in fast motion the covariance covers the error left (with the magnetometer
    taken as calibrated: the filter's own heading covariance, no allowance for an unconfirmed field). Measured
    2026-12-01: loss-1% tilt in99 0.913, 3-axis 0.946; burst-1s 0.996 and 1.000. (A strict xfail until the score
    removed the constant heading offset as the published σ make it most likely, not as a plain mean that the
    heading after the gaps pulled: 3-axis 0.87 then; docs/faults.md.)"""
    for case in ("loss-1%", "burst-1s"):
        o = study["cases"][case]["ours"]
        assert o["att_in99"] >= 0.9 and o["tilt_in99"] >= 0.9, (case, o)
