"""Replays a recorded IMU trial (BROAD benchmark HDF5) through a running attitude-service and scores it.

    attitude-service serve --config config/imu.json5 --listen tcp/127.0.0.1:7447      # the user runs this
    attitude-replay TRIAL.hdf5 --connect tcp/127.0.0.1:7447 [--json]      # or: python -m attitude_client.replay

(installed with the package; the trial reader and the two peers need the ``replay`` extra:
``pip install 'attitude-client[replay]'``, i.e. h5py, vqf and ahrs).

What it does (it never starts the service):

1. Reads the trial with h5py: ``imu_gyr`` (rad/s), ``imu_acc`` (m/s²), ``imu_mag`` (µT), ``opt_quat`` ([w,x,y,z], the
   sensor in an East-North-Up frame aligned with magnetic north; NaN rows where the cameras lost the markers),
   ``movement`` (bool), attribute ``sampling_rate``. Sample k is at ``t_k = (first_sample + k) / rate``, with
   ``first_sample`` an optional attribute (0 when absent): an excerpt (``tests/data/broad/``) keeps the time of its
   source trial. Your own recording works if it has these datasets (``opt_quat`` and ``movement`` only for scoring),
   or as a CSV trial (docs/recordings.md); a truth in its own frames (``align: both``) is aligned to each estimator
   on its own, and the truth's own errors (``truth_tilt_sigma_deg``, ``truth_time_sigma_s``) are allowed for.
2. Streams the raw samples into one vehicle per ``--filters`` entry, one vehicle after the other (each configured
   by a reset request, e.g. ``{"filter": "qpf", "fiducial": "average", "particles": N}``), on ``P/V/imu``: batches of
   ``--batch`` samples ``{"t": t_k, "gyr", "acc", "mag"}`` (body frame; sample k's rate covers ``(t_{k−1}, t_k]``),
   in time order, as fast as the service takes them, through advanced publishers (a put lost on the way is fetched
   again from their cache, ``--cache`` puts; ``--plain`` for plain puts). The client computes nothing else: the service derives
   gravity, the magnetic reference and the noise models from the samples (``service.imu``, ``crates/attitude-core/src/ahrs``). Flow
   control: at most ``--window`` samples per vehicle are in flight (sent, no estimate yet); rejections on
   ``P/V/rejected`` are counted (a ``queue_full`` means the window is too large for the service's
   ``queue_per_vehicle``).
3. Collects the estimate of each sample (matched by ``t``): its ``q`` and the attitude block of its ``cov`` (the
   body-frame attitude error, rad²). A sample without an estimate is left out of the scores, as
   ``attitude-lab imu-study`` does, and counted: ``aligning`` before the vehicle's first estimate (the
   pipeline averages its first ``service.imu.init.duration_s`` of samples), ``missing`` after it (lost, or
   thinned by ``service.imu.max_estimate_rate_hz``). Runs VQF (PyPI ``vqf``, 9D) and Madgwick (PyPI ``ahrs``,
   MARG, gain β = 0.12, BROAD's TAGP value for Madgwick) on the same samples.
4. Scores with :func:`broad_scores`, the definitions of ``crates/attitude-lab/src/study/broad.rs`` (``tests/python/test_broad_metric.py``
   holds the two equal):

   * accuracy, every estimator (BROAD's ``example_code/broad_utils.py`` ``calculateRMSE``): ``e = q_est ⊗ q_opt⁻¹``
     (``e_w ≥ 0``), total ``2·acos e_w``, heading ``2·atan|e_z/e_w|``, inclination ``2·acos√(e_w² + e_z²)``, RMSE in
     degrees over the ``movement`` samples, NaN truth rows left out; no heading alignment (the benchmark applies
     none: ``opt_quat``'s frame is aligned with magnetic north);
   * honesty, our filters only (VQF and Madgwick state no covariance): with ``θ`` the rotation vector of ``e``
     (reference frame) and ``P_ref = R P Rᵀ`` (``R`` body → reference of the estimate), ``tilt_in99`` is the
     fraction of scored samples whose horizontal NEES ``θ_hᵀ (P_ref,h + (0.2°)² I)⁻¹ θ_h`` is within χ²₂'s 99%
     quantile 9.21 (honest: 0.99; the 0.2° is the optical truth's own tilt error) and ``tilt_nees_median`` its
     median (honest: 1.39); ``heading_in99`` the fraction with ``|θ_z − offset| ≤ 2.576·√P_ref,zz``, where
     ``heading_offset_deg`` (reported) is the mean of ``θ_z`` over the scored samples weighted by ``1/P_ref,zz``:
     the angle between the optical frame's north and the magnetic north, a property of the recording, as the
     estimate's own σ make it most likely.

Output: a table, or with ``--json`` one object mapping each estimator (``mekf``, ``qpf:average``, ``vqf``,
``madgwick``) to ``{"total_rmse_deg", "heading_rmse_deg", "inclination_rmse_deg"}``, our filters with
``"tilt_in99", "tilt_nees_median", "heading_in99", "heading_offset_deg"`` besides. ``--details FILE`` writes the
run's particulars (counts, rejections, timings, the pipeline's last diagnostics, samples scored) as JSON.

Data: BROAD (D. Laidig, M. Caruso, A. Cereatti, T. Seel, "BROAD — A Benchmark for Robust Inertial Orientation
Estimation", Data 6(7), 2021, doi:10.3390/data6070072), CC-BY-4.0.
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import threading
import time
from pathlib import Path

import numpy as np
import zenoh

from .client import CACHE, AttitudeClient

ATTRIBUTION = (
    "Data: BROAD (Laidig, Caruso, Cereatti, Seel, Data 6(7), 2021, doi:10.3390/data6070072), CC-BY-4.0."
)
#: Madgwick's gain: BROAD's TAGP parameter for Madgwick (published_madgwick_rmse.json).
MADGWICK_BETA = 0.12
#: χ²₂ 99% quantile, the two-sided 99% of a normal, and the truth's own tilt error (rad): crates/attitude-lab/src/study/broad.rs.
CHI2_2_99 = 9.210340371976182
CHI2_3_99 = 11.344866730144373
Z_99 = 2.575829303548901
TRUTH_TILT_SIGMA_RAD = np.deg2rad(0.2)
#: The keys of an estimator's scores: every estimator's, then those of a filter with a covariance.
ACCURACY_KEYS = ("total_rmse_deg", "heading_rmse_deg", "inclination_rmse_deg")
HONESTY_KEYS = ("tilt_in99", "tilt_nees_median", "heading_in99", "heading_offset_deg", "att_in99", "att_nees_median")

# ---------------------------------------------------------------------------------------------------
# Quaternions, Hamilton [w, x, y, z]; the scores of crates/attitude-lab/src/study/broad.rs


def quatmult(q1: np.ndarray, q2: np.ndarray) -> np.ndarray:
    q1, q2 = np.atleast_2d(q1), np.atleast_2d(q2)
    w1, x1, y1, z1 = q1.T
    w2, x2, y2, z2 = q2.T
    return np.column_stack(
        [
            w1 * w2 - x1 * x2 - y1 * y2 - z1 * z2,
            w1 * x2 + x1 * w2 + y1 * z2 - z1 * y2,
            w1 * y2 - x1 * z2 + y1 * w2 + z1 * x2,
            w1 * z2 + x1 * y2 - y1 * x2 + z1 * w2,
        ]
    )


def invquat(q: np.ndarray) -> np.ndarray:
    out = np.array(q, dtype=float, copy=True)
    out[..., 1:] *= -1.0
    return out


def rotation_matrix(q: np.ndarray) -> np.ndarray:
    """(n, 3, 3) rotation matrices of Hamilton unit quaternions (n, 4): body → reference for q of body → reference."""
    w, x, y, z = np.atleast_2d(q).T
    return np.stack(
        [
            np.stack([1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)], axis=-1),
            np.stack([2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)], axis=-1),
            np.stack([2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)], axis=-1),
        ],
        axis=-2,
    )


def quat_average(q: np.ndarray) -> np.ndarray:
    """The MMSE average of unit quaternions (n, 4): the eigenvector of the largest eigenvalue of ``Σ q qᵀ``, ``w ≥ 0``
    unless the average is a half turn."""
    m = q.T @ q
    vals, vecs = np.linalg.eigh(m)
    a = vecs[:, np.argmax(vals)]
    return a if a[0] >= 0 else -a


def _rotation_vectors(q: np.ndarray) -> np.ndarray:
    q = np.where((q[:, 0] < 0)[:, None], -q, q)
    s = np.linalg.norm(q[:, 1:], axis=1)
    with np.errstate(invalid="ignore", divide="ignore"):
        return np.where((s > 0)[:, None], q[:, 1:] * (2.0 * np.arctan2(s, q[:, 0]) / s)[:, None], 0.0)


def _body_start(q_est: np.ndarray, q_true: np.ndarray) -> np.ndarray:
    """``R`` from the relative rotations alone (hand–eye): ``q_est,i⁻¹·q_est,j = R·(q_true,i⁻¹·q_true,j)·R⁻¹``, so the
    rotation vectors of the two are turned into each other by ``R``; with the pairs ``(i, i + 16)`` the rotation
    that best turns the truth's into the estimate's (Wahba by SVD, weighted by angle). Identity without rotation."""
    step = 16
    if len(q_est) <= step:
        return np.array([1.0, 0.0, 0.0, 0.0])
    ve = _rotation_vectors(quatmult(invquat(q_est[:-step]), q_est[step:]))
    vt = _rotation_vectors(quatmult(invquat(q_true[:-step]), q_true[step:]))
    b = ve.T @ vt
    u, _, vh = np.linalg.svd(b)
    d = np.sign(np.linalg.det(u @ vh)) or 1.0
    m = u @ np.diag([1.0, 1.0, d]) @ vh
    if not np.isfinite(m).all() or np.allclose(b, 0.0):
        return np.array([1.0, 0.0, 0.0, 0.0])
    from scipy.spatial.transform import Rotation

    x, y, z, w = Rotation.from_matrix(m).as_quat()
    return np.array([w, x, y, z])


def alignment(q_est: np.ndarray, q_true: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The constant rotations ``L`` (reference) and ``R`` (body) with ``q_true ≈ L·q_est·R`` (Hamilton) over the
    rows given (unit, finite): ``R`` starts from the relative rotations alone (:func:`_body_start`), then
    alternately the average of ``q_true·R⁻¹·q_est⁻¹`` with ``R`` held and of ``q_est⁻¹·L⁻¹·q_true`` with ``L``
    held, until neither moves by more than 1e-9 rad (at most 50 rounds): ``alignment`` of crates/attitude-lab/src/study/broad.rs."""
    r = _body_start(q_est, q_true)
    l = quat_average(quatmult(quatmult(q_true, invquat(r)), invquat(q_est)))
    for _ in range(50):
        l_new = quat_average(quatmult(quatmult(q_true, invquat(r)), invquat(q_est)))
        if np.dot(l_new, l) < 0:
            l_new = -l_new
        r_new = quat_average(quatmult(quatmult(invquat(q_est), invquat(l_new)), q_true))
        if np.dot(r_new, r) < 0:
            r_new = -r_new

        def angle(a, b):
            d = quatmult(a, invquat(b))[0]
            return 2.0 * np.arctan2(np.linalg.norm(d[1:]), abs(d[0]))

        moved = max(angle(l_new, l), angle(r_new, r))
        l, r = l_new, r_new
        if moved < 1e-9:
            break
    return l, r


def trimmed_alignment(q_est: np.ndarray, q_true: np.ndarray, trim: float) -> tuple[np.ndarray, np.ndarray]:
    """:func:`alignment` fitted without the ``trim`` fraction of the rows whose error is largest: fitted on all, the
    rows' errors ranked, fitted again on the rest, five times at most (until the rows kept stop changing).
    A squared-error fit lets a few large errors (a saturated swing's) turn the frames, and every other row then looks
    off; the trimmed rows are still scored. ``trim`` 0 is :func:`alignment` (``trimmed_alignment`` of
    crates/attitude-lab/src/study/broad.rs)."""
    l, r = alignment(q_est, q_true)
    if not 0.0 < trim < 1.0:
        return l, r
    kept = np.ones(len(q_est), dtype=bool)
    for _ in range(5):
        d = quatmult(quatmult(quatmult(invquat(l), q_true), invquat(r)), invquat(q_est))
        err = 2.0 * np.arctan2(np.linalg.norm(d[:, 1:], axis=1), np.abs(d[:, 0]))
        keep = int(np.ceil((1.0 - trim) * len(err)))
        limit = np.sort(err)[max(keep, 1) - 1]
        new = err <= limit
        if np.array_equal(new, kept):
            break
        kept = new
        l, r = alignment(q_est[kept], q_true[kept])
    return l, r


def broad_scores(
    q_est: np.ndarray,
    cov_att: np.ndarray | None,
    q_true: np.ndarray,
    movement: np.ndarray,
    truth: dict | None = None,
    gyr: np.ndarray | None = None,
) -> dict:
    """The scores of ``crates/attitude-lab/src/study/broad.rs`` over the ``movement`` samples with an estimate and a truth.

    ``q_est``, ``q_true``: (n, 4) Hamilton ``[w, x, y, z]`` of body → reference (East-North-Up, magnetic north),
    NaN rows where there is none. ``cov_att``: (n, 3, 3) covariance of the body-frame attitude error, rad², or
    None (an estimator without one: accuracy only). ``movement``: (n,) bool. ``truth``: the truth's description
    (:func:`truth_model`; default BROAD's: no alignment, 0.2° of tilt); ``gyr`` (n, 3) the body rates that turn the
    truth's time-stamp uncertainty into an angle.

    With ``truth["align"] == "both"`` the estimate is aligned on its own (:func:`alignment`) and scored against
    ``L⁻¹·q_true·R⁻¹``; ``align_reference_deg`` and ``align_body_deg`` report the two rotations' angles.

    Returns ``total_rmse_deg``, ``heading_rmse_deg``, ``inclination_rmse_deg`` and ``scored`` (the samples
    scored); with ``cov_att`` also ``tilt_in99``, ``tilt_nees_median``, ``heading_in99``, ``att_in99``,
    ``att_nees_median``, ``heading_offset_deg``. NaN for a figure without any sample."""
    truth = truth_model(truth)
    q_est = np.asarray(q_est, dtype=float)
    q_true = np.asarray(q_true, dtype=float)
    movement = np.asarray(movement, dtype=bool)
    n = len(q_est)
    if q_est.shape != (n, 4) or q_true.shape != (n, 4) or movement.shape != (n,):
        raise ValueError(f"q_est {q_est.shape}, q_true {q_true.shape}, movement {movement.shape}: expected (n, 4) and (n,)")
    if cov_att is not None:
        cov_att = np.asarray(cov_att, dtype=float)
        if cov_att.shape != (n, 3, 3):
            raise ValueError(f"cov_att {cov_att.shape}: expected ({n}, 3, 3)")
    rows = movement & np.isfinite(q_est).all(axis=1) & np.isfinite(q_true).all(axis=1)
    qe = q_est[rows] / np.linalg.norm(q_est[rows], axis=1)[:, None]
    qt = q_true[rows] / np.linalg.norm(q_true[rows], axis=1)[:, None]
    extra = {}
    if truth["align"] == "both" and len(qe):
        l, r = trimmed_alignment(qe, qt, truth["align_trim"])
        qt = quatmult(quatmult(invquat(l), qt), invquat(r))
        for key, a in (("align_reference_deg", l), ("align_body_deg", r)):
            extra[key] = float(np.rad2deg(2.0 * np.arctan2(np.linalg.norm(a[1:]), abs(a[0]))))
    e = quatmult(qe, invquat(qt))
    e[e[:, 0] < 0] *= -1.0
    w, z = np.minimum(e[:, 0], 1.0), e[:, 3]
    with np.errstate(divide="ignore"):
        heading = 2.0 * np.arctan(np.abs(z / w))
    total = 2.0 * np.arccos(w)
    incl = 2.0 * np.arccos(np.minimum(np.sqrt(w * w + z * z), 1.0))
    m = int(rows.sum())

    def rmse(x: np.ndarray) -> float:
        return float(np.rad2deg(np.sqrt(np.mean(x * x)))) if m else float("nan")

    out = {"total_rmse_deg": rmse(total), "heading_rmse_deg": rmse(heading), "inclination_rmse_deg": rmse(incl)}
    if cov_att is not None:
        rates = None if gyr is None else np.asarray(gyr, dtype=float)[rows]
        out.update(_honesty(qe, e, w, cov_att[rows], m, truth, rates))
    out.update(extra)
    out["scored"] = m
    return out


#: The truth description a recording carries (a CSV trial's ``#`` lines, an HDF5 file's attributes, a trial file's
#: trailer; docs/recordings.md). ``truth_model``'s ``align_trim`` is how a run scores, not a property of the recording.
TRUTH_FILE_KEYS = ("align", "truth_tilt_sigma_deg", "truth_time_sigma_s")


def truth_model(truth: dict | None) -> dict:
    """The truth's description with its defaults (BROAD's): ``align`` ("none" or "both"), ``truth_tilt_sigma_deg``
    (0.2), ``truth_time_sigma_s`` (0), and how the alignment is fitted, ``align_trim`` (0: on every row;
    :func:`trimmed_alignment`)."""
    out = {"align": "none", "truth_tilt_sigma_deg": float(np.rad2deg(TRUTH_TILT_SIGMA_RAD)), "truth_time_sigma_s": 0.0,
           "align_trim": 0.0}
    for k, v in (truth or {}).items():
        if k in out and v is not None:
            out[k] = v if k == "align" else float(v)
    if out["align"] not in ("none", "both"):
        raise ValueError(f"align {out['align']!r}: expected 'none' or 'both'")
    if not 0.0 <= out["align_trim"] < 0.5:
        raise ValueError(f"align_trim {out['align_trim']}: expected a fraction in [0, 0.5)")
    return out


def _honesty(
    qe: np.ndarray, e: np.ndarray, w: np.ndarray, p_att: np.ndarray, m: int, truth: dict, rates: np.ndarray | None
) -> dict:
    """Tilt NEES, heading and 3-axis coverage (crates/attitude-lab/src/study/broad.rs), on the scored rows."""
    if m == 0:
        return {k: float("nan") for k in HONESTY_KEYS}
    v = e[:, 1:]
    s = np.linalg.norm(v, axis=1)
    with np.errstate(invalid="ignore", divide="ignore"):
        theta = np.where((s > 0)[:, None], v * (2.0 * np.arctan2(s, w) / s)[:, None], 0.0)
    r = rotation_matrix(qe)
    pe = r @ p_att @ np.transpose(r, (0, 2, 1))
    truth2 = np.deg2rad(truth["truth_tilt_sigma_deg"]) ** 2
    pe[:, 0, 0] += truth2
    pe[:, 1, 1] += truth2
    if rates is not None and truth["truth_time_sigma_s"] > 0:
        wr = np.einsum("nij,nj->ni", r, rates)
        pe += np.einsum("ni,nj->nij", wr, wr) * truth["truth_time_sigma_s"] ** 2
    # θ_hᵀ P_h⁻¹ θ_h by a Cholesky factor of the 2×2 block (lower triangle, as nalgebra's); not positive
    # definite: infinite.
    a, c, d = pe[:, 0, 0], pe[:, 1, 0], pe[:, 1, 1]
    with np.errstate(invalid="ignore", divide="ignore"):
        l00 = np.sqrt(a)
        l10 = c / l00
        d1 = d - l10 * l10
        y0 = theta[:, 0] / l00
        y1 = (theta[:, 1] - l10 * y0) / np.sqrt(d1)
    nees = np.where((a > 0) & (d1 > 0), y0 * y0 + y1 * y1, np.inf)
    psi = theta[:, 2]
    psi_sigma = np.sqrt(np.maximum(pe[:, 2, 2], 0.0))
    # The constant offset the published σ make most likely: the inverse-variance weighted mean (a phase the
    # estimator declares uncertain, a field reference not yet confirmed, does not move it).
    weights = 1.0 / np.maximum(psi_sigma * psi_sigma, 1e-12)
    offset = float(np.sum(weights * psi) / np.sum(weights))
    th3 = theta.copy()
    th3[:, 2] -= offset
    att = np.full(m, np.inf)
    ok = np.all(np.linalg.eigvalsh(pe) > 0, axis=1)
    if ok.any():
        sol = np.linalg.solve(pe[ok], th3[ok][:, :, None])[:, :, 0]
        att[ok] = np.einsum("ni,ni->n", th3[ok], sol)
    return {
        "tilt_in99": float(np.count_nonzero(nees <= CHI2_2_99) / m),
        "tilt_nees_median": float(np.median(nees)),
        "heading_in99": float(np.count_nonzero(np.abs(psi - offset) <= Z_99 * psi_sigma) / m),
        "att_in99": float(np.count_nonzero(att <= CHI2_3_99) / m),
        "att_nees_median": float(np.median(att)),
        "heading_offset_deg": float(np.rad2deg(offset)),
    }


def broad_rmse(q_est: np.ndarray, q_opt: np.ndarray, movement: np.ndarray) -> dict:
    """BROAD's calculateRMSE: total/heading/inclination RMSE in degrees over ``movement`` (:func:`broad_scores`
    without a covariance)."""
    s = broad_scores(q_est, None, q_opt, movement)
    return {k: s[k] for k in ACCURACY_KEYS}


# ---------------------------------------------------------------------------------------------------
# Data


CSV_COLUMNS = ("t", "gx", "gy", "gz", "ax", "ay", "az", "mx", "my", "mz", "qw", "qx", "qy", "qz", "movement")


def load_trial(path: Path, excerpt_seconds: float | None) -> dict:
    """The trial, its IMU channels as float64: a BROAD-layout HDF5 file (``t`` from the attribute ``first_sample``,
    0 when absent) or a CSV trial (docs/recordings.md: ``# key: value`` lines, a header naming the columns
    ``t, gx, gy, gz, ax, ay, az, mx, my, mz, qw, qx, qy, qz, movement``, one line per sample). ``truth`` describes
    the truth (:func:`truth_model`: the attributes or ``#`` lines ``align``, ``truth_tilt_sigma_deg``,
    ``truth_time_sigma_s``)."""
    if Path(path).suffix == ".csv":
        trial = _load_csv_trial(Path(path))
    else:
        trial = _load_hdf5_trial(Path(path))
    return _check_and_cut(path, trial, excerpt_seconds)


def _load_csv_trial(path: Path) -> dict:
    meta: dict = {}
    header = None
    rows = []
    with open(path) as fh:
        for line in fh:
            line = line.strip()
            if not line:
                continue
            if line.startswith("#"):
                key, sep, value = line[1:].partition(":")
                if sep:
                    meta[key.strip()] = value.strip()
                continue
            fields = [f.strip() for f in line.split(",")]
            if header is None:
                missing = [c for c in CSV_COLUMNS if c not in fields]
                if missing:
                    raise SystemExit(f"{path}: the header has no column {missing[0]!r}")
                header = [fields.index(c) for c in CSV_COLUMNS]
                continue
            rows.append([float(fields[i]) if fields[i] else np.nan for i in header])
    if not rows:
        raise SystemExit(f"{path}: no samples")
    a = np.asarray(rows, dtype=np.float64)
    t = a[:, 0]
    dt = np.diff(t)
    rate = 1.0 / float(np.median(dt)) if len(dt) and np.median(dt) > 0 else 1.0
    quat = a[:, 10:14]
    return {
        "name": path.stem,
        "gyr": np.ascontiguousarray(a[:, 1:4]),
        "acc": np.ascontiguousarray(a[:, 4:7]),
        "mag": np.ascontiguousarray(a[:, 7:10]),
        "opt_quat": quat if np.isfinite(quat).any() else None,
        "movement": a[:, 14] != 0,
        "rate_hz": rate,
        "first_sample": 0,
        "t": t,
        "truth": truth_model({k: meta.get(k) for k in TRUTH_FILE_KEYS}),
    }


def _load_hdf5_trial(path: Path) -> dict:
    try:
        import h5py
    except ImportError as e:
        raise SystemExit("reading a trial needs h5py: pip install 'attitude-client[replay]'") from e
    with h5py.File(path, "r") as f:
        def attr(key):
            v = f.attrs.get(key)
            return v.decode() if isinstance(v, bytes) else v

        trial = {
            "name": path.stem,
            "gyr": np.ascontiguousarray(f["imu_gyr"][:], dtype=np.float64),
            "acc": np.ascontiguousarray(f["imu_acc"][:], dtype=np.float64),
            "mag": np.ascontiguousarray(f["imu_mag"][:], dtype=np.float64),
            "opt_quat": np.asarray(f["opt_quat"][:], dtype=np.float64) if "opt_quat" in f else None,
            "movement": np.asarray(f["movement"][:], dtype=bool) if "movement" in f else None,
            "rate_hz": float(f.attrs["sampling_rate"]),
            "first_sample": int(f.attrs.get("first_sample", 0)),
            "truth": truth_model(
                {k: attr(k) for k in TRUTH_FILE_KEYS}
            ),
        }
    k = trial["first_sample"] + np.arange(len(trial["gyr"]), dtype=np.float64)
    trial["t"] = k / trial["rate_hz"]
    return trial


def _check_and_cut(path: Path, trial: dict, excerpt_seconds: float | None) -> dict:
    n = len(trial["gyr"])
    for key in ("gyr", "acc", "mag"):
        if trial[key].shape != (n, 3) or not np.isfinite(trial[key]).all():
            raise SystemExit(f"{path}: imu_{key} must be {n}×3 finite values")
    for key, shape in (("opt_quat", (n, 4)), ("movement", (n,))):
        if trial[key] is not None and trial[key].shape != shape:
            raise SystemExit(f"{path}: {key} has shape {trial[key].shape}, expected {shape}")
    if excerpt_seconds is not None:
        start = int(np.argmax(trial["movement"])) if trial["movement"] is not None and trial["movement"].any() else 0
        end = min(n, start + int(round(excerpt_seconds * trial["rate_hz"])))
        for key in ("gyr", "acc", "mag", "opt_quat", "movement"):
            if trial[key] is not None:
                trial[key] = trial[key][:end]
        trial["t"] = trial["t"][:end]
    return trial


# ---------------------------------------------------------------------------------------------------
# Through the service


def reset_fields(spec: str, particles: int | None) -> dict:
    """The reset request that switches a vehicle to ``spec``; a qpf's particles only when given (otherwise the
    service's configured count, e.g. config/imu.json5's)."""
    kind, _, fiducial = spec.partition(":")
    fields = {"filter": kind}
    if kind != "mekf":
        fields["fiducial"] = fiducial or "average"
    if kind == "qpf" and particles is not None:
        fields["particles"] = particles
    return fields


def replay(client: AttitudeClient, trial: dict, specs: list[str], args) -> dict:
    """Streams the trial into one vehicle per spec; returns {spec: {"quat": (n, 4), "cov_att": (n, 3, 3), ...}}
    (NaN where a sample has no estimate)."""
    n, t, rate = len(trial["gyr"]), trial["t"], trial["rate_hz"]
    tag = args.tag or f"{os.getpid()}-{int(time.time() * 1000) % 1_000_000}"
    copies = max(1, getattr(args, "copies", 1))
    pause = getattr(args, "pause", 0.0)
    # One vehicle per spec, or `copies` of them fed the same samples at once (keys "spec#2", ...).
    specs = [spec if c == 1 else f"{spec}#{c}" for spec in specs for c in range(1, copies + 1)]
    vehicles = {
        spec: f"{args.vehicle_prefix}-{spec.replace(':', '-').replace('#', '-c')}-{tag}" for spec in specs
    }
    by_vehicle = {v: s for s, v in vehicles.items()}
    lock = threading.Lock()
    cond = threading.Condition(lock)
    quats = {s: np.full((n, 4), np.nan) for s in specs}
    covs = {s: np.full((n, 3, 3), np.nan) for s in specs}
    got = {s: 0 for s in specs}
    newest = {s: -1 for s in specs}
    rejected: dict[str, dict[str, int]] = {s: {} for s in specs}
    last_estimate: dict[str, dict] = {}

    def on_estimate(msg: dict) -> None:
        spec = by_vehicle.get(msg.get("vehicle"))
        if spec is None:
            return
        i = int(round((msg["t"] - t[0]) * rate))
        if not (0 <= i < n) or abs(msg["t"] - t[i]) > 1e-6:
            return
        q = msg["q"]
        cov = np.asarray(msg["cov"], dtype=float)[:3, :3]
        with cond:
            if np.isnan(quats[spec][i, 0]):
                got[spec] += 1
            quats[spec][i] = [q["w"], q["x"], q["y"], q["z"]]
            covs[spec][i] = cov
            newest[spec] = max(newest[spec], i)
            last_estimate[spec] = msg
            cond.notify_all()

    def on_rejected(msg: dict) -> None:
        key = msg.get("key", "")
        parts = key.split("/")
        vehicle = parts[-2] if len(parts) >= 2 else ""
        spec = by_vehicle.get(vehicle)
        if spec is None:
            return
        with cond:
            code = msg.get("code", "?")
            rejected[spec][code] = rejected[spec].get(code, 0) + 1
            cond.notify_all()

    # The estimates are queued by zenoh itself (a FIFO channel, no Python callback on zenoh's thread) and
    # drained by a thread of ours: a callback that waits for the interpreter while the main thread encodes
    # batches makes the service's publisher block, and zenoh closes a transport that stays blocked.
    estimate_subs = [
        client.session.declare_subscriber(client.key(v, "estimate"), zenoh.handlers.FifoChannel(1 << 18))
        for v in vehicles.values()
    ]
    stop = threading.Event()

    def drain() -> None:
        while not stop.is_set():
            idle = True
            for sub in estimate_subs:
                while True:
                    try:
                        sample = sub.try_recv()
                    except zenoh.ZError:  # closed: the session is going away
                        return
                    if sample is None:
                        break
                    idle = False
                    try:
                        on_estimate(json.loads(sample.payload.to_bytes()))
                    except (ValueError, KeyError, TypeError):
                        pass
            if idle:
                time.sleep(0.001)

    drainer = threading.Thread(target=drain, name="estimates", daemon=True)
    drainer.start()
    subs = [client.subscribe_rejections(on_rejected)]
    for spec, vehicle in vehicles.items():
        if getattr(args, "no_reset", False):
            break  # the vehicles run the filter the service's configuration gives them
        fields = reset_fields(spec.split("#")[0], args.particles)
        if getattr(args, "reset_t", None) is not None:
            fields["t"] = args.reset_t  # re-anchors the vehicle's time (a vehicle replayed again)
        client.reset(vehicle, **fields)
    time.sleep(0.2)  # let the subscriptions reach the service
    client.wait_listened()  # (and the service know of them: it puts estimates only while one matches)

    t0 = time.monotonic()
    sent = 0
    for start in range(0, n, args.batch):
        end = min(n, start + args.batch)
        batch = [(t[k], trial["gyr"][k], trial["acc"][k], trial["mag"][k]) for k in range(start, end)]
        for spec, vehicle in vehicles.items():
            # Flow control: wait until the estimates are within `window` samples of what is sent.
            deadline = time.monotonic() + args.timeout
            with cond:
                while start - (newest[spec] + 1) > args.window:
                    if not cond.wait(timeout=max(0.0, deadline - time.monotonic())):
                        raise SystemExit(
                            f"{spec}: no estimate progress for {args.timeout} s at sample {newest[spec]}"
                            f" (rejections {rejected[spec]})"
                        )
            client.publish_imu_batch(vehicle, batch)
        sent = end
        if pause > 0:
            time.sleep(pause)
    # Wait until every sample has its estimate; a refused sample never will, so also stop once the service has
    # processed or refused everything sent (its P/@/vehicles row) and no estimate came for `quiet` s since.
    # (Not on a pause in the estimates alone: on a busy machine the service may fall seconds behind, and
    # stopping then would count the tail it is still working on as lost.)
    quiet = 3.0

    def finished(vehicle: str) -> bool:
        try:
            row = next((r for r in client.vehicles(timeout=5.0) if r["vehicle"] == vehicle), None)
        except (TimeoutError, ValueError, KeyError):
            return False
        return row is not None and row["received"] >= sent and row["processed"] + row["rejected"] >= row["received"]

    for spec in specs:
        last_progress = last_check = time.monotonic()
        done_since = None
        while True:
            with cond:
                if newest[spec] >= sent - 1:
                    break
                before = got[spec]
                cond.wait(timeout=0.5)
                progressed = got[spec] != before
            now = time.monotonic()
            if progressed:
                last_progress = now
                done_since = None if done_since is None else now
            if now - last_progress > args.timeout:
                break
            if done_since is None and now - last_check >= 0.5:
                last_check = now
                if finished(vehicles[spec]):
                    done_since = now
            if done_since is not None and now - max(done_since, last_progress) >= quiet:
                break
    seconds = time.monotonic() - t0
    stop.set()
    drainer.join(timeout=5)
    for s in subs + estimate_subs:
        s.undeclare()
    out = {}
    for spec in specs:
        has = ~np.isnan(quats[spec][:, 0])
        first = int(np.argmax(has)) if has.any() else n
        diagnostics = last_estimate.get(spec, {}).get("diagnostics", {})
        out[spec] = {
            "quat": quats[spec],
            "cov_att": covs[spec],
            "vehicle": vehicles[spec],
            "estimates": got[spec],
            "aligning": first,
            "missing": int(n - first - has[first:].sum()),
            "rejected": rejected[spec],
            "seconds": seconds,
            # (Of this vehicle; with copies, all of them: `copies` times as many.)
            "samples_per_s": n / seconds if seconds > 0 else None,
            "imu_diagnostics": diagnostics.get("imu"),
        }
    return out


# ---------------------------------------------------------------------------------------------------
# Peers


def run_vqf(trial: dict) -> np.ndarray:
    from vqf import VQF

    return VQF(1.0 / trial["rate_hz"]).updateBatch(trial["gyr"], trial["acc"], trial["mag"])["quat9D"]


def run_madgwick(trial: dict) -> np.ndarray:
    """ahrs' Madgwick MARG filter. Its earth frame is North-West-Up (x to magnetic north, z up); rotated by +90°
    about up into East-North-Up."""
    from ahrs.filters import Madgwick

    q = Madgwick(
        gyr=trial["gyr"], acc=trial["acc"], mag=trial["mag"], frequency=trial["rate_hz"], gain=MADGWICK_BETA
    ).Q
    rz = np.array([np.cos(np.pi / 4), 0.0, 0.0, np.sin(np.pi / 4)])
    return quatmult(rz, q)


# ---------------------------------------------------------------------------------------------------


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("trial", type=Path, help="a BROAD trial (.hdf5), a recording with the same datasets, or a CSV "
                                              "trial (docs/recordings.md)")
    ap.add_argument("--connect", required=True, help="zenoh endpoint of the running service, e.g. tcp/127.0.0.1:7447")
    ap.add_argument("--prefix", default="attitude", help="the service's key prefix (default attitude)")
    ap.add_argument("--json", action="store_true", help="print one JSON object {estimator: {total_rmse_deg, ...}}")
    ap.add_argument("--filters", default="mekf,qpf:average",
                    help="comma-separated filters, one vehicle each (default mekf,qpf:average)")
    ap.add_argument("--particles", type=int,
                    help="particles of a qpf vehicle (default: the service's configured count)")
    ap.add_argument("--excerpt-seconds", type=float,
                    help="replay only the opening rest and this many seconds from the first movement sample")
    ap.add_argument("--batch", type=int, default=100,
                    help="samples per put on P/V/imu (default 100 = 0.35 s at 286 Hz; at most the service's "
                         "limits.max_batch and limits.max_payload_bytes, about 200 bytes a sample)")
    ap.add_argument("--window", type=int, default=2000,
                    help="most samples per vehicle sent ahead of its estimates (default 2000)")
    ap.add_argument("--timeout", type=float, default=60.0, help="longest wait without progress, s (default 60)")
    ap.add_argument("--vehicle-prefix", default="broad", help="vehicle ids are PREFIX-FILTER-TAG (default broad)")
    ap.add_argument("--tag", help="TAG of the vehicle ids (default: from the process id and the clock). A particle "
                                  "filter's seed derives from its vehicle id: a fixed tag on a fresh service "
                                  "repeats a run. Every replay needs vehicle ids new to the service (an id already used "
                                  "refuses the replay's times as old): give each trial its own tag")
    ap.add_argument("--copies", type=int, default=1,
                    help="feed the samples to this many vehicles per filter at once (ids ...-c2, -c3, ...): the "
                         "service's throughput with that many vehicles; the copies must agree exactly (default 1)")
    ap.add_argument("--pause", type=float, default=0.0,
                    help="seconds between batches (another arrival timing; the estimates must not change)")
    ap.add_argument("--no-peers", action="store_true", help="skip VQF and Madgwick")
    ap.add_argument("--cache", type=int, default=CACHE,
                    help=f"puts each input key keeps for the service to fetch again when one is lost (advanced "
                         f"publishers, default {CACHE})")
    ap.add_argument("--plain", action="store_true",
                    help="plain puts instead of advanced publishers (no recovery of a lost put)")
    ap.add_argument("--details", type=Path, help="write the run's particulars here (JSON)")
    ap.add_argument("--align-trim", type=float, default=0.0,
                    help="for a truth in its own frames (align: both): fit the alignment without this fraction of the "
                         "samples with the largest error, e.g. 0.1 (every sample is still scored; default 0, the fit "
                         "on every sample: docs/recordings.md)")
    args = ap.parse_args()
    if args.batch < 1 or args.window < args.batch or (args.particles is not None and args.particles < 1) or args.copies < 1 or args.pause < 0:
        ap.error("--batch must be ≥ 1, --window ≥ --batch, --particles ≥ 1, --copies ≥ 1, --pause ≥ 0")
    if not 0.0 <= args.align_trim < 0.5:
        ap.error("--align-trim must be a fraction in [0, 0.5)")
    args.reset_t = None

    trial = load_trial(args.trial, args.excerpt_seconds)
    trial["truth"] = truth_model({**trial["truth"], "align_trim": args.align_trim})
    if trial["opt_quat"] is None or trial["movement"] is None or not trial["movement"].any():
        raise SystemExit(f"{args.trial}: needs opt_quat and movement samples to score")
    specs = [s.strip() for s in args.filters.split(",") if s.strip()]

    with AttitudeClient(args.connect, prefix=args.prefix, timeout=10.0, recovery=not args.plain,
                        cache=args.cache) as client:
        client.wait_for_service(timeout=20.0)
        # One vehicle after the other: on a small machine a particle filter running beside the MEKF delays the
        # service's dispatch, and the two compete for the cores the timings measure.
        runs = {}
        for spec in specs:
            runs.update(replay(client, trial, [spec], args))
    # Copies of a vehicle got the same samples: they must have published the same estimates.
    copies = {spec: [runs.pop(key) for key in list(runs) if key.startswith(spec + "#")] for spec in specs}
    for spec in specs:
        others = copies[spec]
        same = all(
            np.array_equal(r["quat"], runs[spec]["quat"], equal_nan=True)
            and np.array_equal(r["cov_att"], runs[spec]["cov_att"], equal_nan=True)
            for r in others
        )
        if args.copies > 1:
            runs[spec]["copies"] = args.copies
            runs[spec]["copies_identical"] = same
            runs[spec]["samples_per_s_all_copies"] = runs[spec]["samples_per_s"] * args.copies
            runs[spec]["rejected_all_copies"] = sum(sum(r["rejected"].values()) for r in others) + sum(
                runs[spec]["rejected"].values())

    scores = {
        spec: broad_scores(run["quat"], run["cov_att"], trial["opt_quat"], trial["movement"], trial["truth"],
                           trial["gyr"])
        for spec, run in runs.items()
    }
    peer_seconds = {}
    if not args.no_peers:
        for name, fn in (("vqf", run_vqf), ("madgwick", run_madgwick)):
            t0 = time.perf_counter()
            q = fn(trial)
            peer_seconds[name] = time.perf_counter() - t0
            scores[name] = broad_scores(q, None, trial["opt_quat"], trial["movement"], trial["truth"])
    results = {name: {k: v for k, v in s.items() if k != "scored"} for name, s in scores.items()}

    if args.details:
        details = {
            "trial": trial["name"],
            "samples": len(trial["gyr"]),
            "rate_hz": trial["rate_hz"],
            "first_sample": trial["first_sample"],
            "t_s": [float(trial["t"][0]), float(trial["t"][-1])],
            "particles": args.particles,
            "batch": args.batch,
            "window": args.window,
            "service": {s: {k: v for k, v in r.items() if k not in ("quat", "cov_att")} for s, r in runs.items()},
            "scored": {name: s["scored"] for name, s in scores.items()},
            "peer_seconds": peer_seconds,
            "results": results,
            "attribution": ATTRIBUTION,
        }
        args.details.write_text(json.dumps(details, indent=2))

    for spec, run in runs.items():
        if run["rejected"] or run["missing"]:
            print(f"warning: {spec}: rejections {run['rejected']}, {run['missing']} samples without an estimate",
                  file=sys.stderr)
    if args.json:
        print(json.dumps(results))
        return 0
    print(f"{trial['name']}: {len(trial['gyr'])} samples at {trial['rate_hz']:.3f} Hz, "
          f"t = {trial['t'][0]:.2f}–{trial['t'][-1]:.2f} s")
    print(f"{'estimator':<14} {'total°':>8} {'heading°':>9} {'incl.°':>8} {'tilt in99':>10} {'NEES med.':>10} "
          f"{'hdg in99':>9} {'hdg off°':>9}   notes")
    for name, r in results.items():
        honesty = "".join(
            f" {r[k]:>{w}.{p}f}" if k in r else f" {'–':>{w}}"
            for k, w, p in (("tilt_in99", 10, 3), ("tilt_nees_median", 10, 2), ("heading_in99", 9, 3),
                            ("heading_offset_deg", 9, 2))
        )
        note = ""
        if name in runs:
            run = runs[name]
            note = f"through the service, {run['samples_per_s']:.0f} samples/s"
            if args.copies > 1:
                note += (f" per vehicle, {run['samples_per_s_all_copies']:.0f} for all {args.copies}"
                         f" (copies {'identical' if run['copies_identical'] else 'DIFFER'})")
            if name.startswith("qpf"):
                note += f", {args.particles or 'the service’s configured'} particles"
        print(f"{name:<14} {r['total_rmse_deg']:>8.2f} {r['heading_rmse_deg']:>9.2f} "
              f"{r['inclination_rmse_deg']:>8.2f}{honesty}   {note}")
    print(f"BROAD RMSE over `movement` (broad_utils.calculateRMSE, alignment: {trial['truth']['align']}); honesty as "
          "crates/attitude-lab/src/study/broad.rs. " + ATTRIBUTION)
    return 0


if __name__ == "__main__":
    sys.exit(main())
