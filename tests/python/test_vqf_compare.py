"""Our MEKF (attitude-lab imu-bench: the service's vehicle pipeline, no network) beside VQF on a real
BROAD excerpt committed in tests/data/broad (trial 16, fast translations).

Data: BROAD (Laidig, Caruso, Cereatti, Seel, Data 6(7), 2021), CC-BY-4.0.
"""

import json
import os
import pathlib
import subprocess
import sys

import pytest


ROOT = pathlib.Path(__file__).resolve().parents[2]
TRIAL = ROOT / "tests" / "data" / "broad" / "16_undisturbed_fast_translation_B_excerpt.hdf5"


def test_mekf_and_vqf_side_by_side_on_broad():
    assert TRIAL.exists(), f"{TRIAL} is missing: the test data of the repository (tests/data/broad/README.md)"
    binary = os.environ.get("ATTITUDE_LAB_BIN", str(ROOT / "target" / "release" / "attitude-lab"))
    out = subprocess.run(
        [sys.executable, str(ROOT / "benches" / "vqf_compare.py"), str(TRIAL), "--json",
         "--no-python-loop", "--repeat", "1", "--bin", binary],
        capture_output=True, text=True, timeout=300,
    )
    assert out.returncode == 0, out.stderr
    report = json.loads([line for line in out.stdout.splitlines() if line.startswith("{")][-1])
    assert report["samples"] > 10_000
    # Speed belongs to the benchmark (BENCHMARKS.md); here only that the reported ratio is the ratio of the two
    # reported rates (a wall-clock ratio on a shared machine is no test).
    assert report["mekf_samples_per_s"] > 0 and report["vqf_samples_per_s"] > 0, report
    assert report["ratio"] == pytest.approx(report["mekf_samples_per_s"] / report["vqf_samples_per_s"], rel=1e-12)
    # Accuracy on the excerpt (movement phases, degrees). Deterministic: the same samples through the same code
    # give the same figures. Measured: ours 0.813 (0.707 before the alignment's initial heading covariance took the
    # tilt's error into the heading, 0.836 before the preset of issue 26), VQF 1.179 aligned and 0.889 unaligned.
    # Aligned here means on the heading of the opening rest: ours now settles at rest on the magnetometer read
    # against the refined vertical, and this recording's field in motion is not its field at rest (docs/broad.md),
    # so the rest's heading offset moved (-0.54° -> +0.12°) while the unaligned total improved (0.81° -> 0.77°).
    # Ours within ±8% of its figure (an RMSE 1.5× worse, 1.22°, fails; so does one of 0.889, VQF's)
    # and at most VQF's unaligned one (as tests/python/test_broad_replay.py asks of this excerpt); VQF's within
    # ±5% of both of its figures (the data, the metric and the heading alignment are read right: the aligned and
    # unaligned figures are 33% apart).
    errors = report["errors_deg"]
    mekf, vqf = report["mekf_total_rmse_deg"], report["vqf_total_rmse_deg"]
    assert mekf == errors["mekf"]["aligned"]["total"] and vqf == errors["vqf"]["aligned"]["total"], report
    assert 0.813 / 1.08 <= mekf <= 0.813 * 1.08, report
    assert mekf <= errors["vqf"]["unaligned"]["total"], report
    assert vqf == pytest.approx(1.179, rel=0.05), report
    assert errors["vqf"]["unaligned"]["total"] == pytest.approx(0.889, rel=0.05), report


def test_bench_beside_vqf_is_the_script_calling_the_binary():
    """`vqf_compare.py --bench` (what `attitude-service bench --vqf` was): the lab binary's `bench --json`
    object with the comparison under "vqf"; the binary itself runs no Python."""
    binary = os.environ.get("ATTITUDE_LAB_BIN", str(ROOT / "target" / "release" / "attitude-lab"))
    out = subprocess.run(
        [sys.executable, str(ROOT / "benches" / "vqf_compare.py"), str(TRIAL), "--json", "--bench",
         "--seconds", "0.05", "--particles", "200", "--no-python-loop", "--repeat", "1", "--bin", binary],
        capture_output=True, text=True, timeout=300,
    )
    assert out.returncode == 0, out.stderr
    report = json.loads([line for line in out.stdout.splitlines() if line.startswith("{")][-1])
    assert report["particles"] == 200
    assert report["mekf_us_per_step"] > 0 and report["qpf_ns_per_particle_step"] > 0, report
    assert report["vqf"]["samples"] > 10_000
    v = report["vqf"]
    assert v["ratio"] == pytest.approx(v["mekf_samples_per_s"] / v["vqf_samples_per_s"], rel=1e-12), report
    # The option is gone from the binary.
    gone = subprocess.run([binary, "bench", "--vqf", str(TRIAL)], capture_output=True, text=True, timeout=60)
    assert gone.returncode != 0 and "--vqf" in gone.stderr
