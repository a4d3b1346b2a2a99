"""One BROAD metric: attitude_client.replay's `broad_scores` gives the numbers of crates/attitude-lab/src/study/broad.rs.

`attitude-lab imu-study` runs both committed excerpts (tests/data/broad/, exported by scripts/broad-export.py)
through the service's vehicle pipeline, scores them in Rust and writes every sample's estimate (`--series`: q and the
attitude covariance, printed to round-trip); `broad_scores` on those estimates, with the truth and `movement` as
attitude_client.replay reads them from the HDF5 files, must give the same accuracy and honesty figures. The MEKF and the QPF
(their covariances differ in shape: the QPF's is a particle spread). Measured agreement: 4e-14 at most. And a
truth in its own frames (`align: both`), the alignment fitted on every sample and trimmed: 7e-12 at most.

Data: BROAD (Laidig, Caruso, Cereatti, Seel, Data 6(7), 2021, doi:10.3390/data6070072), CC-BY-4.0.
"""

from __future__ import annotations

import json
import subprocess
import sys

import numpy as np
import pytest

from attitude_client.replay import ACCURACY_KEYS, HONESTY_KEYS, broad_scores, load_trial, quatmult
from conftest import LAB, ROOT

DATA = ROOT / "tests" / "data" / "broad"
EXCERPTS = ["16_undisturbed_fast_translation_B_excerpt", "34_disturbed_attached_magnet_3cm_excerpt"]


def read_series(path):
    """q (n, 4) w x y z and P_att (n, 3, 3) of an imu-study series CSV (NaN where no estimate)."""
    csv = np.genfromtxt(path, delimiter=",", names=True)
    q = np.column_stack([csv[k] for k in ("qw", "qx", "qy", "qz")])
    p = np.column_stack([csv[f"p{i}{j}"] for i in range(3) for j in range(3)]).reshape(-1, 3, 3)
    return csv["t"], q, p


@pytest.mark.parametrize("spec", [[], ["--filter", "qpf:average", "--particles", "200"]], ids=["mekf", "qpf"])
def test_python_scores_equal_the_rust_scores(tmp_path, spec):
    files = [DATA / f"{name}.hdf5" for name in EXCERPTS]
    missing = [str(f) for f in files if not f.exists()]
    assert not missing, f"committed excerpts missing: {missing}"
    exported = subprocess.run(
        [sys.executable, str(ROOT / "scripts" / "broad-export.py"), *map(str, files), "--out", str(tmp_path / "trials")],
        capture_output=True, text=True, timeout=60,
    )
    assert exported.returncode == 0, exported.stderr
    out = subprocess.run(
        [str(LAB), "imu-study", str(tmp_path / "trials"), "--config", str(ROOT / "config" / "imu.json5"), "--json",
         "--series", str(tmp_path / "series"), *spec],
        capture_output=True, text=True, timeout=120,
    )
    assert out.returncode == 0, out.stderr
    rust = {r["trial"]: r for r in json.loads(out.stdout)}
    assert set(rust) == set(EXCERPTS)
    for name, f in zip(EXCERPTS, files):
        trial = load_trial(f, None)
        t, q, p = read_series(tmp_path / "series" / f"{name}.csv")
        # The same samples at the same times: the excerpt keeps its source's time (first_sample).
        assert len(t) == len(trial["t"]) and np.array_equal(t, trial["t"]), name
        assert trial["t"][0] > 19.0, trial["t"][0]
        # Estimates for all but the pipeline's alignment (its first 0.1 s).
        assert np.isfinite(q).all(axis=1).sum() == rust[name]["published"] > len(t) - 40, name
        py = broad_scores(q, p, trial["opt_quat"], trial["movement"])
        r = rust[name]
        assert py["scored"] == r["scored"] > 15_000, (name, py, r)
        for key in ACCURACY_KEYS + HONESTY_KEYS:
            assert py[key] == pytest.approx(r[key], rel=1e-9, abs=1e-9), (name, key, py[key], r[key])
        # Not trivially equal: real errors and a covariance that is neither ignored nor perfect.
        assert 0.3 < py["total_rmse_deg"] < 10 and 0.2 < py["tilt_in99"] < 1.0, (name, py)


def test_scores_of_known_errors():
    """A pure heading error of 3° is 3° total and heading, 0 inclination; a tilt of 2° about east 2° total and
    inclination (crates/attitude-lab/src/study/broad.rs's own test); a stated σ of 1° against a 2° tilt error: NEES 4 / (1 + 0.04)."""
    deg = np.pi / 180
    truth = np.array([[np.cos(0.4), 0.1, -0.3, np.sin(0.4)]])
    truth /= np.linalg.norm(truth)

    def about(axis, angle_deg):  # e ⊗ truth: an error in the reference frame
        a = np.asarray(axis, float) * np.sin(angle_deg * deg / 2)
        return quatmult(np.array([np.cos(angle_deg * deg / 2), *a]), truth)

    p = np.eye(3)[None] * deg**2
    s = broad_scores(about([0, 0, 1], 3.0), p, truth, np.array([True]))
    assert s["total_rmse_deg"] == pytest.approx(3.0) and s["heading_rmse_deg"] == pytest.approx(3.0)
    assert s["inclination_rmse_deg"] == pytest.approx(0.0, abs=1e-6)
    assert s["heading_offset_deg"] == pytest.approx(3.0) and s["heading_in99"] == 1.0
    s = broad_scores(about([1, 0, 0], 2.0), p, truth, np.array([True]))
    assert s["total_rmse_deg"] == pytest.approx(2.0) and s["inclination_rmse_deg"] == pytest.approx(2.0)
    assert s["heading_rmse_deg"] == pytest.approx(0.0, abs=1e-6)
    assert s["tilt_nees_median"] == pytest.approx(4.0 / (1.0 + 0.2**2), rel=1e-9) and s["tilt_in99"] == 1.0
    # No truth, or not moving: nothing scored.
    s = broad_scores(about([1, 0, 0], 2.0), p, np.full((1, 4), np.nan), np.array([True]))
    assert s["scored"] == 0 and np.isnan(s["total_rmse_deg"]) and np.isnan(s["tilt_in99"])


def test_aligned_scores_equal_the_rust_scores(tmp_path):
    """A truth in its own frames (``align: both``): the excerpt's truth carried into other reference and body frames
    (``L·q·R``, half turns and tilts, as a motion-capture rig's are), exported and scored by imu-study, with the
    alignment fitted on every sample and without the tenth with the largest error (``--align-trim 0.1``);
    ``broad_scores`` on the same estimates gives the same figures, and the fitted frames are the ones put in."""
    import h5py

    name = EXCERPTS[0]
    src = DATA / f"{name}.hdf5"
    assert src.exists(), f"committed excerpt missing: {src}"
    rotated = tmp_path / f"{name}.hdf5"
    rotated.write_bytes(src.read_bytes())

    def q_of(axis, angle):
        a = np.asarray(axis, float) / np.linalg.norm(axis)
        return np.array([np.cos(angle / 2), *(a * np.sin(angle / 2))])

    l = q_of([0.2, -0.3, 1.0], 2.6)
    r = q_of([1.0, 0.1, 0.2], 3.0)
    with h5py.File(rotated, "r+") as f:
        q = f["opt_quat"][:]
        ok = np.isfinite(q).all(axis=1)
        q[ok] = quatmult(quatmult(np.broadcast_to(l, q[ok].shape), q[ok]), np.broadcast_to(r, q[ok].shape))
        f["opt_quat"][...] = q
        f.attrs["align"] = "both"
    exported = subprocess.run(
        [sys.executable, str(ROOT / "scripts" / "broad-export.py"), str(rotated), "--out", str(tmp_path / "trials")],
        capture_output=True, text=True, timeout=60,
    )
    assert exported.returncode == 0, exported.stderr
    trial = load_trial(rotated, None)
    assert trial["truth"]["align"] == "both"
    angle = lambda a: float(np.rad2deg(2 * np.arctan2(np.linalg.norm(a[1:]), abs(a[0]))))  # noqa: E731
    for trim in (0.0, 0.1):
        series = tmp_path / f"series-{trim}"
        out = subprocess.run(
            [str(LAB), "imu-study", str(tmp_path / "trials"), "--config", str(ROOT / "config" / "imu.json5"),
             "--json", "--series", str(series), "--align-trim", str(trim)],
            capture_output=True, text=True, timeout=120,
        )
        assert out.returncode == 0, out.stderr
        (r_scores,) = json.loads(out.stdout)
        _, q_est, p = read_series(series / f"{name}.csv")
        py = broad_scores(q_est, p, trial["opt_quat"], trial["movement"], {**trial["truth"], "align_trim": trim})
        assert py["scored"] == r_scores["scored"] > 15_000, (trim, py, r_scores)
        for key in ACCURACY_KEYS + HONESTY_KEYS + ("align_reference_deg", "align_body_deg"):
            assert py[key] == pytest.approx(r_scores[key], rel=1e-9, abs=1e-9), (trim, key, py[key], r_scores[key])
        # The frames put in come back (to the estimator's own heading offset and mounting, a degree or so).
        assert py["align_reference_deg"] == pytest.approx(angle(l), abs=2.0), py
        assert py["align_body_deg"] == pytest.approx(angle(r), abs=2.0), py
        assert 0.3 < py["total_rmse_deg"] < 5 and 0.5 < py["tilt_in99"] <= 1.0, (trim, py)
    with pytest.raises(ValueError):
        broad_scores(q_est, p, trial["opt_quat"], trial["movement"], {"align": "both", "align_trim": 0.5})
